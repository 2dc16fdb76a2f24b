r"""Time integration of the explicit solver: central differences in velocity-Verlet form.

Compiled kernels of :class:`fenics_plast.solvers.explicit.ExplicitDynamics` and :class:`Drivers`,
what drives a run besides the internal force (prescribed motion, external loads) and the steps
that integrate them together with contact. The internal force itself is
:func:`fenics_plast.solvers.fused_force.internal_force` (or the UFL route in explicit.py); the
contact forces are :func:`contact_forces` with the data of
:mod:`fenics_plast.solvers.explicit_contact`.

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
* contact (per pair, :func:`contact_forces`): energy taken up by the contact (penalty energy +
  frictional dissipation) E_c += -(f_c,n + f_c,n+1)/2 . (du - dd), dd the tool's translation over
  the step, and the work of the moving tool W_tool += (F_c,n + F_c,n+1)/2 . dd.

Rigid walls (boundary type "wall", :func:`stop_at_walls`): after the drift a dof past its wall is
put back on it and v_{n+1/2} becomes the velocity that lands it there; the energy this takes, E_wall,
is the stopped dof's own balance over the step, 1/2 m (v_n^2 - v_{n+1}^2) - du (g_n + g_{n+1}) / 2
(g its net internal force, :func:`settle_walls`).

Balance: KE + W_int + E_c + E_wall = KE0 + W_ext with W_ext = W_load + sum W_set + W_tool (+ the
supports' work, zero for homogeneous velocity constraints).

The stable step's element size (:func:`quad_min_size`: smallest edge or altitude of the deformed
quads) is here too; ExplicitDynamics.stable_dt divides it by the wave speed and combines it with the
contact penalty's limit (explicit_contact.py).

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
kept before the step), see :data:`STEP_OK` and ``ExplicitDynamics._step_failed``.
"""
from __future__ import annotations

import numba
import numpy as np
from mpi4py import MPI

from fenics_plast.solvers.fused_force import folded_cell, update_and_force

_njit = numba.njit(cache=True, nogil=True, fastmath={"contract", "arcp", "nsz"})
_NONE = np.zeros(0)             # "no load vector" for the walls' kernels called by the plain kernels

VELOCITY, DISPLACEMENT = 0, 1


# ----------------------------------------------------------------------------------------------
# stable step: the smallest element size of the deformed mesh (ExplicitDynamics.stable_dt)


@numba.njit(cache=True)
def _quad_min_size(x, cell_dofs, out):
    for c in range(cell_dofs.shape[0]):
        h = np.inf
        for k in range(4):
            a = cell_dofs[c, k]
            b = cell_dofs[c, (k + 1) % 4]
            ex = x[b, 0] - x[a, 0]
            ey = x[b, 1] - x[a, 1]
            le = np.sqrt(ex * ex + ey * ey)
            h = min(h, le)
            for m in (2, 3):                   # distance of the opposite vertices from edge k's line
                d = cell_dofs[c, (k + m) % 4]
                dx = x[d, 0] - x[a, 0]
                dy = x[d, 1] - x[a, 1]
                h = min(h, abs(ex * dy - ey * dx) / max(le, 1e-300))
        out[c] = h
    return out


def quad_min_size(P):
    """Smallest edge length or altitude (distance of a vertex from an opposite edge's line) of
    each quad; P (n, 4, 2) vertices in cyclic order."""
    P = np.ascontiguousarray(P, dtype=float)
    n = P.shape[0]
    cd = np.arange(4 * n, dtype=np.int64).reshape(n, 4)
    return _quad_min_size(P.reshape(-1, 2), cd, np.empty(n))


_G = 1.0 / np.sqrt(3.0)
_XI = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])    # cyclic vertex order


