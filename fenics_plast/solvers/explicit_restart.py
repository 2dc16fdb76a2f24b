"""The explicit solver's restart state (:mod:`fenics_plast.checkpoint`): what a resumed run needs of
:class:`~fenics_plast.solvers.explicit.ExplicitDynamics` (``solver.restart``), each value keyed by node, cell
or quadrature point rather than by one run's numbering, so that a run on other ranks or partitions resumes it.
"""
from __future__ import annotations

import weakref

import numpy as np
from mpi4py import MPI


class ExplicitRestart:
    """The restart state of ``solver`` (an :class:`~fenics_plast.solvers.explicit.ExplicitDynamics`):
    :meth:`state_dict` to save, :meth:`load_state` to restore, :meth:`keys` what names the values."""

    def __init__(self, solver):
        # a weak reference: a cycle solver <-> this object would leave the solver's PETSc objects to the garbage
        # collector, which runs at different times on different ranks (their collective destroy would hang)
        self.solver = weakref.proxy(solver)

    def state_dict(self):
        """The state a resumed run needs (see fenics_plast.checkpoint; collective): the owned entries of u,
        u_n, v, a, du, f [mm, mm/s, mm/s^2, N] and of theta/theta_n (ufl route, q1p0), the committed
        quadrature-point state binv (n,3,3) and eqps (n,) (and the temperature (n,) [K] of Johnson-Cook
        materials), each keyed by node, cell or point; the time t [s], the step count, KE0 and the (summed)
        work accumulators W_int, W_ext [N mm]. With drivers also: the load and contact force vectors fload,
        fcon [N], the prescribed dofs' reactions reac [N], the summed load and reaction work W_load, W_sets
        [N mm], E0_stored, and per contact pair its nodal history (contact<i>: t_n, N_n, p_n, t, f_c) and
        accumulators (contact<i>_acc, contact<i>_pen). Once selective mass scaling has added mass: the nodal
        mass [tonne] (by dof), the cells' density factors cell_scale (by cell) and the summed E_mass [N mm].
        With walls: their summed energy E_wall [N mm]; with element erosion: the cells' ``alive`` flags (by
        cell)."""
        from fenics_plast.checkpoint import Keyed, owned_keyed
        s = self.solver
        kv, kq = self.keys()
        n = s.n_own
        d = dict(u=owned_keyed(s.u, kv), u_n=owned_keyed(s.u_n, kv), v=owned_keyed(s.v, kv),
                 a=Keyed(s.a, kv[:n]), du=Keyed(s.du, kv[:n]), f=Keyed(np.array(s.f), kv[:n]),
                 **{k: Keyed(v, kq) for k, v in s.qmap.state().items()}, t=s.t,
                 step_count=s.step_count, KE0=s.KE0, W_int=s.allreduce(s.W_int, MPI.SUM),
                 W_ext=s.allreduce(s.W_ext, MPI.SUM))
        if s.theta is not None:
            d.update(theta=owned_keyed(s.theta), theta_n=owned_keyed(s.theta_n))
        if s.has_drivers:
            d.update(s.drivers.state_dict(kv))
        cs = s.cell_steps
        if cs.mass_scaled:
            from fenics_plast.checkpoint import cell_keys
            d.update(mass=Keyed(s.mass.copy(), kv[:n]),
                     cell_scale=Keyed(cs.cell_scale.copy(), cell_keys(s.mesh)[: s.n_cells_own]),
                     E_mass=s.allreduce(cs.E_mass, MPI.SUM))
        if s.walls.active:
            d.update(E_wall=s.walls.energy())
        if s.erosion_ratio > 0.0:
            from fenics_plast.checkpoint import cell_keys
            d.update(alive=Keyed(s.alive.astype(float), cell_keys(s.mesh)[: s.n_cells_own]))
        return d

    def keys(self):
        """(dof keys of V, quadrature-point keys of the owned points): the checkpoint's keys, which
        name each value by node coordinates and cell/point rather than by this run's numbering."""
        if not hasattr(self, "_keys"):
            from fenics_plast.checkpoint import dof_keys, qp_keys
            s = self.solver
            self._keys = (dof_keys(s.V), qp_keys(s.mesh, s.n_cells_own, s.qmap.nq))
        return self._keys

    def load_state(self, d):
        """Restore :meth:`state_dict` (collective). Raises CheckpointError (on every rank) when the
        checkpoint is of another mesh or layout. The summed work accumulators go to rank 0."""
        from fenics_plast import checkpoint as ck
        s = self.solver
        keys = ["u", "u_n", "v", "a", "du", "f", *s.qmap.state(), "t", "step_count", "W_int", "W_ext", "KE0"]
        keys += ["theta", "theta_n"] if s.theta is not None else []
        keys += s.drivers.required_keys() if s.has_drivers else []
        keys += ["E_wall"] if s.walls.active else []
        keys += ["alive"] if s.erosion_ratio > 0.0 else []
        ck.require(d, keys, "explicit solver")
        kv, kq = self.keys()
        n = s.n_own
        why = None
        try:
            owned = {k: d[k].take(kv[:n]) for k in ("u", "u_n", "v", "a", "du", "f")}
            qp = {k: d[k].take(kq) for k in s.qmap.state()}
            if s.theta is not None:
                kt = ck.dof_keys(s.theta.function_space)
                nt = s.theta.function_space.dofmap.index_map.size_local
                owned_t = {k: d[k].take(kt[:nt]) for k in ("theta", "theta_n")}
            if s.has_drivers:
                driver_rows = s.drivers.take(d, kv)
            scaled = "mass" in d
            if scaled:
                mass = d["mass"].take(kv[:n])
                cell_scale = d["cell_scale"].take(ck.cell_keys(s.mesh)[: s.n_cells_own])
            if s.erosion_ratio > 0.0:
                alive = d["alive"].take(ck.cell_keys(s.mesh)[: s.n_cells_own])
        except ck.CheckpointError as e:
            why = str(e)
        ck.raise_on_any(s.comm, why)
        for k in ("u", "u_n", "v"):
            ck.set_owned(getattr(s, k), owned[k])
        s.a[:] = owned["a"]
        s.du[:] = owned["du"]
        s.f[:] = owned["f"]
        s.qmap.set_state(qp)
        if s.theta is not None:
            for k in ("theta", "theta_n"):
                ck.set_owned(getattr(s, k), owned_t[k])
        s.t = float(d["t"])
        s.step_count = int(d["step_count"])
        root = s.comm.rank == 0
        s.W_int = float(d["W_int"]) if root else 0.0
        s.W_ext = float(d["W_ext"]) if root else 0.0
        s.KE0 = None if d["KE0"] is None else float(d["KE0"])
        if s.has_drivers:
            s.drivers.restore(d, driver_rows, root)
        if s.walls.active:
            s.walls.restore(d["E_wall"], root)
        if s.erosion_ratio > 0.0:
            s.alive[:] = np.asarray(alive) > 0.5
            s.eroded_reported = s.cell_steps.erosion_stats()["cells"]
        if scaled:                      # selective mass scaling: the mass, the cells' factors, E_mass
            s.cell_steps.restore_scaling(mass, cell_scale, float(d["E_mass"]) if root else 0.0)
            np.divide(1.0, s.mass, out=s.minv)
            s.free_minv[:] = s.minv
            s.free_minv[s.fixed] = 0.0
            s.free_minv[s.drivers.pdofs] = 0.0
            if s.contact.pairs:
                s.contact.mass_changed()
