r"""The explicit solver's integrator: central differences in velocity-Verlet form.

The compiled step kernels of :class:`fenics_plast.solvers.explicit.ExplicitDynamics` (the plain and
the general ones, the rigid walls' stops, the step loops ``advance*`` with their status codes
``STEP_*``) and :class:`Drivers`, what drives a run besides the internal force (prescribed motion,
external loads) and the steps that integrate them together with contact. The internal force itself
is :func:`fenics_plast.solvers.fused_force.internal_force` (or the UFL route in explicit.py); the
contact forces are :func:`fenics_plast.solvers.contact_kernels.contact_forces` with the data of
:mod:`fenics_plast.solvers.explicit_contact`. The stable step is
:class:`fenics_plast.solvers.cell_steps.CellSteps`'s (``solver.cell_steps``).

One step t_n -> t_{n+1} = t_n + dt (units mm, N, s, tonne/mm^3; arrays are the owned, unrolled
dofs, 2 per node (3 on hexahedra, geometry "3d"): index bs node + component):

    v_{n+1/2} = v_n + dt/2 a_n                   free dofs
    v_{n+1/2} = V(t_n + dt/2)                    prescribed velocity V(t)
    u_{n+1}   = u_n + dt v_{n+1/2}               (prescribed displacement d(t): u_{n+1} = d(t_{n+1}),
                                                  v_{n+1/2} = (u_{n+1} - u_n) / dt)
    f_{n+1}   = f_int(u_{n+1})  (material update and commit)
    e_{n+1}   = f_load(t_{n+1}) + f_contact(u_{n+1}, t_{n+1})
    a_{n+1}   = (e_{n+1} - f_{n+1}) / M          0 on constrained and prescribed dofs
    v_{n+1}   = v_{n+1/2} + dt/2 a_{n+1}         (prescribed: V(t_{n+1}), or the central difference
                                                  (d(t + dt/2) - d(t - dt/2)) / dt of d)

Energies (trapezoidal rule over the step, du = u_{n+1} - u_n):

* internal work  W_int += du . (f_n + f_{n+1}) / 2 (all dofs: prescribed dofs too);
* load work      W_load += du . (f_load,n + f_load,n+1) / 2;
* reaction work of each prescribed set: W_set += du . (r_n^+ + r_{n+1}^-) / 2 with the reaction
  (the force the constraint exerts on the body) r = f_int - f_load - f_contact + M a and the
  acceleration of the prescribed dof taken over each half step, a_n^+ = 2 (v_{n+1/2} - v_n) / dt,
  a_{n+1}^- = 2 (v_{n+1} - v_{n+1/2}) / dt (so the inertia term integrates to
  M v_{n+1/2} (v_{n+1} - v_n), the discrete kinetic energy change of the dof);
* contact (per pair, :func:`~fenics_plast.solvers.contact_kernels.contact_forces`): energy taken
  up by the contact (penalty energy + frictional dissipation) E_c += -(f_c,n + f_c,n+1)/2 . (du - dd),
  dd the tool's translation over the step, and the work of the moving tool
  W_tool += (F_c,n + F_c,n+1)/2 . dd.

Rigid walls (boundary type "wall", :func:`stop_at_walls`): after the drift a dof past its wall is
put back on it and v_{n+1/2} becomes the velocity that lands it there; the energy this takes, E_wall,
is the stopped dof's own balance over the step, 1/2 m (v_n^2 - v_{n+1}^2) - du (g_n + g_{n+1}) / 2
(g its net internal force, :func:`settle_walls`).

Balance: KE + W_int + E_c + E_wall = KE0 + W_ext with W_ext = W_load + sum W_set + W_tool (+ the
supports' work, zero for homogeneous velocity constraints).

The plain kernels (:func:`kick_drift`, :func:`kick`, :func:`advance`) serve runs with only
homogeneous velocity constraints (the Taylor bar: same arithmetic as before the general drivers
existed); the general ones (:func:`drift_general`, :func:`kick_general`, :func:`advance_general`)
serve runs with prescribed motion, loads or contact. ``advance*`` run several steps of a serial
run in one compiled call; the per-step data that depend on Python callables (prescribed values,
load factors, tool translations) are evaluated beforehand by :meth:`Drivers.step_data` for the
step times t_k (computed by repeated addition exactly as the step-by-step path does).

A step whose force pass fails (a cell that folds: :func:`fused_force.folded_cell`, before anything
is written; or a stress or force that is not finite) ends the loop before its loads, contact and
kick: it is not counted, and the solver goes back to the state before it (u = u_n, v and du as
kept before the step), see :data:`STEP_OK` and ``StepGuard.step_failed``.
"""
from __future__ import annotations

