"""Quadrature-point data and the update/commit cycle around a material.

``QuadratureMap`` evaluates a UFL expression of the incremental deformation gradient Fu at the
quadrature points of the owned cells (one compiled ``fem.Expression``), runs
``material.update_into`` from the COMMITTED state (binv, eqps, and the temperature of Johnson-Cook
materials), and writes the Kirchhoff stress tau (and the spatial tangent a) into quadrature
Functions used by the forms. The tangent is stored as a 9x9 tensor per point, a[3i+j, 3k+l] = a_ijkl (basix 0.5 has no rank-4 tensor elements); ``a_values`` is (n,3,3,3,3).
The trial state is kept until ``commit()``; nothing is needed to restore since every update
starts from the committed state. Points are numbered cell-major over the owned cells (point
p = c nq + q of owned cell c), the numbering a ``MaterialRegions`` (several materials) relies on.

State: every variable of :data:`fenics_plast.state_variables.STATE` is an attribute, committed
(``binv`` (n,3,3), ``eqps`` (n,), ``temperature`` (n,) [K]) and trial (``binv_trial``, ...), allocated
with its initial values; ``variables`` holds those of this material (``state_variables.present``), the
ones :meth:`commit`, :meth:`state` / :meth:`set_state` (checkpoints) and :meth:`fields` (cell-mean
output) iterate over. Temperature: the state of Johnson-Cook materials, their initial temperature at
the start (0 at points of materials without one; ``thermal`` says whether any material has one).
``dt`` (a (1,) array, [s]): the time increment of the update (plastic strain rate, adiabatic heating),
set by the explicit solver before each step; it stays 0 in static analyses (the static convention:
no rate term, no heating).

Never write a quadrature Function to XDMF (segfaults in dolfinx 0.5.2): use ``cell_mean``.
"""
from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem

from fenics_plast import dolfinx_compat as dc
from fenics_plast.state_variables import STATE, present


class MaterialUpdateError(RuntimeError):
    """Non-finite values from the material update."""


