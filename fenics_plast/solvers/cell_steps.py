"""The explicit solver's time step per cell and selective mass scaling: :class:`CellSteps`, a collaborator
that :class:`~fenics_plast.solvers.explicit.ExplicitDynamics` builds (``solver.cell_steps``) from the data
it needs, passed explicitly.

* The stable step of each cell on the deformed mesh: the size estimate h / c (quadrilaterals: the
  smallest edge or altitude; hexahedra: kappa V / A_max, :mod:`fenics_plast.solvers.hex_step`) and,
  with ``stable_step = "element"``, the element's own step 2 / omega_max where it is larger
  (quadrilaterals) or where it is computed (hexahedra); the minimum over the cells and the ranks
  (:meth:`CellSteps.stable_dt`; the solver combines it with the contact springs' limit).
* Selective mass scaling (:meth:`CellSteps.scale_mass`, :meth:`CellSteps.mass_scaling_stats`): the
  cells' density factors, the nodal mass they add and the kinetic energy it brings in; the solver
  updates its accelerations and contact springs from the dofs whose mass changed.
* What element erosion has removed (:meth:`CellSteps.erosion_stats`, :meth:`CellSteps.eroded_cells`):
  the compiled force pass erodes the cells (the solver's ``alive``); an eroded cell sets no stable step.

The data (:class:`CellSteps`' parameters): reference node positions and the current displacement,
the cells' nodes, the element kind, wave speeds, each cell's share of its nodes' lumped mass and its
Lame constants (:func:`cell_masses`), the nodal mass and velocity, the erosion flags and the MPI
communicator. Lengths mm, times s, masses tonne, moduli MPa.
"""
from __future__ import annotations

import math

import numpy as np
from dolfinx import fem
from mpi4py import MPI

from fenics_plast import dolfinx_compat as dc
from fenics_plast.solvers import hex_step, quad_step


def cell_masses(material, density, regions, N, W):
    """(m, lam, mu): each owned cell's share m_ca = int_cell rho N_a w dV of the lumped mass of its nodes
    (nc, 4) or (nc, 8) [tonne] (basix order) and its Lame constants lam, mu (nc,) [MPa]. ``material``:
    a ``Material`` or (``regions`` True) a ``MaterialRegions`` with ``density`` one per material
    [tonne/mm^3]; N (nq, nv) shape functions at the quadrature points, W (nc, nq) the cells' weights
    w |det J0| q_w [mm^3]."""
    nc = W.shape[0]
    if regions:
        rho = material.per_cell(density)
        lam = np.ascontiguousarray(material.per_cell([m.lame[0] for m in material.materials]), dtype=float)
        mu = np.ascontiguousarray(material.per_cell([m.lame[1] for m in material.materials]), dtype=float)
    else:
        rho = np.full(nc, density)
        lm, mu = material.lame
        lam, mu = np.full(nc, float(lm)), np.full(nc, float(mu))
    return rho[:, None] * np.einsum("qa,cq->ca", N, W), lam, mu