import numba
import numpy as np
from mpi4py import MPI

from fenics_plast.solvers.contact_kernels import contact_forces
from fenics_plast.solvers.fused_force import folded_cell, update_and_force

_njit = numba.njit(cache=True, nogil=True, fastmath={"contract", "arcp", "nsz"})
_NONE = np.zeros(0)             # "no load vector" for the walls' kernels called by the plain kernels

VELOCITY, DISPLACEMENT = 0, 1


# ----------------------------------------------------------------------------------------------
# plain kernels: homogeneous velocity constraints only


@_njit
def _load(fload, fcon, i):
    """fload[i] + fcon[i], 0 where the arrays are empty (the plain kernels' call)."""
    x = 0.0
    if fload.shape[0]:
        x += fload[i]
    if fcon.shape[0]:
        x += fcon[i]
    return x


@_njit
def stop_at_walls(v, a, du, u, u_n, dt, mass, f, fload, fcon, walls):
    """Rigid unilateral walls (boundary type "wall"), after the drift: a dof that has passed its wall
    is put back on it, u = limit, and its half-step velocity becomes the one that lands it there,
    v_{n+1/2} = (limit - u_n) / dt (the forward-increment constraint of an explicit contact; the
    tangential components go on unchanged).

    The energy the stop takes is the dof's own discrete balance over the step, closed in
    :func:`settle_walls` after the kick: E = 1/2 m (v_n^2 - v_{n+1}^2) - du (g_n + g_{n+1}) / 2 with
    g = f - fload - fcon its net internal force (what the free dofs' kinetic energy change and the
    trapezoidal works match): 1/2 m v^2 for a node that lands at speed v and stays, 0 for a node at
    rest on the wall. v_n is v_{n+1/2} - dt/2 a_n (a still holds a_n here); f, fload, fcon hold the
    step-n forces (fload, fcon may be empty: none).

    walls = (dofs (nw,) int64 owned dofs, limit (nw,) the displacement at which each dof touches its
    wall [mm], side (nw,) +1 / -1: the side of the wall the body is on, lost (1,) the energy the stops
    took [N mm] (accumulated), pending (nw,) and hit (nw,) uint8: the open balance of the dofs
    stopped in this step).
    """
    dofs, limit, side, lost, pending, hit = walls
    for j in range(dofs.shape[0]):
        i = dofs[j]
        if side[j] * (u[i] - limit[j]) < 0.0:
            v_n = v[i] - 0.5 * dt * a[i]
            u[i] = limit[j]
            du[i] = u[i] - u_n[i]
            v[i] = du[i] / dt
            pending[j] = 0.5 * mass[i] * v_n * v_n - 0.5 * du[i] * (f[i] - _load(fload, fcon, i))
            hit[j] = 1


@_njit
def settle_walls(v, du, mass, f, fload, fcon, walls):
    """After the kick: closes the balance of the dofs stopped in this step (:func:`stop_at_walls`)
    with their step-end velocity and forces, into walls' ``lost``."""
    dofs, limit, side, lost, pending, hit = walls
    for j in range(dofs.shape[0]):
        if hit[j]:
            i = dofs[j]
            lost[0] += pending[j] - 0.5 * mass[i] * v[i] * v[i] - 0.5 * du[i] * (f[i] - _load(fload, fcon, i))
            hit[j] = 0