@numba.njit(cache=True)
def _quad_eig_dt(x, cell_dofs, cells, mass, lam, mu, axisymmetric, fbar, out):
    """2 / omega_max of the listed cells' elastic elements: out[k] for cell ``cells[k]``.

    omega_max^2 is the largest eigenvalue of M^-1/2 K M^-1/2 with K the small-strain elastic
    stiffness of the cell in its current shape x (2 x 2 Gauss points, weight 2 pi r in
    axisymmetry, hoop strain u_r / r; fbar: the volumetric part through the cell's mean
    dilatation, as Q1/P0 does) with moduli lam[c], mu[c] [MPa], and M the cell's share of its
    nodes' lumped mass mass[c] (4,) [tonne] (cyclic order). By Irons' theorem the assembled
    system's omega_max is at most the largest element value.
    """
    B = np.zeros((4, 4, 8))
    W = np.zeros(4)
    K = np.zeros((8, 8))
    for k in range(cells.shape[0]):
        c = cells[k]
        lm, m = lam[c], mu[c]
        kap = lm + 2.0 * m / 3.0
        B[:] = 0.0
        vol = 0.0
        q = 0
        for a in range(2):
            for b in range(2):
                xi = (2 * a - 1) * _G
                eta = (2 * b - 1) * _G
                j00 = j01 = j10 = j11 = 0.0
                r = 0.0
                N = np.empty(4)
                dN = np.empty((4, 2))
                for v in range(4):
                    N[v] = 0.25 * (1.0 + xi * _XI[v, 0]) * (1.0 + eta * _XI[v, 1])
                    dN[v, 0] = 0.25 * _XI[v, 0] * (1.0 + eta * _XI[v, 1])
                    dN[v, 1] = 0.25 * _XI[v, 1] * (1.0 + xi * _XI[v, 0])
                    px = x[cell_dofs[c, v], 0]
                    py = x[cell_dofs[c, v], 1]
                    j00 += dN[v, 0] * px
                    j01 += dN[v, 1] * px
                    j10 += dN[v, 0] * py
                    j11 += dN[v, 1] * py
                    r += N[v] * px
                det = j00 * j11 - j01 * j10
                w = abs(det) * (2.0 * np.pi * r if axisymmetric else 1.0)
                W[q] = w
                vol += w
                for v in range(4):
                    # d N / d x = J^-T d N / d xi, J = [[dx/dxi, dx/deta], [dy/dxi, dy/deta]]
                    gx = (j11 * dN[v, 0] - j10 * dN[v, 1]) / det
                    gy = (-j01 * dN[v, 0] + j00 * dN[v, 1]) / det
                    B[q, 0, 2 * v] = gx                  # rr
                    B[q, 1, 2 * v + 1] = gy              # zz
                    if axisymmetric:
                        B[q, 2, 2 * v] = N[v] / r        # hoop
                    B[q, 3, 2 * v] = gy                  # engineering shear
                    B[q, 3, 2 * v + 1] = gx
                q += 1
        bbar = np.zeros(8)
        for q in range(4):
            for i in range(8):
                bbar[i] += (B[q, 0, i] + B[q, 1, i] + B[q, 2, i]) * W[q] / vol
        K[:] = 0.0
        for q in range(4):
            tr = B[q, 0] + B[q, 1] + B[q, 2]
            vb = bbar if fbar else tr
            for i in range(8):
                for j in range(8):
                    dev = 0.0
                    for s in range(3):
                        dev += 2.0 * m * (B[q, s, i] - tr[i] / 3.0) * (B[q, s, j] - tr[j] / 3.0)
                    dev += m * B[q, 3, i] * B[q, 3, j]
                    K[i, j] += (dev + kap * vb[i] * vb[j]) * W[q]
        out[k] = element_step(K, mass[c], 2)
    return out