class CellSteps:
    """Per-cell stable steps, selective mass scaling and erosion statistics of the explicit solver (see the
    module doc).

    Parameters
    ----------
    X : (n_nodes, gdim) reference positions of the owned + ghost nodes [mm].
    u : (gdim n_nodes,) the displacement's array (owned + ghost, unrolled) [mm], read at each call.
    cell_nodes : (nc, 4) or (nc, 8) int64, the owned cells' nodes (basix order).
    three_d, axisymmetric : the geometry (hexahedra; quadrilaterals with weight 2 pi r).
    fbar : the element is "q1p0" (the element step of the F-bar element).
    stable_step : "element" or "size" (see :meth:`stable_dt`).
    wave_speed : the dilatational wave speed c [mm/s] (several materials: the fastest one).
    cell_wave_speeds : (nc,) each cell's wave speed [mm/s] (several materials) or None (one material).
    cell_mass, lam, mu : :func:`cell_masses`.
    W : (nc, nq) the cells' reference quadrature weights [mm^3] (erosion statistics).
    alive : (nc,) uint8, 0 for an eroded cell (the solver's array, read at each call).
    erosion_ratio : > 0 when element erosion is on.
    mass, v : the solver's nodal mass (n_own,) [tonne] (mass scaling adds to it in place) and velocity
        array (owned + ghost) [mm/s].
    V : the vector function space (assembly of the added mass over the ranks).
    cell_index : (nc,) the cells' indices in the mesh file (``original_cell_index``).
    comm : the mesh's communicator.
    """

    def __init__(self, X, u, cell_nodes, three_d, axisymmetric, fbar, stable_step, wave_speed, cell_wave_speeds,
                 cell_mass, lam, mu, W, alive, erosion_ratio, mass, v, V, cell_index, comm):
        self.X = X
        self.three_d, self.axisymmetric, self.fbar = three_d, axisymmetric, fbar
        self.bs = X.shape[1]
        self._u = u.reshape(-1, self.bs)
        self.cell_nodes = cell_nodes                                 # basix order
        # quadrilaterals: cyclic vertex order (size, element step); hexahedra: basix order
        self.cell_dofs = cell_nodes if three_d else np.ascontiguousarray(cell_nodes[:, quad_step.QUAD_CYCLE])
        self._xbuf = np.empty_like(X)
        self._hbuf = np.empty(cell_nodes.shape[0])
        self.stable_step = stable_step
        self.c, self._cell_c = wave_speed, cell_wave_speeds
        self.cell_mass, self._lam_c, self._mu_c = cell_mass, lam, mu
        if three_d:        # (8 nodes, basix order) and the size estimate's factor per cell
            self._mass_cyc = cell_mass
            self._hex_kappa = hex_step.size_factor(lam, mu)
        else:
            self._mass_cyc = np.ascontiguousarray(cell_mass[:, quad_step.QUAD_CYCLE])
        self._W = W
        self.alive, self.erosion_ratio = alive, erosion_ratio
        self.cell_index = cell_index
        self.comm = comm
        # selective mass scaling: the unscaled nodal mass, each owned cell's density factor (>= 1) and its
        # square root, the kinetic energy the added mass brought in [N mm] (local accumulator);
        # mass_scaled: some cell of some rank has been scaled (the same on every rank)
        self.mass, self.mass0, self._v, self._V = mass, mass.copy(), v, V
        self.n_own = mass.size
        self.cell_scale = np.ones(cell_nodes.shape[0])
        self._sqrt_scale = np.ones(cell_nodes.shape[0])
        self.E_mass = 0.0
        self.mass_scaled = False
        self._dm = None

    def _reduce(self, x, op):
        """Global reduction of a float (no MPI call in serial)."""
        return x if self.comm.size == 1 else self.comm.allreduce(x, op=op)

    def size_dt(self):
        """The size estimate of each owned cell's stable step on the current (deformed) mesh [s]:
        sqrt(s) h / c, h the cell's smallest edge or altitude (hexahedra: kappa V / A_max, see
        :mod:`~fenics_plast.solvers.hex_step`), c its material's dilatational wave speed, s its
        mass-scaling density factor (1 without); inf for an eroded cell. A work buffer (nc,), overwritten
        by the next call."""
        np.add(self.X, self._u, out=self._xbuf)
        if self.three_d:        # kappa V / A_max (hex_step.py: kappa, the cube's breathing mode)
            h = hex_step.hex_size(self._xbuf, self.cell_dofs, self._hbuf)
            np.multiply(h, self._hex_kappa, out=h)
        else:
            h = quad_step.quad_size(self._xbuf, self.cell_dofs, self._hbuf)
        np.divide(h, self.c if self._cell_c is None else self._cell_c, out=h)
        if self.mass_scaled:
            np.multiply(h, self._sqrt_scale, out=h)
        if self.erosion_ratio > 0.0:
            h[self.alive == 0] = np.inf
        return h

    def element_dt(self, cells):
        """2 / omega_max of the elastic elements of ``cells`` (owned indices) in their current shape,
        with their (scaled) share of the lumped mass [s] (:func:`quad_step.quad_eig_dt`,
        :func:`hex_step.hex_eig_dt`); call after :meth:`size_dt` (node positions)."""
        cells = np.ascontiguousarray(cells, dtype=np.int64)
        if self.three_d:
            out = hex_step.hex_eig_dt(self._xbuf, self.cell_dofs, cells, self._mass_cyc, self._lam_c, self._mu_c,
                                      self.fbar)
            return out * self._sqrt_scale[cells]
        out = quad_step.quad_eig_dt(self._xbuf, self.cell_dofs, cells, self._mass_cyc, self._lam_c, self._mu_c,
                                    self.axisymmetric, self.fbar, np.empty(cells.size))
        return out * self._sqrt_scale[cells]

    def cell_dt(self, below=math.inf):
        """Stable step of each owned cell [s] (a new array): stable_step "size": the size estimate
        sqrt(s) h / c (:meth:`size_dt`); "element": the larger of that and the cell's elastic element
        step 2 / omega_max (:meth:`element_dt`), the latter computed for the cells whose size estimate is
        below ``below`` (the others get their size estimate, a lower bound). See :meth:`stable_dt`."""
        d = self.size_dt().copy()
        cand = np.flatnonzero(d < below) if self.stable_step == "element" else ()
        if len(cand):
            d[cand] = np.maximum(d[cand], self.element_dt(cand))
        return d

    def local_min_dt(self):
        """(min over the owned cells of :meth:`cell_dt`, its cell index or -1), rank-local: the element
        step is computed only for the cells whose size estimate is below the minimum found (few)."""
        d = self.size_dt()
        if not d.size:
            return math.inf, -1
        if self.stable_step == "size":
            i = int(np.argmin(d))
            return float(d[i]), i
        if self.three_d:
            best, arg = hex_step.hex_lazy_min(d, self._xbuf, self.cell_dofs, self._mass_cyc, self._lam_c,
                                              self._mu_c, self._sqrt_scale, self.fbar)
            return float(best), int(arg)
        best, arg = quad_step.quad_lazy_min(d, np.argsort(d), self._xbuf, self.cell_dofs, self._mass_cyc,
                                            self._lam_c, self._mu_c, self._sqrt_scale, self.axisymmetric,
                                            self.fbar)
        return float(best), int(arg)

    def stable_dt(self):
        """The cells' stable step [s] on the current (deformed) mesh: the minimum over the cells and the
        ranks of :meth:`cell_dt`. stable_step "size": sqrt(s) h / c, h the cell's smallest edge or
        altitude, c the wave speed of its material, s its mass-scaling density factor (1 without).
        "element" (the default): max(sqrt(s) h / c, 2 / omega_max), omega_max the largest frequency
        of the cell's elastic element with its share of the lumped mass (exact for the elastic element, and the
        assembled mesh's omega_max is at most the largest element value, Irons). The size estimate
        collapses on a cell with a corner near 180 degrees (the altitude of the vertex there tends
        to 0 while the cell is a sound triangle: 0.12 ns against 4.9 ns for the element's own step
        in the 400 m/s Taylor bar at 25 us); with "element" the element's step is taken where it is
        larger, computed only for the few cells whose size estimate is below the minimum found
        (:func:`quad_step.quad_lazy_min`): where the smallest size estimate is at or below its
        cell's element step, the result is the size estimate's. Collective. (The solver's
        ``stable_dt`` combines it with the contact springs' limit.)"""
        return self._reduce(self.local_min_dt()[0], MPI.MIN)

    def limit_text(self, dt):
        """What sets the stable step dt [s], for messages."""
        if self._cell_c is None:
            return f"smallest element {dt * self.c:.4g} mm, wave speed {self.c / 1e3:.4g} m/s"
        return f"smallest transit time h/c of a cell, wave speeds up to {self.c / 1e3:.4g} m/s"

    def corners(self, i):
        """(current, reference) positions (nv, gdim) [mm] of owned cell i's nodes (quadrilaterals: cyclic
        order; hexahedra: basix order), new arrays."""
        idx = self.cell_dofs[i]
        return self.X[idx] + self._u[idx], self.X[idx]

    def centre(self, i):
        """(index in the mesh file, reference vertex mean [mm] as a list) of owned cell i."""
        return int(self.cell_index[i]), self.X[self.cell_dofs[i]].mean(axis=0).tolist()

    # -- selective mass scaling ---------------------------------------------------------------
    def scale_mass(self, target):
        """Selective mass scaling to the stable step ``target`` [s] (collective). Every owned cell whose
        stable step dt_c (:meth:`cell_dt`) is below ``target`` gets its density factor raised so that its
        step becomes ``target``: s_c <- s_c (target / dt_c)^2 (dt_c grows as sqrt(s_c)); its nodes (4 or 8)
        get the mass (s_new - s_old) m_ca, m_ca the cell's share of node a's lumped mass, assembled over
        the ranks, added to ``mass`` in place. Mass is never removed. The added mass takes the node's
        current velocity: the kinetic energy 1/2 dm v^2 it brings is accumulated in ``E_mass``.
        Returns (the number of cells scaled now, all ranks; the owned dofs whose mass changed, or None
        when no cell was scaled): the solver updates their inverse mass and acceleration."""
        dtc = self.cell_dt(below=target)
        low = np.flatnonzero(dtc < target * (1.0 - 1e-12))     # (a scaled cell is at the target to round-off)
        n_low = self._reduce(int(low.size), MPI.SUM)
        if n_low == 0:
            return 0, None
        if self._dm is None:
            self._dm = fem.Function(self._V, name="added_mass")
        ratio = target / dtc[low]
        old = self.cell_scale[low]
        new = old * ratio * ratio
        self.cell_scale[low] = new
        self._sqrt_scale[low] = np.sqrt(new)
        self.mass_scaled = True
        add = self._dm.x.array
        add[:] = 0.0
        nodes = add.reshape(-1, self.bs)
        col = np.zeros(nodes.shape[0])
        np.add.at(col, self.cell_nodes[low].reshape(-1), ((new - old)[:, None] * self.cell_mass[low]).reshape(-1))
        nodes[:] = col[:, None]
        if self.comm.size > 1:
            dc.scatter_reverse_add(self._dm)
        dm = add[: self.n_own]
        ch = np.flatnonzero(dm > 0.0)
        v = self._v[ch]
        self.E_mass += 0.5 * float(np.dot(dm[ch] * v, v))
        self.mass[ch] += dm[ch]
        return n_low, ch

    def restore_scaling(self, mass, cell_scale, E_mass):
        """Set the scaled nodal mass (n_own,) [tonne], the cells' density factors (nc,) and this rank's
        share of ``E_mass`` [N mm] of a checkpoint."""
        self.mass[:] = mass
        self.cell_scale[:] = cell_scale
        self._sqrt_scale = np.sqrt(self.cell_scale)
        self.mass_scaled = True
        self.E_mass = E_mass

    def mass_scaling_stats(self):
        """What mass scaling has added so far (collective): added_mass, body_mass [tonne; in plane
        strain per mm of depth], fraction (added / body), cells (cells with a factor > 1),
        max_factor (largest density factor), kinetic (kinetic energy of the added mass now,
        1/2 sum dm v^2) and energy (the kinetic energy it brought in, ``E_mass``) [N mm]."""
        bs, n = self.bs, self.n_own
        dm = self.mass - self.mass0
        v = self._v[:n]
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
        loc = np.array([float(np.count_nonzero(dead)), float(self._W[dead].sum()),
                        float(self._W.sum()), float(self.cell_mass[dead].sum()),
                        float(self.cell_mass.sum())])
        tot = self.comm.allreduce(loc, op=MPI.SUM) if self.comm.size > 1 else loc
        return dict(cells=int(round(tot[0])), volume_fraction=float(tot[1] / tot[2]),
                    mass_fraction=float(tot[3] / tot[4]))

    def eroded_cells(self):
        """[(original cell index, reference centre [mm])] of the eroded cells, all ranks (collective)."""
        loc = [self.centre(i) for i in np.flatnonzero(self.alive == 0)]
        return sorted(c for part in (self.comm.allgather(loc) if self.comm.size > 1 else [loc]) for c in part)