@_njit
def kick_drift(v, a, f, du, u, u_n, dt, n, mass, walls):
    """v += dt/2 a; du = dt v; u_n = u (all entries); u[:n] += du; the walls' stops
    (:func:`stop_at_walls`). Returns du . f (owned) [N mm]."""
    u_n[:] = u
    for i in range(n):
        v[i] += 0.5 * dt * a[i]
        du[i] = dt * v[i]
        u[i] += du[i]
    stop_at_walls(v, a, du, u, u_n, dt, mass, f, _NONE, _NONE, walls)
    w = 0.0
    for i in range(n):
        w += du[i] * f[i]
    return w


@_njit
def kick(v, a, f, free_minv, du, dt, n, mass, walls):
    """a = -f / M (0 on constrained dofs); v += dt/2 a; the walls' balance (:func:`settle_walls`).
    Returns du . f (owned) [N mm]."""
    w = 0.0
    for i in range(n):
        a[i] = -f[i] * free_minv[i]
        v[i] += 0.5 * dt * a[i]
        w += du[i] * f[i]
    settle_walls(v, du, mass, f, _NONE, _NONE, walls)
    return w


#: status of a step (:func:`advance`, :func:`advance_general`, ``ExplicitDynamics``): every step finite
STEP_OK = -1
#: status: the stress or force of the step is not finite (the quadrature state holds its update)
STEP_NONFINITE = -2
#: status (``ExplicitDynamics.internal_force``, :meth:`Drivers.step`): a cell folds, on some rank
STEP_FOLDS = -3


@_njit
def advance(nsteps, dt, v, a, free_minv, du, n, force_args, work, mass, walls, kept):
    """``nsteps`` central-difference steps of size dt in one call (serial runs, fused force).

    force_args : the :class:`~fenics_plast.solvers.fused_force.FusedPass` of the force pass,
    whose arrays are updated in place; mass, walls: as :func:`stop_at_walls`.
    work : (1,) internal work [N mm], incremented step by step
    exactly as :meth:`ExplicitDynamics.step` does (so the result does not depend on how steps are
    grouped). kept (2, n): v and du (owned entries) before the step in progress, what the solver's
    ``StepGuard.undo_step`` needs, with u_n, to go back to the last finite state.
    Returns (steps done, status): status :data:`STEP_OK`; or the owned cell that the next step
    folds (>= 0: :func:`fused_force.folded_cell`; that step wrote no state, stress or force, and
    u_n, kept restore its u, v, du); or :data:`STEP_NONFINITE` (the next step's stress or force is
    not finite: its material update is committed). The failed step is not among the steps done
    and its kick is not taken.
    """
    u, u_n, f = force_args.u, force_args.u_n, force_args.f
    for k in range(nsteps):
        kept[0, :n] = v[:n]             # (slices: a call here slowed the 3-D loop by 10 %)
        kept[1, :n] = du[:n]
        w_old = kick_drift(v, a, f, du, u, u_n, dt, n, mass, walls)
        bad = folded_cell(force_args)
        if bad >= 0:
            return k, bad
        if not update_and_force(force_args):
            return k, STEP_NONFINITE
        w_new = kick(v, a, f, free_minv, du, dt, n, mass, walls)
        work[0] += 0.5 * (w_old + w_new)
    return nsteps, STEP_OK


# ----------------------------------------------------------------------------------------------
# general kernels: prescribed motion, external loads, contact


