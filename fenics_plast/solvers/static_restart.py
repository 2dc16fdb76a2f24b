"""The static solver's restart state (:mod:`fenics_plast.checkpoint`): what a resumed run needs of
:class:`~fenics_plast.solvers.static.StaticSolver` (``solver.restart``) at a converged increment, each value
keyed by node, cell or quadrature point rather than by one run's numbering.
"""
from __future__ import annotations

import weakref

import numpy as np

from petsc4py import PETSc


class StaticRestart:
    """The restart state of ``solver`` (a :class:`~fenics_plast.solvers.static.StaticSolver`):
    :meth:`state_dict` to save, :meth:`load_state` to restore, :meth:`keys` what names the values."""

    def __init__(self, solver):
        # a weak reference: a cycle solver <-> this object would leave the solver's PETSc objects to the garbage
        # collector, which runs at different times on different ranks (their collective destroy would hang)
        self.solver = weakref.proxy(solver)

    def state_dict(self):
        """The state a resumed run needs, at a converged increment (collective; see
        fenics_plast.checkpoint): the owned entries of w, w_n, w_nm1 (displacement [mm] and, q1p0,
        dilatation), the committed quadrature-point state (``qmap.state()``: binv (n,3,3), eqps (n,), the
        temperature (n,) [K] of Johnson-Cook materials) and a remeshed body's reference volume ratio (n,)
        (``qmap.reference_volume``; None on the first mesh), keyed by node, cell or point; the load factor,
        force scale [N], round-off floor [N], counters, the increment and cut-back records, and MUMPS
        ICNTL(14)."""
        from fenics_plast.checkpoint import Keyed, owned_keyed
        s = self.solver
        kw, kq = self.keys()
        icntl = PETSc.Options().getInt(s.prefix + "mat_mumps_icntl_14", 100) if s.is_set_up else 100
        reference_volume = s.qmap.reference_volume
        d = dict(w=owned_keyed(s.w, kw), w_n=owned_keyed(s.w_n, kw), w_nm1=owned_keyed(s.w_nm1, kw),
                 **{k: Keyed(v, kq) for k, v in s.qmap.state().items()},
                 reference_volume=None if reference_volume is None else Keyed(reference_volume.copy(), kq),
                 lam_converged=s.lam_converged, force_scale=s.force_scale,
                 roundoff_floor=s.roundoff_floor, total_iterations=s.total_iterations,
                 total_iterations_failed=s.total_iterations_failed, jacobians=s.jacobians,
                 increments=s.increments,
                 cutbacks=s.cutbacks, linesearch_retries=s.linesearch_retries,
                 mumps_workspace_raises=s.mumps_workspace_raises,
                 mumps_icntl_14=icntl)
        return d

    def keys(self):
        """(dof keys of W, quadrature-point keys of the owned points): the checkpoint's keys, which
        name each value by node coordinates and cell/point rather than by this run's numbering."""
        if not hasattr(self, "_keys"):
            from fenics_plast.checkpoint import dof_keys, qp_keys
            s = self.solver
            self._keys = (dof_keys(s.W), qp_keys(s.mesh, s.qmap.n_owned, s.qmap.nq))
        return self._keys

    def load_state(self, d):
        """Restore :meth:`state_dict` (collective). Raises CheckpointError on every rank when the
        checkpoint is of another mesh or layout."""
        from fenics_plast import checkpoint as ck
        s = self.solver
        ck.require(d, ["w", "w_n", "w_nm1", *s.qmap.state(), "lam_converged", "force_scale", "roundoff_floor",
                       "total_iterations", "increments", "cutbacks"], "static solver")
        if not s.is_set_up:
            s.setup()
        kw, kq = self.keys()
        why = None
        try:
            n = s.W.dofmap.index_map.size_local * s.W.dofmap.index_map_bs
            owned = {k: d[k].take(kw[:n]) for k in ("w", "w_n", "w_nm1")}
            qp = {k: d[k].take(kq) for k in s.qmap.state()}
            reference_volume = None if d.get("reference_volume") is None else d["reference_volume"].take(kq)
        except ck.CheckpointError as e:
            why = str(e)
        ck.raise_on_any(s.comm, why)
        for k in ("w", "w_n", "w_nm1"):
            ck.set_owned(getattr(s, k), owned[k])
        s.qmap.set_state(qp)
        s.qmap.reference_volume = None if reference_volume is None else np.asarray(reference_volume, dtype=float)
        s.lam_converged = float(d["lam_converged"])
        s.set_load(s.lam_converged)
        s.force_scale = float(d["force_scale"])
        s.roundoff_floor = float(d["roundoff_floor"])
        s.total_iterations = int(d["total_iterations"])
        s.total_iterations_failed = int(d.get("total_iterations_failed", 0))
        s.jacobians = int(d.get("jacobians", 0))
        s.increments = list(d["increments"])
        s.cutbacks = list(d["cutbacks"])
        s.linesearch_retries = list(d.get("linesearch_retries", []))
        s.mumps_workspace_raises = list(d.get("mumps_workspace_raises", []))
        icntl = int(d.get("mumps_icntl_14", 100))
        if icntl != PETSc.Options().getInt(s.prefix + "mat_mumps_icntl_14", 100):
            PETSc.Options()[s.prefix + "mat_mumps_icntl_14"] = icntl
            s.snes.getKSP().setFromOptions()