class QuadratureMap:
    def __init__(self, mesh, kin, material, Fu_expr, degree=2, tangent=True):
        self.mesh = mesh
        self.kin = kin
        self.material = material
        self.degree = degree
        self.has_tangent = bool(tangent)
        cell = mesh.ufl_cell()
        self.points, self.weights = dc.quadrature_rule(cell.cellname(), degree)
        self.nq = len(self.weights)
        tdim = mesh.topology.dim
        imap = mesh.topology.index_map(tdim)
        self.n_owned = imap.size_local
        self.cells = np.arange(self.n_owned, dtype=np.int32)
        self.n = self.n_owned * self.nq          # owned quadrature points
        n_cells = getattr(material, "n_cells", self.n_owned)    # MaterialRegions: cells it was built for
        if n_cells != self.n_owned:
            raise ValueError(f"the material's regions cover {n_cells} cells, the mesh has {self.n_owned} owned cells")

        self.QT = dc.quadrature_space(mesh, degree, (3, 3))
        self.tau = fem.Function(self.QT, name="tau")
        if self.has_tangent:
            self.QA = dc.quadrature_space(mesh, degree, (9, 9))
            self.a = fem.Function(self.QA, name="tangent")
        else:
            self.QA, self.a = None, None

        # qp dofmaps: trivial (dof = cell*nq + q) on the owned cells? Checked per space: the
        # numbering of spaces with different block sizes need not agree in parallel.
        def owned_blocks(space):
            return np.asarray(dc.cell_dofs(space)[: self.n_owned].reshape(-1))
        self._qdofs = owned_blocks(self.QT)      # block index of each owned qp
        self._qdofs_a = owned_blocks(self.QA) if self.has_tangent else self._qdofs
        arange = np.arange(self.n)
        self.trivial_tau = bool(np.array_equal(self._qdofs, arange))
        self.trivial_a = bool(np.array_equal(self._qdofs_a, arange))

        # compiled expression of Fu and its buffer (None: the caller computes Fu itself and only uses
        # the state arrays, e.g. the explicit solver's fused pass)
        self.Fu_expr = None if Fu_expr is None else fem.Expression(Fu_expr, self.points)
        self._Fu = np.zeros((self.n_owned, self.nq * 9))

        # committed and trial state: every declared variable (the kernels take them all); ``variables``
        # those of this material, the ones committed, checkpointed and written. All committed arrays, then
        # the trial copies: the heap layout (array alignment) moves the last bit of BLAS dot products (the
        # elastic energy); this order gives earlier versions' outputs bit for bit (measured with address
        # randomisation off, setarch -R; one variable's pair after the other's did not)
        for v in STATE:
            setattr(self, v.name, initial_values(v, material, self.n))
        for v in STATE:
            setattr(self, v.name + "_trial", getattr(self, v.name).copy())
        self.variables = present(material)
        self.thermal = bool(getattr(material, "thermal", False))
        self.dt = np.zeros(1)                    # time increment of the update [s]; 0: no physical time
        #: (n,) or None: the factor 1 / (the increment's isotropic thermal stretch) each point's F_u takes
        #: (:mod:`fenics_plast.thermal.build`: theta_n / theta_n+1); None: no thermal expansion
        self.stretch = None
        #: (n,) or None: J_theta, the thermal volume ratio of the stress-free state to the first mesh's
        #: reference, by which the material's Kirchhoff stress (per stress-free volume, tau = J_e sigma) and
        #: tangent are scaled to the reference's (tau = J sigma, J = J_e J_theta): the solver's; None: 1
        self.volume_scale = None
        #: (n,) or None: J_ref, the volume ratio dv_ref / dV_0 of this mesh's reference to the first mesh's (a
        #: remeshed body's reference is a deformed shape, :func:`fenics_plast.runner_static_remesh.remeshed`): the
        #: solver's Cauchy stress is tau / (J_ref theta), theta = det Fbar from this reference, so tau and the
        #: tangent are divided by it; None: 1 (the first mesh)
        self.reference_volume = None
        # trivial dofmap: the material writes straight into the Functions' arrays (views)
        self.tau_values = (self.tau.x.array[: self.n * 9].reshape(self.n, 3, 3) if self.trivial_tau
                           else np.zeros((self.n, 3, 3)))
        if not self.has_tangent:
            self.a_values = None
        elif self.trivial_a:
            self.a_values = self.a.x.array[: self.n * 81].reshape(self.n, 3, 3, 3, 3)
        else:
            self.a_values = np.zeros((self.n, 3, 3, 3, 3))
        self._cell_weights = None
        self._dg0 = None

    # -- update cycle ----------------------------------------------------------------------
    @property
    def Fu(self):
        """Last evaluated Fu, (n, 3, 3) view."""
        return self._Fu.reshape(self.n, 3, 3)

    def evaluate_Fu(self):
        dc.eval_expression(self.Fu_expr, self.mesh, self.cells, self._Fu)
        return self.Fu

    def update(self, tangent=True):
        """Trial material update from the committed state; fills tau (and a if tangent).

        Raises MaterialUpdateError (on the ranks concerned only, after the collective writes)
        if the stress or tangent is not finite.
        """
        Fu = self.evaluate_Fu()
        if self.stretch is not None:            # the thermal stretch's increment taken out: F_u of F_e F_p
            Fu *= self.stretch[:, None, None]
        tangent = tangent and self.has_tangent
        a = self.a_values if tangent else None
        self.material.update_into(Fu, self.binv, self.eqps, self.tau_values,
                                  self.binv_trial, self.eqps_trial, a, temp_n=self.temperature,
                                  temp=self.temperature_trial, dt=float(self.dt[0]))
        scale = self.stress_scale()
        if scale is not None:                   # Kirchhoff per stress-free volume -> per reference volume
            self.tau_values *= scale[:, None, None]
            if tangent:
                a *= scale[:, None, None, None, None]
        bad = not np.isfinite(self.tau_values).all() or (tangent and not np.isfinite(a).all())
        # scatter_forward is collective: write on every rank before raising (a rank-local raise
        # here would deadlock the others)
        self._write(self.tau, self.tau_values, 9, self._qdofs, self.trivial_tau)
        if tangent:
            self._write(self.a, a, 81, self._qdofs_a, self.trivial_a)
        if bad:
            raise MaterialUpdateError(self._bad_cell_message(Fu, a if tangent else None))

    def stress_scale(self):
        """(n,) or None: the factor from the material's Kirchhoff stress (per stress-free volume) to the
        solver's (per volume of this mesh's reference times J_ref): J_theta / J_ref (:attr:`volume_scale`,
        :attr:`reference_volume`); None: 1."""
        if self.reference_volume is None:
            return self.volume_scale
        if self.volume_scale is None:
            return 1.0 / self.reference_volume
        return self.volume_scale / self.reference_volume

    def _bad_cell_message(self, Fu, a) -> str:
        """Where the update failed: the first owned cell with a non-finite stress (or tangent), its
        original (input) index, the centre of its reference shape [mm], det Fu there."""
        per_point = ~np.isfinite(self.tau_values).all(axis=(1, 2))
        if a is not None:
            per_point |= ~np.isfinite(a).reshape(self.n, -1).all(axis=1)
        p = int(np.flatnonzero(per_point)[0])
        cell = p // self.nq
        from fenics_plast import dolfinx_compat as dc
        centre = self.mesh.geometry.x[dc.geometry_dofs(self.mesh)[cell], : self.mesh.geometry.dim].mean(axis=0)
        original = int(self.mesh.topology.original_cell_index[cell])
        Fc = Fu[cell * self.nq:(cell + 1) * self.nq]
        det = float(np.linalg.det(Fc).min()) if np.isfinite(Fc).all() else float("nan")
        where = ", ".join(f"{c} = {v:.4g}" for c, v in zip("xyz", centre))
        return (f"material update returned a non-finite stress or tangent in cell {original} (input "
                f"numbering, reference centre at {where} mm; {int(per_point.sum())} point(s) on rank "
                f"{self.mesh.comm.rank}; smallest det Fu there {det:.3e}): the cell is inverted or crushed "
                f"in this increment")

    def _write(self, fun, values, bs, blocks, trivial):
        if not trivial:
            idx = (blocks[:, None] * bs + np.arange(bs)).reshape(-1)
            fun.x.array[idx] = values.reshape(-1)
        fun.x.scatter_forward()

    def commit(self):
        for v in self.variables:
            getattr(self, v.name)[:] = getattr(self, v.name + "_trial")

    # -- state by declaration ----------------------------------------------------------------
    def state(self) -> dict:
        """The committed state of this material's variables, ``{name: (n,) + shape array}`` (views)."""
        return {v.name: getattr(self, v.name) for v in self.variables}

    def set_state(self, values) -> None:
        """Set the committed and trial state from ``{name: (n,) + shape}`` (e.g. a checkpoint's rows);
        every variable of this material must be given."""
        for v in self.variables:
            getattr(self, v.name)[:] = values[v.name]
            getattr(self, v.name + "_trial")[:] = values[v.name]

    def fields(self, out=None) -> dict:
        """Cell means (DG0 Functions named by each variable's ``output``) of the written variables,
        ``{output: Function}``; ``out``: such a dict from an earlier call, reused."""
        out = {} if out is None else out
        for v in self.variables:
            if v.output:
                out[v.output] = self.cell_mean(getattr(self, v.name), name=v.output, out=out.get(v.output))
        return out

    # -- output ----------------------------------------------------------------------------
    def _weights(self):
        if self._cell_weights is None:
            w = self.kin.weight
            expr = fem.Expression(ufl.as_ufl(w) * abs(ufl.JacobianDeterminant(self.mesh)), self.points)
            wq = dc.eval_expression(expr, self.mesh, self.cells).reshape(self.n_owned, self.nq) * self.weights[None, :]
            self._cell_weights = wq / wq.sum(axis=1, keepdims=True)
            self.DG0 = dc.function_space(self.mesh, "DG", 0)
            self._dg0_dofs = dc.cell_dofs(self.DG0).reshape(-1)[: self.n_owned]
        return self._cell_weights

    def cell_mean(self, values_per_qp, name="cell_mean", out=None):
        """Weighted (w dV) cell mean of owned-qp values (n,) or (n_owned, nq) -> DG0 Function."""
        cw = self._weights()
        vals = np.asarray(values_per_qp).reshape(self.n_owned, self.nq)
        if out is None:
            out = fem.Function(self.DG0, name=name)
        out.x.array[self._dg0_dofs] = (vals * cw).sum(axis=1)
        out.x.scatter_forward()
        return out


def initial_values(variable, material, n: int) -> np.ndarray:
    """(n,) + shape values of a state variable at n virgin points (its ``initial`` rule)."""
    if variable.initial == "zero":
        return np.zeros((n,) + variable.shape)
    if variable.initial == "identity":
        return np.tile(np.eye(variable.shape[0]), (n, 1, 1))
    return getattr(material, variable.initial)(n)


def von_mises(tau, J=None):
    """von Mises equivalent of (n,3,3) stress (Cauchy if J is given: tau / J)."""
    s = tau if J is None else tau / J[:, None, None]
    dev = s - np.trace(s, axis1=1, axis2=2)[:, None, None] / 3.0 * np.eye(3)
    return np.sqrt(1.5 * np.einsum("nij,nij->n", dev, dev))


def pressure(tau, J=None):
    """Pressure -tr(sigma)/3 (Kirchhoff if J is None)."""
    s = tau if J is None else tau / J[:, None, None]
    return -np.trace(s, axis1=1, axis2=2) / 3.0