@_njit
def drift_general(v, a, f, fload, fcon, mass, du, u, u_n, dt, n, pdofs, pkind, pval, pv_old, r_old, walls):
    """First half of a step with prescribed dofs (and the walls' stops, :func:`stop_at_walls`, before
    the prescribed values are set).

    pdofs (np,) prescribed owned dofs, pkind (np,) VELOCITY | DISPLACEMENT, pval (np, 2) this
    step's values: (v_{n+1/2}, v_{n+1}) [mm/s] or (u_{n+1}, v_{n+1}) [mm, mm/s]. Writes v_n of the
    prescribed dofs to pv_old and their reaction r_n^+ [N] to r_old. Returns (du . f, du . fload)
    [N mm] (owned dofs).
    """
    u_n[:] = u
    for i in range(n):
        v[i] += 0.5 * dt * a[i]
        du[i] = dt * v[i]
        u[i] += du[i]
    stop_at_walls(v, a, du, u, u_n, dt, mass, f, fload, fcon, walls)
    for j in range(pdofs.shape[0]):
        i = pdofs[j]
        pv_old[j] = v[i]                  # a = 0 there: still v_n
        if pkind[j] == VELOCITY:
            v[i] = pval[j, 0]
            du[i] = dt * v[i]
            u[i] = u_n[i] + du[i]
        else:
            u[i] = pval[j, 0]
            du[i] = u[i] - u_n[i]
            v[i] = du[i] / dt
        r_old[j] = f[i] - fload[i] - fcon[i] + mass[i] * 2.0 * (v[i] - pv_old[j]) / dt
    w_int = 0.0
    w_load = 0.0
    for i in range(n):
        w_int += du[i] * f[i]
        w_load += du[i] * fload[i]
    return w_int, w_load


@_njit
def kick_general(v, a, f, fload, fcon, free_minv, mass, du, dt, n, pdofs, pset, pval, r_old, reac, wset, walls):
    """Second half of a step: a = (fload + fcon - f) / M on free dofs, v += dt/2 a; prescribed dofs
    get v_{n+1}, their reaction r_{n+1}^- into reac (np,) [N] and the trapezoidal reaction work
    into wset[set] [N mm]; the walls' balance (:func:`settle_walls`). Returns (du . f, du . fload)
    [N mm]."""
    w_int = 0.0
    w_load = 0.0
    for i in range(n):
        a[i] = (fload[i] + fcon[i] - f[i]) * free_minv[i]
        v[i] += 0.5 * dt * a[i]
        w_int += du[i] * f[i]
        w_load += du[i] * fload[i]
    for j in range(pdofs.shape[0]):
        i = pdofs[j]
        vh = v[i]
        v[i] = pval[j, 1]
        r = f[i] - fload[i] - fcon[i] + mass[i] * 2.0 * (v[i] - vh) / dt
        wset[pset[j]] += 0.5 * (r_old[j] + r) * du[i]
        reac[j] = r
    settle_walls(v, du, mass, f, fload, fcon, walls)
    return w_int, w_load


@_njit
def advance_general(nsteps, dt, v, a, free_minv, mass, du, n, force_args, fload, fload_rows,
                    pdofs, pkind, pset, pvals, pv_old, r_old, reac, wset, fcon, contact_args, trans, work, walls,
                    kept):
    """``nsteps`` steps of a serial, fused-force run with prescribed motion, loads and contact (the
    same kernels, in the same order, as the step-by-step path of ExplicitDynamics).

    fload_rows (nsteps, n) or (nsteps, 0): the load vector at the step ends (none: fload stays);
    pvals (nsteps, np, 2) the prescribed values of each step; contact_args: the
    :class:`~fenics_plast.solvers.contact_kernels.ContactArrays` of :func:`contact_forces`;
    trans (nsteps + 1, npairs, 2) the tool translations at
    the step times. work (2,) += internal work, load work [N mm]; walls: as :func:`stop_at_walls`;
    kept (2, n): as :func:`advance`. Returns (steps done, status) as :func:`advance` (a failed step
    stops before its loads, contact and kick).
    """
    u, u_n, f = force_args.u, force_args.u_n, force_args.f
    has_load = fload_rows.shape[1] > 0
    has_contact = contact_args.X.shape[0] > 0
    for k in range(nsteps):
        kept[0, :n] = v[:n]
        kept[1, :n] = du[:n]
        wi0, wl0 = drift_general(v, a, f, fload, fcon, mass, du, u, u_n, dt, n, pdofs, pkind, pvals[k],
                                 pv_old, r_old, walls)
        bad = folded_cell(force_args)
        if bad >= 0:
            return k, bad
        if not update_and_force(force_args):
            return k, STEP_NONFINITE
        if has_load:
            fload[:] = fload_rows[k]
        if has_contact:
            contact_forces(u, du, dt, contact_args, trans[k], trans[k + 1], fcon)
        wi1, wl1 = kick_general(v, a, f, fload, fcon, free_minv, mass, du, dt, n, pdofs, pset, pvals[k],
                                r_old, reac, wset, walls)
        work[0] += 0.5 * (wi0 + wi1)
        work[1] += 0.5 * (wl0 + wl1)
    return nsteps, STEP_OK


