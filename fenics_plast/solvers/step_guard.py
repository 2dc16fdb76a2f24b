"""The explicit solver's guard against a failed step: a step whose force pass finds a cell that would fold
(a quadrature point's Jacobian <= 0 or not finite, :func:`~fenics_plast.solvers.fused_force.folded_cell`) or a
stress or force that is not finite is not taken, and the solver goes back to the last finite state.

:class:`StepGuard` is :class:`~fenics_plast.solvers.explicit.ExplicitDynamics`' ``guard``: it keeps v and du
before each step (:meth:`~StepGuard.keep`), makes the ranks agree on a failure (one Allreduce of a
preallocated int a step under MPI), notes the most folded cell of a fold (``pending_fold``) or the reason of a
non-finite step (``step_failure``), and undoes the step (:meth:`~StepGuard.step_failed`). The run loop
(:mod:`~fenics_plast.solvers.time_stepping`) reads the two notes and stops the run with
:func:`~fenics_plast.solvers.collapse.fold_error` or :func:`~fenics_plast.solvers.collapse.unstable_message`.
"""
from __future__ import annotations

import math
import weakref

import numpy as np
from mpi4py import MPI

from fenics_plast.solvers import fused_force
from fenics_plast.solvers import integrator as ti
from fenics_plast.solvers.fused_force_hex import hex_folded_cells


class StepGuard:
    """The failed-step bookkeeping of ``solver`` (an :class:`~fenics_plast.solvers.explicit.ExplicitDynamics`).

    ``kept`` (2, n_own): v [mm/s] and du [mm] before the step in progress; ``pending_fold``: the note of a step
    that would fold a cell, undone (a dict: the rank's most folded owned cell, its smallest point Jacobian at
    that state, the step dt [s], whether u was finite), or None; ``step_failure``: the reason of the first
    non-finite step (the lowest rank's), or None."""

    def __init__(self, solver):
        # a weak reference: a cycle solver <-> this object would leave the solver's PETSc objects to the garbage
        # collector, which runs at different times on different ranks (their collective destroy would hang)
        self.solver = weakref.proxy(solver)
        self.kept = np.zeros((2, solver.n_own))
        self.pending_fold = None
        self.step_failure = None
        self._flag = np.zeros(1, dtype=np.int32)     # any_rank's buffer

    def keep(self):
        """Keep v and du before the step in progress (:meth:`undo_step` goes back to them)."""
        s = self.solver
        self.kept[0] = s.v.x.array[: s.n_own]
        self.kept[1] = s.du

    def any_rank(self, flag) -> bool:
        """``flag`` of any rank (one Allreduce of a preallocated int under MPI: called every step)."""
        comm = self.solver.comm
        if comm.size == 1:
            return bool(flag)
        self._flag[0] = 1 if flag else 0
        comm.Allreduce(MPI.IN_PLACE, self._flag, op=MPI.MAX)
        return bool(self._flag[0])

    def no_fold(self, bad) -> bool:
        """True when no rank has a folding cell (``bad``: this rank's first one, or -1)."""
        return not self.any_rank(bad >= 0)

    def agree(self, why):
        """``ti.STEP_OK`` when no rank has a failure (``why``: this rank's reason, or None); else
        ``ti.STEP_NONFINITE`` with ``step_failure`` set on every rank (the lowest rank's reason)."""
        if not self.any_rank(why is not None):
            return ti.STEP_OK
        comm = self.solver.comm
        whys = [w for w in comm.allgather(why) if w] if comm.size > 1 else [why]
        if self.step_failure is None:
            self.step_failure = whys[0]
        return ti.STEP_NONFINITE

    def folded_cells(self, jmin=None) -> int:
        """The first owned cell that folds at the current u (-1: none), by the fused pass's test
        (:func:`fused_force.quad_folded_cells`, :func:`~fenics_plast.solvers.fused_force_hex.hex_folded_cells`);
        ``jmin`` (n_cells_own,), when given, gets each cell's smallest point Jacobian (+inf: eroded or
        eroding, -inf: not finite). Rank-local."""
        s = self.solver
        g, u = s.geometry, s.u.x.array
        buf = np.empty(0) if jmin is None else jmin
        if s.three_d:
            return int(hex_folded_cells(u, s.cell_nodes, g.dNdX, g.W, s.alive, s.erosion_ratio, buf))
        return int(fused_force.quad_folded_cells(u, s.cell_nodes, g.dNdX, g.N, g.Rinv, g.W, s.alive,
                                                 s.erosion_ratio, buf))

    def step_failed(self, status, dt):
        """After a step of size dt [s] whose force pass failed (``ti.STEP_FOLDS``: note the most folded cell
        of this rank at that state in ``pending_fold``; ``ti.STEP_NONFINITE``: ``step_failure`` set, the
        quadrature state as the pass left it): back to the last finite state (:meth:`undo_step`). The step is
        not counted and the run stops (:func:`~fenics_plast.solvers.collapse.fold_error`, collective)."""
        if status == ti.STEP_FOLDS:
            s = self.solver
            jmin = np.empty(s.n_cells_own)
            self.folded_cells(jmin)
            i = int(np.argmin(jmin)) if jmin.size else -1
            self.pending_fold = dict(cell=i, j_next=float(jmin[i]) if i >= 0 else math.inf, dt=dt,
                                     finite=bool(np.isfinite(s.u.x.array[: s.n_own]).all()))
        self.undo_step()

    def undo_step(self):
        """Back to the state before the step in progress, whose force pass failed: u = u_n (owned and
        ghosts), v and du as kept before the step, no wall stop pending, theta = theta_n (ufl route); u_n
        stays equal to u."""
        s = self.solver
        s.u.x.array[:] = s.u_n.x.array
        s.v.x.array[: s.n_own] = self.kept[0]
        s.du[:] = self.kept[1]
        s.walls.args[5][:] = 0
        if s.theta is not None:
            s.theta.x.array[:] = s.theta_n.x.array
