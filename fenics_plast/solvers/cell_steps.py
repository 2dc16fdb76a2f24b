"""The explicit solver's time step per cell and selective mass scaling (a part of
:class:`~fenics_plast.solvers.explicit.ExplicitDynamics`, which inherits :class:`CellSteps`).

* The stable step of each cell on the deformed mesh: the size estimate h / c (quadrilaterals: the
  smallest edge or altitude; hexahedra: kappa V / A_max, :mod:`fenics_plast.solvers.hex_step`) and,
  with ``stable_step = "element"``, the element's own step 2 / omega_max where it is larger
  (quadrilaterals) or where it is computed (hexahedra); the minimum over the cells and the ranks,
  combined with the contact springs' limit (:meth:`CellSteps.stable_dt`).
* Selective mass scaling (:meth:`CellSteps.scale_mass`, :meth:`CellSteps.mass_scaling_stats`).
* What element erosion has removed (:meth:`CellSteps.erosion_stats`, :meth:`CellSteps.eroded_cells`):
  the compiled force pass erodes the cells (``alive``); an eroded cell sets no stable step.

``CellSteps`` reads the solver's attributes set in ``ExplicitDynamics.__init__``: the mesh data
(``_X``, ``_cell_nodes``, ``_cell_dofs``, ``geometry``, ``three_d``, ``kin``, ``element``), the
material and densities (``material``, ``density``, ``regions``, ``c``, ``_cell_c``), the nodal
vectors (``u``, ``v``, ``a``, ``f``, ``mass``, ``minv``, ``free_minv``, ``fixed``), ``contact``,
``drivers`` and the MPI helpers (``comm``, ``_reduce``). Lengths mm, times s, masses tonne, moduli MPa.
"""
from __future__ import annotations

import math

import numpy as np
from dolfinx import fem
from mpi4py import MPI

from fenics_plast import dolfinx_compat as dc
from fenics_plast.solvers import hex_step, quad_step