# ----------------------------------------------------------------------------------------------
# drivers: prescribed motion, external loads, and the steps that integrate them with contact


def _raise_on_any(comm, why):
    """ValueError on every rank when ``why`` (a message or None) is set on any rank."""
    whys = [w for w in comm.allgather(why) if w] if comm.size > 1 else [why] if why else []
    if whys:
        raise ValueError(whys[0])


def _as_function(value):
    """A callable of t: the value itself, or a constant."""
    if callable(value):
        return value
    c = float(value)
    return lambda t: c


class StepData:
    """What :func:`advance_general` needs besides the state, for ``nsteps`` steps from t.

    times (nsteps + 1,) [s]; pvals (nsteps, np, 2); fload_rows (nsteps, n) or (nsteps, 0);
    trans (nsteps + 1, npairs, 2) [mm]."""

    __slots__ = ("times", "pvals", "fload_rows", "trans")


class Drivers:
    """Prescribed motion and external loads of an explicit solver ``s``
    (:class:`~fenics_plast.solvers.explicit.ExplicitDynamics`), and the steps that integrate them
    together with the solver's contact pairs (``s.contact``,
    :class:`~fenics_plast.solvers.explicit_contact.ContactSet`).

    * prescribed sets: owned dofs of one component whose velocity (VELOCITY) or displacement
      (DISPLACEMENT) is a function of time; flattened to pdofs (np,), pkind (np,), pset (np,);
      reac (np,) their reaction at the current time [N], wset (nsets,) their work [N mm];
    * loads: fixed nodal vectors (n,) [N per unit] scaled by functions of time, or callables of time
      returning nodal vectors (n,) [N]; fload (n,) the load at the current time [N], W_load its work;
    * fcon (n,) the contact force at the current time [N].
    All arrays are rank-local (owned dofs); accumulators are summed over the ranks when reported.
    """

    def __init__(self, solver):
        self.s = solver
        self.n, self.bs = int(solver.n_own), int(solver.bs)
        self.sets = []                 # dicts: component, dofs (owned), kind, fun, name
        self.loads = []                # (base (n,), fun of t) or (None, fun of t -> (n,))
        self.fload = np.zeros(self.n)
        self.fcon = np.zeros(self.n)
        self.W_load = 0.0
        self.E0_stored = 0.0           # elastic + contact energy at the first step [N mm]
        # round-off floor of the instability check: 1e-20 M c^2 (M the body's mass, c the wave speed)
        mass = solver.allreduce(float(solver.mass[0::self.bs].sum()), MPI.SUM)
        self.ke_floor = 1e-20 * mass * solver.c ** 2
        self._build()

    @property
    def active(self):
        """True with prescribed motion, loads or contact (the general kernels)."""
        return bool(self.sets or self.loads or self.s.contact.pairs)

    # -- prescribed motion -------------------------------------------------------------------
    def add_set(self, component, dofs, kind, fun, name=None):
        """Register a set: component ``component`` of the nodes ``dofs`` (block indices of the
        solver's space, owned + ghost; ghosts ignored). A dof already constrained (velocity_bcs,
        another set) is refused (ValueError on every rank: collective). Returns the set id."""
        if component not in range(self.bs):
            raise ValueError(f"component must be 0..{self.bs - 1}, got {component!r}")
        nodes = np.unique(np.asarray(dofs, dtype=np.int64).reshape(-1))
        why = None
        n_local = self.s.u.x.array.size // self.bs
        if nodes.size and (nodes.min() < 0 or nodes.max() >= n_local):
            why = (f"prescribed dofs must be node (block) indices of the solver's space, 0 <= i < {n_local} "
                   "(e.g. ExplicitDynamics.boundary_dofs)")
        dofs = nodes * self.bs + component                  # unrolled
        dofs = dofs[dofs < self.n]
        clash = np.intersect1d(dofs, np.union1d(self.s.fixed, self.pdofs))
        if why is None and clash.size:
            why = f"{clash.size} of the prescribed dofs are already constrained (velocity_bcs or another prescribed set)"
        _raise_on_any(self.s.comm, why)
        self.sets.append(dict(component=int(component), dofs=dofs, kind=kind, fun=_as_function(fun),
                              name=name or f"set{len(self.sets)}"))
        self._build()
        return len(self.sets) - 1

    def _build(self):
        S = self.sets
        self.pdofs = np.concatenate([s["dofs"] for s in S]).astype(np.int64) if S else np.zeros(0, np.int64)
        self.pkind = np.array([s["kind"] for s in S for _ in s["dofs"]], dtype=np.int64)
        self.pset = np.array([k for k, s in enumerate(S) for _ in s["dofs"]], dtype=np.int64)
        self.reac = np.zeros(self.pdofs.size)
        self.pv_old = np.zeros(self.pdofs.size)
        self.r_old = np.zeros(self.pdofs.size)
        self.wset = np.zeros(len(S))

    def set_values(self, t0, t1, dt):
        """(nsets, 2) values of one step t0 -> t1: velocity sets (V(t0 + dt/2), V(t1)),
        displacement sets (d(t1), (d(t1 + dt/2) - d(t1 - dt/2)) / dt)."""
        out = np.empty((len(self.sets), 2))
        for k, s in enumerate(self.sets):
            fn = s["fun"]
            if s["kind"] == VELOCITY:
                out[k] = fn(t0 + 0.5 * dt), fn(t1)
            else:
                out[k] = fn(t1), (fn(t1 + 0.5 * dt) - fn(t1 - 0.5 * dt)) / dt
        return out

    def initial_values(self, t, h):
        """(nsets, 2): (value at t, velocity at t) (displacement sets: forward difference over h)."""
        out = np.empty((len(self.sets), 2))
        for k, s in enumerate(self.sets):
            fn = s["fun"]
            out[k] = (fn(t), fn(t)) if s["kind"] == VELOCITY else (fn(t), (fn(t + h) - fn(t)) / h)
        return out

    def reaction(self, set_id):
        """(2,) rank-local reaction of a set (its component only)."""
        out = np.zeros(self.bs)
        out[self.sets[set_id]["component"]] = float(self.reac[self.pset == set_id].sum())
        return out

    # -- loads -------------------------------------------------------------------------------
    def add_load(self, base, fun):
        """A load ``fun(t) * base`` (base (n,) or longer: owned entries first [N per unit of fun])
        or, base None, ``fun(t)`` itself ((n,) or longer) [N]."""
        if base is not None:
            base = np.array(base[: self.n], dtype=float)
            fun = _as_function(fun)
        self.loads.append((base, fun))

    def load_vector(self, t, out=None):
        out = np.zeros(self.n) if out is None else out
        out[:] = 0.0
        for base, fn in self.loads:
            if base is None:
                vec = np.asarray(fn(t), dtype=float).reshape(-1)
                if vec.size < self.n:
                    raise ValueError(f"an external force callable returned {vec.size} values, "
                                     f"{self.n} owned dofs expected")
                out += vec[: self.n]
            else:
                out += fn(t) * base
        return out

    # -- steps -------------------------------------------------------------------------------
    def step_data(self, t, dt, nsteps):
        """:class:`StepData` of ``nsteps`` steps of size dt from t (times by repeated addition, as
        the solver advances its clock)."""
        d = StepData()
        times = np.empty(nsteps + 1)
        times[0] = t
        for k in range(nsteps):
            t = t + dt
            times[k + 1] = t
        d.times = times
        d.pvals = np.empty((nsteps, self.pdofs.size, 2))
        if self.pdofs.size:
            for k in range(nsteps):
                d.pvals[k] = self.set_values(times[k], times[k + 1], dt)[self.pset]
        if self.loads:
            d.fload_rows = np.empty((nsteps, self.n))
            for k in range(nsteps):
                self.load_vector(times[k + 1], d.fload_rows[k])
        else:
            d.fload_rows = np.zeros((nsteps, 0))
        d.trans = self.s.contact.translations_at(times)
        return d

    def initialize(self):
        """Solver state at its current time: prescribed values (u and v), internal, load and contact
        forces, acceleration, reactions, KE0 (collective)."""
        s, n = self.s, self.n
        if self.sets:
            h = 0.5 * s.stable_dt()                     # forward difference of displacement sets
            vals = self.initial_values(s.t, h)[self.pset]
            disp = self.pkind == DISPLACEMENT
            s.u.x.array[self.pdofs[disp]] = vals[disp, 0]
            s.v.x.array[self.pdofs] = vals[:, 1]
            s.u.x.scatter_forward()
            s.v.x.scatter_forward()
        s.internal_force()
        if self.loads:
            why = None
            try:
                self.load_vector(s.t, self.fload)
            except ValueError as e:                     # e.g. a callable's size, maybe on one rank only
                why = str(e)
            _raise_on_any(s.comm, why)
        if s.contact.pairs:
            tr = s.contact.translations(s.t)
            s.contact.update(s.u.x.array, np.zeros_like(s.u.x.array), 0.0, tr, tr, self.fcon, s.t)
        np.multiply(self.fload + self.fcon - s.f[:n], s.free_minv, out=s.a)
        self.reac[:] = s.f[self.pdofs] - self.fload[self.pdofs] - self.fcon[self.pdofs]
        s.KE0 = s.kinetic_energy()
        self.E0_stored = s.elastic_energy() + sum(p.stored_energy() for p in s.contact.pairs)

    def step(self, dt):
        """One step of the solver (the kernels of :func:`advance_general`, with the internal force of
        either route and, under MPI, the ghost update of u). Returns the status of the solver's force
        pass (``ExplicitDynamics.internal_force``, the same on every rank): a failed step stops
        before its loads, contact and kick, and the solver undoes its drift."""
        s, n = self.s, self.n
        d = self.step_data(s.t, dt, 1)
        v, u = s.v.x.array, s.u.x.array
        wi0, wl0 = drift_general(v, s.a, s.f, self.fload, self.fcon, s.mass, s.du, u, s.u_n.x.array, dt, n,
                                 self.pdofs, self.pkind, d.pvals[0], self.pv_old, self.r_old, s.walls.args)
        if s.theta is not None:
            s.theta_n.x.array[:] = s.theta.x.array
        if s.comm.size > 1:
            s.u.x.scatter_forward()
        status = s.internal_force()
        if status != STEP_OK:
            return status               # the solver goes back (before loads, contact, kick)
        if self.loads:
            self.fload[:] = d.fload_rows[0]
        if s.contact.pairs:
            s.contact.update(u, s.du, dt, d.trans[0], d.trans[1], self.fcon, d.times[1])
        wi1, wl1 = kick_general(v, s.a, s.f, self.fload, self.fcon, s.free_minv, s.mass, s.du, dt, n,
                                self.pdofs, self.pset, d.pvals[0], self.r_old, self.reac, self.wset,
                                s.walls.args)
        s.W_int += 0.5 * (wi0 + wi1)
        self.W_load += 0.5 * (wl0 + wl1)
        return STEP_OK

    def advance(self, nsteps, dt):
        """``nsteps`` steps in one compiled call (serial, fused force, compiled gaps). Returns
        (steps done, status) (:func:`advance_general`)."""
        s = self.s
        d = self.step_data(s.t, dt, nsteps)
        work = np.array([s.W_int, self.W_load])
        out = advance_general(nsteps, dt, s.v.x.array, s.a, s.free_minv, s.mass, s.du, self.n, s.force_args,
                              self.fload, d.fload_rows, self.pdofs, self.pkind, self.pset, d.pvals, self.pv_old,
                              self.r_old, self.reac, self.wset, self.fcon, s.contact.args(), d.trans, work,
                              s.walls.args, s.guard.kept)
        s.W_int, self.W_load = float(work[0]), float(work[1])
        return out

    # -- energies ----------------------------------------------------------------------------
    def energies(self, ke, w_int, w_ext, comm, e_mass=0.0, e_wall=0.0):
        """The energy entries of the drivers and the balance error (collective); ``e_mass``: the kinetic
        energy brought in by mass scaling, ``e_wall``: the kinetic energy taken by the walls' stops
        [N mm] (summed), a source and a sink of the balance."""
        s, acc = self.s, self.s.contact.acc
        loc = np.concatenate([[self.W_load, float(self.wset.sum())], acc[:, 0], acc[:, 1]])
        tot = comm.allreduce(loc, op=MPI.SUM) if comm.size > 1 else loc
        npairs = acc.shape[0]
        w_load, w_pres = float(tot[0]), float(tot[1])
        e_c, w_tool = float(tot[2:2 + npairs].sum()), float(tot[2 + npairs:].sum())
        stored = sum(p.stored_energy() for p in s.contact.pairs)
        w_ext = w_ext + w_pres + w_load + w_tool
        scale = s.KE0 + abs(w_ext) + e_mass
        err = abs(ke + w_int + e_c + e_wall - s.KE0 - w_ext - e_mass) / (scale if scale > 0.0 else 1.0)
        return dict(external_work=w_ext, balance_error=err, prescribed_work=w_pres, load_work=w_load,
                    tool_work=w_tool, contact_work=e_c, contact_stored=stored)

    def ke_limit(self):
        """1.5 (KE0 + |W_ext| + energy stored at the start) + 1e-20 M c^2 (a round-off floor: a body
        at rest has KE0 = 0) (collective)."""
        s = self.s
        loc = self.W_load + float(self.wset.sum()) + float(s.contact.acc[:, 1].sum())
        return 1.5 * (s.KE0 + abs(s.allreduce(loc, MPI.SUM)) + self.E0_stored) + self.ke_floor

    # -- checkpoints -------------------------------------------------------------------------
    def state_dict(self, kv):
        """fload, fcon [N] (keyed by dof), reac [N] (by prescribed dof), summed W_load, W_sets
        [N mm], E0_stored, and the contact pairs' state (ContactSet.state_dict)."""
        from fenics_plast.checkpoint import Keyed
        s, n = self.s, self.n
        d = dict(fload=Keyed(self.fload.copy(), kv[:n]), fcon=Keyed(self.fcon.copy(), kv[:n]),
                 reac=Keyed(self.reac.copy(), kv[self.pdofs]), W_load=s.allreduce(self.W_load, MPI.SUM),
                 W_sets=[s.allreduce(float(w), MPI.SUM) for w in self.wset], E0_stored=self.E0_stored)
        d.update(s.contact.state_dict(kv, s.comm))
        return d

    def required_keys(self):
        return ["fload", "fcon", "reac", "W_load", "W_sets", "E0_stored"] + self.s.contact.required_keys()

    def take(self, d, kv):
        """This rank's rows (raises CheckpointError, rank-local, for another mesh)."""
        n = self.n
        return dict(fload=d["fload"].take(kv[:n]), fcon=d["fcon"].take(kv[:n]), reac=d["reac"].take(kv[self.pdofs]),
                    contact=self.s.contact.take(d, kv))

    def restore(self, d, rows, root):
        """Restore what :meth:`take` read; the summed accumulators go to rank 0 (root)."""
        self.fload[:], self.fcon[:], self.reac[:] = rows["fload"], rows["fcon"], rows["reac"]
        self.W_load = float(d["W_load"]) if root else 0.0
        self.wset[:] = np.asarray(d["W_sets"], dtype=float) if root else 0.0
        self.E0_stored = float(d["E0_stored"])
        self.s.contact.restore(d, rows["contact"], root)