@numba.njit(cache=True)
def element_step(K, mass_c, bs):
    """2 / omega_max [s] of an element of stiffness K (n, n) [N/mm] and nodal masses mass_c (n / bs,)
    [tonne] (bs dofs per node): omega_max^2 the largest eigenvalue of M^-1/2 K M^-1/2 (inf if none is
    positive). K is overwritten. Quadrilaterals (:func:`_quad_eig_dt`) and hexahedra
    (:func:`fenics_plast.solvers.hex_step.hex_eig_dt`)."""
    n = K.shape[0]
    for i in range(n):
        for j in range(n):
            K[i, j] /= np.sqrt(mass_c[i // bs] * mass_c[j // bs])
    w2 = np.linalg.eigvalsh(K)[-1]
    return 2.0 / np.sqrt(w2) if w2 > 0.0 else np.inf


@numba.njit(cache=True)
def _lazy_min(d, order, x, cell_dofs, mass, lam, mu, scale_sqrt, axisymmetric, fbar):
    """min over the cells of max(d[c], e[c] sqrt(s_c)) (e: :func:`_quad_eig_dt`), visiting the cells in
    the order of d (ascending, ``order``) and stopping when d reaches the minimum found: the
    eigenvalue is computed for the few cells whose size estimate d is below the result. Returns
    (minimum, cell)."""
    best = np.inf
    arg = -1
    one = np.empty(1, dtype=np.int64)
    e = np.empty(1)
    for k in range(order.shape[0]):
        c = order[k]
        if d[c] >= best:
            break
        one[0] = c
        _quad_eig_dt(x, cell_dofs, one, mass, lam, mu, axisymmetric, fbar, e)
        v = max(d[c], e[0] * scale_sqrt[c])
        if v < best:
            best = v
            arg = c
    return best, arg


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
#: status (``ExplicitDynamics._internal_force``, :meth:`Drivers.step`): a cell folds, on some rank
STEP_FOLDS = -3


@_njit
def advance(nsteps, dt, v, a, free_minv, du, n, force_args, work, mass, walls, kept):
    """``nsteps`` central-difference steps of size dt in one call (serial runs, fused force).

    force_args : the arguments of :func:`fused_force.internal_force` (u and u_n first, f last),
    whose arrays are updated in place; mass, walls: as :func:`stop_at_walls`.
    work : (1,) internal work [N mm], incremented step by step
    exactly as :meth:`ExplicitDynamics.step` does (so the result does not depend on how steps are
    grouped). kept (2, n): v and du (owned entries) before the step in progress, what the solver's
    ``_undo_step`` needs, with u_n, to go back to the last finite state.
    Returns (steps done, status): status :data:`STEP_OK`; or the owned cell that the next step
    folds (>= 0: :func:`fused_force.folded_cell`; that step wrote no state, stress or force, and
    u_n, kept restore its u, v, du); or :data:`STEP_NONFINITE` (the next step's stress or force is
    not finite: its material update is committed). The failed step is not among the steps done
    and its kick is not taken.
    """
    u, u_n, f = force_args[0], force_args[1], force_args[-1]
    for k in range(nsteps):
        kept[0, :n] = v[:n]             # (slices: a call here slowed the 3-D loop by 10 %)
        kept[1, :n] = du[:n]
        w_old = kick_drift(v, a, f, du, u, u_n, dt, n, mass, walls)
        bad = folded_cell(*force_args)
        if bad >= 0:
            return k, bad
        if not update_and_force(*force_args):
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


PLANE, CIRCLE, GENERIC = 0, 1, -1
SPHERE, CYLINDER, TORUS = 2, 3, 4           # 3-D kinds (PLANE and GENERIC serve both dimensions)
COULOMB, QUASI_COULOMB = 0, 1
_TINY = 1e-300                              # as fenics_plast.tools._TINY: guarded normals


@_njit
def contact_forces(u, du, dt, X, cdofs, cpair, area, kind, params, eps, eps_t, mu, law, gN,
                   t_hist, N_hist, p_hist, t_scal, slip, fc, acc, pen, trans_old, trans_new, fcon):
    """Penalty contact of nodes against rigid tools, Coulomb friction as elastoplastic slip.

    Nodes k (all pairs concatenated): cdofs (nc, 2) their owned dofs, X (nc, 2) reference position
    [mm], cpair (nc,) pair index, area (nc,) tributary area int N_k w dA0 [mm^2]. Per pair p:
    kind PLANE (params: point x, y, normal x, y), CIRCLE (params: centre x, y, radius, -) or
    GENERIC (gap and normal given in gN (nc, 3) = (g, N_x, N_y), computed by the tool's gap_np);
    eps, eps_t normal and tangential penalties [N/mm^3], mu, law COULOMB | QUASI_COULOMB;
    trans_old, trans_new (npairs, 2) tool translation at t_n, t_{n+1} [mm].

    p = eps <-g> [MPa]; trial tangential traction t_tr = T . t_n - eps_t T . (du - dd) (T = (N_y,
    -N_x), t_n the traction vector of the last step, dd the tool's translation over the step),
    t = clamp(t_tr, -mu p_b, mu p_b); coulomb: N, p_b current, quasi-coulomb: N, p_b of the last
    step (history) and t = 0 out of contact. Force on the body fc = area (p N + t T) [N].

    History (t_hist (nc,2) [MPa], N_hist (nc,2), p_hist (nc,) [MPa], t_scal (nc,) [MPa]), the status
    slip (nc,) (1: in contact and slipping, i.e. |t_tr| > mu p_b or frictionless) and fc (nc, 2) [N]
    are updated in place; fcon (owned dofs) gets the nodal forces (zeroed first on the
    contact dofs). acc (npairs, 4) += contact energy E_c, tool work, impulse x, impulse y [N mm,
    N mm, N s, N s] (trapezoidal); pen (npairs,) running max of -g [mm].

    3-D (X (nc, 3)): :func:`contact_forces_3d`, the same law with vectors (shapes there).
    """
    if X.shape[1] == 3:
        contact_forces_3d(u, du, dt, X, cdofs, cpair, area, kind, params, eps, eps_t, mu, law, gN,
                          t_hist, N_hist, p_hist, t_scal, slip, fc, acc, pen, trans_old, trans_new, fcon)
        return
    nc = X.shape[0]
    for k in range(nc):
        fcon[cdofs[k, 0]] = 0.0
        fcon[cdofs[k, 1]] = 0.0
    for k in range(nc):
        pr = cpair[k]
        ix = cdofs[k, 0]
        iy = cdofs[k, 1]
        x = X[k, 0] + u[ix]
        y = X[k, 1] + u[iy]
        ddx = trans_new[pr, 0] - trans_old[pr, 0]
        ddy = trans_new[pr, 1] - trans_old[pr, 1]
        kd = kind[pr]
        if kd == PLANE:
            nx = params[pr, 2]
            ny = params[pr, 3]
            g = (x - (params[pr, 0] + trans_new[pr, 0])) * nx + (y - (params[pr, 1] + trans_new[pr, 1])) * ny
        elif kd == CIRCLE:
            rx = x - (params[pr, 0] + trans_new[pr, 0])
            ry = y - (params[pr, 1] + trans_new[pr, 1])
            dist = np.sqrt(rx * rx + ry * ry)
            g = dist - params[pr, 2]
            nx = rx / dist
            ny = ry / dist
        else:
            g = gN[k, 0]
            nx = gN[k, 1]
            ny = gN[k, 2]
        p = eps[pr] * (-g) if g < 0.0 else 0.0
        sx = du[ix] - ddx
        sy = du[iy] - ddy
        t = 0.0
        tx = 0.0
        ty = 0.0
        sl = 1.0 if g < 0.0 else 0.0
        if mu[pr] > 0.0:
            if law[pr] == COULOMB:
                nfx, nfy, bound, active = nx, ny, mu[pr] * p, True
            else:
                nfx, nfy, bound, active = N_hist[k, 0], N_hist[k, 1], mu[pr] * p_hist[k], g < 0.0
            tx = nfy
            ty = -nfx
            ttr = tx * t_hist[k, 0] + ty * t_hist[k, 1] - eps_t[pr] * (tx * sx + ty * sy)
            if active:
                t = min(max(ttr, -bound), bound)
            sl = 1.0 if (g < 0.0 and active and abs(ttr) > bound) else 0.0
        A = area[k]
        fx = A * (p * nx + t * tx)
        fy = A * (p * ny + t * ty)
        mx = 0.5 * (fc[k, 0] + fx)
        my = 0.5 * (fc[k, 1] + fy)
        acc[pr, 0] -= mx * sx + my * sy
        acc[pr, 1] += mx * ddx + my * ddy
        acc[pr, 2] += dt * mx
        acc[pr, 3] += dt * my
        fc[k, 0] = fx
        fc[k, 1] = fy
        fcon[ix] += fx
        fcon[iy] += fy
        t_hist[k, 0] = t * tx
        t_hist[k, 1] = t * ty
        N_hist[k, 0] = nx
        N_hist[k, 1] = ny
        p_hist[k] = p
        t_scal[k] = t
        slip[k] = sl
        if -g > pen[pr]:
            pen[pr] = -g


@_njit
def _tool_gap_3d(kd, prm, tr, x, N):
    """Gap [mm] of the point x (3,) to a compiled 3-D tool of kind kd, parameters prm (8,) and
    translation tr (3,) [mm]; its unit normal (tool into body) into N (3,).

    PLANE (point (3), normal (3)); SPHERE (centre (3), radius); CYLINDER (point on the axis (3),
    unit axis (3), radius); TORUS (centre (3), unit axis (3), ring radius, tube radius).  Normals
    are guarded with _TINY where they are undefined (sphere centre, cylinder or torus axis)."""
    y0 = x[0] - (prm[0] + tr[0])
    y1 = x[1] - (prm[1] + tr[1])
    y2 = x[2] - (prm[2] + tr[2])
    if kd == PLANE:
        N[0] = prm[3]
        N[1] = prm[4]
        N[2] = prm[5]
        return y0 * N[0] + y1 * N[1] + y2 * N[2]
    if kd == SPHERE:
        dist = np.sqrt(y0 * y0 + y1 * y1 + y2 * y2 + _TINY)
        N[0] = y0 / dist
        N[1] = y1 / dist
        N[2] = y2 / dist
        return dist - prm[3]
    a = y0 * prm[3] + y1 * prm[4] + y2 * prm[5]            # axial coordinate
    r0 = y0 - a * prm[3]
    r1 = y1 - a * prm[4]
    r2 = y2 - a * prm[5]
    rho = np.sqrt(r0 * r0 + r1 * r1 + r2 * r2 + _TINY)
    if kd == CYLINDER:
        N[0] = r0 / rho
        N[1] = r1 / rho
        N[2] = r2 / rho
        return rho - prm[6]
    # TORUS: distance to the centre circle of radius prm[6] in the plane a = 0
    dr = rho - prm[6]
    dist = np.sqrt(dr * dr + a * a + _TINY)
    N[0] = dr / dist * r0 / rho + a / dist * prm[3]
    N[1] = dr / dist * r1 / rho + a / dist * prm[4]
    N[2] = dr / dist * r2 / rho + a / dist * prm[5]
    return dist - prm[7]


@_njit
def contact_forces_3d(u, du, dt, X, cdofs, cpair, area, kind, params, eps, eps_t, mu, law, gN,
                      t_hist, N_hist, p_hist, t_scal, slip, fc, acc, pen, trans_old, trans_new, fcon):
    """:func:`contact_forces` in 3-D: the tangential traction is a vector of the tangent plane.

    Shapes: X (nc, 3) [mm], cdofs (nc, 3), params (npairs, 8) (see :func:`_tool_gap_3d`; kinds
    PLANE, SPHERE, CYLINDER, TORUS, or GENERIC with gN (nc, 4) = (g, N) from the tool's gap_np),
    trans_old, trans_new (npairs, 3) [mm], t_hist (nc, 3) [MPa], N_hist (nc, 3), fc (nc, 3) [N],
    acc (npairs, 5) += (E_c, tool work, impulse x, y, z) [N mm, N mm, N s x 3].

    p = eps <-g>; with the relative displacement increment s = du - dd and the normal N_f of the
    tangent plane (coulomb: N now, bound mu p; quasi-coulomb: N_hist, bound mu p_hist, t = 0 out
    of contact), P_T = I - N_f N_f^T: t_tr = P_T (t_n - eps_t s), t = t_tr if |t_tr| <= bound, else
    bound t_tr / |t_tr| (return map on the norm; 2-D: T T^T = P_T, the same law).  t_hist gets the
    vector t, t_scal its norm |t| [MPa]; slip, fc, fcon, N_hist, p_hist, pen as in 2-D.
    """
    nc = X.shape[0]
    x = np.empty(3)
    N = np.empty(3)
    for k in range(nc):
        for j in range(3):
            fcon[cdofs[k, j]] = 0.0
    for k in range(nc):
        pr = cpair[k]
        for j in range(3):
            x[j] = X[k, j] + u[cdofs[k, j]]
        kd = kind[pr]
        if kd == GENERIC:
            g = gN[k, 0]
            for j in range(3):
                N[j] = gN[k, 1 + j]
        else:
            g = _tool_gap_3d(kd, params[pr], trans_new[pr], x, N)
        p = eps[pr] * (-g) if g < 0.0 else 0.0
        s0 = du[cdofs[k, 0]] - (trans_new[pr, 0] - trans_old[pr, 0])
        s1 = du[cdofs[k, 1]] - (trans_new[pr, 1] - trans_old[pr, 1])
        s2 = du[cdofs[k, 2]] - (trans_new[pr, 2] - trans_old[pr, 2])
        t0 = 0.0
        t1 = 0.0
        t2 = 0.0
        sl = 1.0 if g < 0.0 else 0.0
        if mu[pr] > 0.0:
            if law[pr] == COULOMB:
                nf0, nf1, nf2, bound, active = N[0], N[1], N[2], mu[pr] * p, True
            else:
                nf0, nf1, nf2 = N_hist[k, 0], N_hist[k, 1], N_hist[k, 2]
                bound, active = mu[pr] * p_hist[k], g < 0.0
            q0 = t_hist[k, 0] - eps_t[pr] * s0
            q1 = t_hist[k, 1] - eps_t[pr] * s1
            q2 = t_hist[k, 2] - eps_t[pr] * s2
            qn = q0 * nf0 + q1 * nf1 + q2 * nf2
            q0 -= qn * nf0
            q1 -= qn * nf1
            q2 -= qn * nf2
            norm = np.sqrt(q0 * q0 + q1 * q1 + q2 * q2)
            over = norm > bound
            if active:
                scale = bound / norm if over else 1.0
                t0 = scale * q0
                t1 = scale * q1
                t2 = scale * q2
            sl = 1.0 if (g < 0.0 and active and over) else 0.0
        A = area[k]
        f0 = A * (p * N[0] + t0)
        f1 = A * (p * N[1] + t1)
        f2 = A * (p * N[2] + t2)
        m0 = 0.5 * (fc[k, 0] + f0)
        m1 = 0.5 * (fc[k, 1] + f1)
        m2 = 0.5 * (fc[k, 2] + f2)
        acc[pr, 0] -= m0 * s0 + m1 * s1 + m2 * s2
        acc[pr, 1] += (m0 * (trans_new[pr, 0] - trans_old[pr, 0]) + m1 * (trans_new[pr, 1] - trans_old[pr, 1])
                       + m2 * (trans_new[pr, 2] - trans_old[pr, 2]))
        acc[pr, 2] += dt * m0
        acc[pr, 3] += dt * m1
        acc[pr, 4] += dt * m2
        fc[k, 0] = f0
        fc[k, 1] = f1
        fc[k, 2] = f2
        fcon[cdofs[k, 0]] += f0
        fcon[cdofs[k, 1]] += f1
        fcon[cdofs[k, 2]] += f2
        t_hist[k, 0] = t0
        t_hist[k, 1] = t1
        t_hist[k, 2] = t2
        for j in range(3):
            N_hist[k, j] = N[j]
        p_hist[k] = p
        t_scal[k] = np.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
        slip[k] = sl
        if -g > pen[pr]:
            pen[pr] = -g


@_njit
def advance_general(nsteps, dt, v, a, free_minv, mass, du, n, force_args, fload, fload_rows,
                    pdofs, pkind, pset, pvals, pv_old, r_old, reac, wset, fcon, contact_args, trans, work, walls,
                    kept):
    """``nsteps`` steps of a serial, fused-force run with prescribed motion, loads and contact (the
    same kernels, in the same order, as the step-by-step path of ExplicitDynamics).

    fload_rows (nsteps, n) or (nsteps, 0): the load vector at the step ends (none: fload stays);
    pvals (nsteps, np, 2) the prescribed values of each step; contact_args: the arguments of
    :func:`contact_forces` from X to pen; trans (nsteps + 1, npairs, 2) the tool translations at
    the step times. work (2,) += internal work, load work [N mm]; walls: as :func:`stop_at_walls`;
    kept (2, n): as :func:`advance`. Returns (steps done, status) as :func:`advance` (a failed step
    stops before its loads, contact and kick).
    """
    u, u_n, f = force_args[0], force_args[1], force_args[-1]
    has_load = fload_rows.shape[1] > 0
    has_contact = contact_args[0].shape[0] > 0
    for k in range(nsteps):
        kept[0, :n] = v[:n]
        kept[1, :n] = du[:n]
        wi0, wl0 = drift_general(v, a, f, fload, fcon, mass, du, u, u_n, dt, n, pdofs, pkind, pvals[k],
                                 pv_old, r_old, walls)
        bad = folded_cell(*force_args)
        if bad >= 0:
            return k, bad
        if not update_and_force(*force_args):
            return k, STEP_NONFINITE
        if has_load:
            fload[:] = fload_rows[k]
        if has_contact:
            contact_forces(u, du, dt, *contact_args, trans[k], trans[k + 1], fcon)
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
        mass = solver._reduce(float(solver.mass[0::self.bs].sum()), MPI.SUM)
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
        s._internal_force()
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
        pass (``ExplicitDynamics._internal_force``, the same on every rank): a failed step stops
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
        status = s._internal_force()
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
        out = advance_general(nsteps, dt, s.v.x.array, s.a, s.free_minv, s.mass, s.du, self.n, s._force_args,
                              self.fload, d.fload_rows, self.pdofs, self.pkind, self.pset, d.pvals, self.pv_old,
                              self.r_old, self.reac, self.wset, self.fcon, s.contact.args(), d.trans, work,
                              s.walls.args, s._kept)
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
        return 1.5 * (s.KE0 + abs(s._reduce(loc, MPI.SUM)) + self.E0_stored) + self.ke_floor

    # -- checkpoints -------------------------------------------------------------------------
    def state_dict(self, kv):
        """fload, fcon [N] (keyed by dof), reac [N] (by prescribed dof), summed W_load, W_sets
        [N mm], E0_stored, and the contact pairs' state (ContactSet.state_dict)."""
        from fenics_plast.checkpoint import Keyed
        s, n = self.s, self.n
        d = dict(fload=Keyed(self.fload.copy(), kv[:n]), fcon=Keyed(self.fcon.copy(), kv[:n]),
                 reac=Keyed(self.reac.copy(), kv[self.pdofs]), W_load=s._reduce(self.W_load, MPI.SUM),
                 W_sets=[s._reduce(float(w), MPI.SUM) for w in self.wset], E0_stored=self.E0_stored)
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