class CellSteps:
    """Per-cell stable steps and selective mass scaling of the explicit solver (see the module doc)."""

    def _size_dt(self):
        """The size estimate of each owned cell's stable step on the current (deformed) mesh [s]:
        sqrt(s) h / c, h the cell's smallest edge or altitude (hexahedra: kappa V / A_max, see
        :mod:`~fenics_plast.solvers.hex_step`), c its material's dilatational wave speed, s its
        mass-scaling density factor (1 without); inf for an eroded cell. A work buffer, overwritten by
        the next call; ``self._xbuf`` holds the current node positions afterwards."""
        np.add(self._X, self.u.x.array.reshape(-1, self.bs), out=self._xbuf)
        if self.three_d:        # kappa V / A_max (hex_step.py: kappa, the cube's breathing mode)
            h = hex_step.hex_size(self._xbuf, self._cell_dofs, self._hbuf)
            np.multiply(h, self._hex_kappa, out=h)
        else:
            h = quad_step.quad_size(self._xbuf, self._cell_dofs, self._hbuf)
        np.divide(h, self.c if self._cell_c is None else self._cell_c, out=h)
        if self.mass_scaled:
            np.multiply(h, self._sqrt_scale, out=h)
        if self.erosion_ratio > 0.0:
            h[self.alive == 0] = np.inf
        return h

    def _eig_dt(self, cells):
        """2 / omega_max of the elastic elements of ``cells`` (owned indices) in their current shape,
        with their (scaled) share of the lumped mass [s] (:func:`quad_step.quad_eig_dt`);
        call after :meth:`_size_dt` (node positions)."""
        cells = np.ascontiguousarray(cells, dtype=np.int64)
        if self.three_d:
            out = hex_step.hex_eig_dt(self._xbuf, self._cell_dofs, cells, self._mass_cyc, self._lam_c, self._mu_c,
                                      self.element == "q1p0")
            return out * self._sqrt_scale[cells]
        out = quad_step.quad_eig_dt(self._xbuf, self._cell_dofs, cells, self._mass_cyc, self._lam_c, self._mu_c,
                                    self.kin.axisymmetric, self.element == "q1p0", np.empty(cells.size))
        return out * self._sqrt_scale[cells]

    def cell_dt(self, below=math.inf):
        """Stable step of each owned cell [s] (a new array): stable_step "size": the size estimate
        sqrt(s) h / c (:meth:`_size_dt`); "element": the larger of that and the cell's elastic element
        step 2 / omega_max (:meth:`_eig_dt`), the latter computed for the cells whose size estimate is
        below ``below`` (the others get their size estimate, a lower bound). See :meth:`stable_dt`."""
        d = self._size_dt().copy()
        cand = np.flatnonzero(d < below) if self.stable_step == "element" else ()
        if len(cand):
            d[cand] = np.maximum(d[cand], self._eig_dt(cand))
        return d

    def _local_min_dt(self):
        """(min over the owned cells of :meth:`cell_dt`, its cell index or -1): the element step is
        computed only for the cells whose size estimate is below the minimum found (few)."""
        d = self._size_dt()
        if not d.size:
            return math.inf, -1
        if self.stable_step == "size":
            i = int(np.argmin(d))
            return float(d[i]), i
        if self.three_d:
            best, arg = hex_step.hex_lazy_min(d, self._xbuf, self._cell_dofs, self._mass_cyc, self._lam_c,
                                              self._mu_c, self._sqrt_scale, self.element == "q1p0")
            return float(best), int(arg)
        best, arg = quad_step.quad_lazy_min(d, np.argsort(d), self._xbuf, self._cell_dofs, self._mass_cyc,
                                            self._lam_c, self._mu_c, self._sqrt_scale, self.kin.axisymmetric,
                                            self.element == "q1p0")
        return float(best), int(arg)

    def stable_dt(self):
        """The stable step [s] on the current (deformed) mesh: the minimum over the cells of
        :meth:`cell_dt`. stable_step "size": sqrt(s) h / c, h the cell's smallest edge or
        altitude, c the wave speed of its material, s its mass-scaling density factor (1 without).
        "element" (the default): max(sqrt(s) h / c, 2 / omega_max), omega_max the largest frequency
        of the cell's elastic element with its share of the lumped mass (exact for the elastic element, and the
        assembled mesh's omega_max is at most the largest element value, Irons). The size estimate
        collapses on a cell with a corner near 180 degrees (the altitude of the vertex there tends
        to 0 while the cell is a sound triangle: 0.12 ns against 4.9 ns for the element's own step
        in the 400 m/s Taylor bar at 25 us); with "element" the element's step is taken where it is
        larger, computed only for the few cells whose size estimate is below the minimum found
        (:func:`quad_step.quad_lazy_min`): where the smallest size estimate is at or below its
        cell's element step, the result is the size estimate's. With contact pairs combined with the
        smallest penalty-spring limit dt_c = min 2 sqrt(m_i / (eps A_i)) of the contact nodes as
        1 / sqrt(1 / dt^2 + 1 / dt_c^2) (explicit_contact.py). Collective."""
        dt = self._reduce(self._local_min_dt()[0], MPI.MIN)
        if not self.contact.pairs:
            return dt
        dtc = self.contact.dt_stable
        return 1.0 / math.sqrt(1.0 / dt ** 2 + 1.0 / dtc ** 2)

    def _limit_text(self, dt):
        """What sets the stable step dt [s], for messages."""
        if self._cell_c is None:
            return f"smallest element {dt * self.c:.4g} mm, wave speed {self.c / 1e3:.4g} m/s"
        return f"smallest transit time h/c of a cell, wave speeds up to {self.c / 1e3:.4g} m/s"

    # -- selective mass scaling and the time-step floor ---------------------------------------
    def _setup_cell_masses(self):
        """Each owned cell's share m_ca = int_cell rho N_a w dV of the lumped mass of its nodes (4, or 8 on hexahedra)
        [tonne] (basix order ``_cell_mass``, cyclic order ``_mass_cyc``) and its Lame constants
        (``_lam_c``, ``_mu_c`` [MPa]): the element steps and mass scaling."""
        nc = self.n_cells_own
        if self.regions:
            rho = self.material.per_cell(self.density)
            self._lam_c = np.ascontiguousarray(self.material.per_cell([m.lame[0] for m in self.material.materials]),
                                               dtype=float)
            self._mu_c = np.ascontiguousarray(self.material.per_cell([m.lame[1] for m in self.material.materials]),
                                              dtype=float)
        else:
            rho = np.full(nc, self.density)
            lm, mu = self.material.lame
            self._lam_c, self._mu_c = np.full(nc, float(lm)), np.full(nc, float(mu))
        self._cell_mass = rho[:, None] * np.einsum("qa,cq->ca", self.geometry.N, self.geometry.W)
        if self.three_d:        # (8 nodes, basix order) and the size estimate's factor per cell
            self._mass_cyc = self._cell_mass
            self._hex_kappa = hex_step.size_factor(self._lam_c, self._mu_c)
        else:
            self._mass_cyc = np.ascontiguousarray(self._cell_mass[:, quad_step.QUAD_CYCLE])
        self._sqrt_scale = np.ones(nc)

    def scale_mass(self, target):
        """Selective mass scaling to the stable step ``target`` [s] (collective; called by :meth:`run`
        at every step-size check when ``mass_scaling_dt`` is set).

        Every owned cell whose stable step dt_c (:meth:`cell_dt`) is below ``target`` gets its density
        factor raised so that its step becomes ``target``: s_c <- s_c (target / dt_c)^2 (dt_c grows as
        sqrt(s_c)); its nodes (4 or 8) get the mass (s_new - s_old) m_ca, m_ca the cell's share of node a's
        lumped mass, assembled over the ranks. Mass is never removed. The added mass takes the node's
        current velocity: the kinetic energy 1/2 dm v^2 it brings is accumulated in ``E_mass``, a term
        of the energy balance (:meth:`energies`). The acceleration of the changed dofs is recomputed
        with the new mass; the contact springs' step limit too. Returns the number of cells scaled
        now (all ranks)."""
        dtc = self.cell_dt(below=target)
        low = np.flatnonzero(dtc < target * (1.0 - 1e-12))     # (a scaled cell is at the target to round-off)
        n_low = self._reduce(int(low.size), MPI.SUM)
        if n_low == 0:
            return 0
        if not hasattr(self, "_dm"):
            self._dm = fem.Function(self.V, name="added_mass")
        ratio = target / dtc[low]
        old = self.cell_scale[low]
        new = old * ratio * ratio
        self.cell_scale[low] = new
        self._sqrt_scale[low] = np.sqrt(new)
        self.mass_scaled = True
        bs, n = self.bs, self.n_own
        add = self._dm.x.array
        add[:] = 0.0
        nodes = add.reshape(-1, bs)
        col = np.zeros(nodes.shape[0])
        np.add.at(col, self._cell_nodes[low].reshape(-1), ((new - old)[:, None] * self._cell_mass[low]).reshape(-1))
        nodes[:] = col[:, None]
        if self.comm.size > 1:
            dc.scatter_reverse_add(self._dm)
        dm = add[:n]
        ch = np.flatnonzero(dm > 0.0)
        v = self.v.x.array[ch]
        self.E_mass += 0.5 * float(np.dot(dm[ch] * v, v))
        self.mass[ch] += dm[ch]
        self.minv[ch] = 1.0 / self.mass[ch]
        self.free_minv[ch] = self.minv[ch]
        self.free_minv[self.fixed] = 0.0
        if self.has_drivers:
            d = self.drivers
            self.free_minv[d.pdofs] = 0.0
            self.a[ch] = (d.fload[ch] + d.fcon[ch] - self.f[ch]) * self.free_minv[ch]
        else:
            self.a[ch] = -self.f[ch] * self.free_minv[ch]
        if self.contact.pairs:
            self.contact.mass_changed()
        return n_low

    def mass_scaling_stats(self):
        """What mass scaling has added so far (collective): added_mass, body_mass [tonne; in plane
        strain per mm of depth], fraction (added / body), cells (cells with a factor > 1),
        max_factor (largest density factor), kinetic (kinetic energy of the added mass now,
        1/2 sum dm v^2) and energy (the kinetic energy it brought in, ``E_mass``) [N mm]."""
        bs, n = self.bs, self.n_own
        dm = self.mass - self.mass0
        v = self.v.x.array[:n]
        loc = np.array([float(dm[0::bs].sum()), float(self.mass0[0::bs].sum()),
                        float(np.count_nonzero(self.cell_scale > 1.0)), 0.5 * float(np.dot(dm * v, v)), self.E_mass])
        tot = self.comm.allreduce(loc, op=MPI.SUM) if self.comm.size > 1 else loc
        smax = self._reduce(float(self.cell_scale.max()) if self.cell_scale.size else 1.0, MPI.MAX)
        return dict(added_mass=float(tot[0]), body_mass=float(tot[1]), fraction=float(tot[0] / tot[1]),
                    cells=int(round(tot[2])), max_factor=smax, kinetic=float(tot[3]), energy=float(tot[4]))

    # -- element erosion --------------------------------------------------------------------------
    def erosion_stats(self):
        """What element erosion has removed so far (collective): cells (eroded cells), volume_fraction
        (their reference volume over the body's) and mass_fraction (their share of the unscaled lumped
        mass over the body's)."""
        dead = self.alive == 0
        loc = np.array([float(np.count_nonzero(dead)), float(self.geometry.W[dead].sum()),
                        float(self.geometry.W.sum()), float(self._cell_mass[dead].sum()),
                        float(self._cell_mass.sum())])
        tot = self.comm.allreduce(loc, op=MPI.SUM) if self.comm.size > 1 else loc
        return dict(cells=int(round(tot[0])), volume_fraction=float(tot[1] / tot[2]),
                    mass_fraction=float(tot[3] / tot[4]))

    def eroded_cells(self):
        """[(original cell index, reference centre [mm])] of the eroded cells, all ranks (collective)."""
        loc = [(int(self.mesh.topology.original_cell_index[i]), self._X[self._cell_dofs[i]].mean(axis=0).tolist())
               for i in np.flatnonzero(self.alive == 0)]
        return sorted(c for part in (self.comm.allgather(loc) if self.comm.size > 1 else [loc]) for c in part)
