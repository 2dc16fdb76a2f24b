r"""Compiled penalty contact of body nodes against rigid tools, Coulomb friction as elastoplastic slip.

The kernels of :mod:`fenics_plast.solvers.explicit_contact` (which builds their arrays: nodes, tributary
areas, tools' shape codes and parameters, penalties, the nodal history): :func:`contact_forces` (2-D;
it hands 3-D data to :func:`contact_forces_3d`). The gaps are the tool shapes' own formulas, compiled
(:mod:`fenics_plast.solvers.tool_gaps`). Called every step by the explicit solver's integrator
(:mod:`fenics_plast.solvers.integrator`). Units mm, N, MPa, s.

Per pair (trapezoidal over each step, du the node's displacement increment and dd the tool's
translation over the step): energy taken up by the contact (penalty energy + frictional dissipation)
E_c += -(f_c,n + f_c,n+1)/2 . (du - dd), and the work of the moving tool
W_tool += (F_c,n + F_c,n+1)/2 . dd.

Codes: a tool's kind is its shape's code (:mod:`fenics_plast.tool_shapes`), :data:`GENERIC` (gap and
normal given, from the tool's ``gap_np``) or :data:`BODY` (a master surface of the body,
:mod:`fenics_plast.solvers.body_surface`: gap, normal and the increment dd of the nearest master point
given per node; dd takes the tool translation's place in the slip and the energy, and the pair does no
tool work; the reactions on the master nodes are added by the caller); friction laws :data:`COULOMB`,
:data:`QUASI_COULOMB`.
"""
from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np

from fenics_plast.solvers.contact_law import COULOMB, QUASI_COULOMB, node_law  # noqa: F401 (the laws' codes)
from fenics_plast.solvers.tool_gaps import FLAGS, gap_2d, gap_3d

_njit = numba.njit(cache=True, **FLAGS)

GENERIC = -1                    # a tool whose gap and normal come from its gap_np (any other kind: a shape code)
BODY = -2                       # a master surface of the body: gap, normal and the master point's increment given


class ContactArrays(NamedTuple):
    """The arrays of :func:`contact_forces`: the nodes of all pairs concatenated (nc rows), the pairs'
    data (npairs rows), the nodal history and the accumulators (shapes and units there)."""
    X: np.ndarray           # (nc, dim) reference positions [mm]
    dofs: np.ndarray        # (nc, dim) the nodes' owned dofs
    pair: np.ndarray        # (nc,) pair index of each node
    area: np.ndarray        # (nc,) tributary areas [mm^2]
    kind: np.ndarray        # (npairs,) tool shape codes or GENERIC
    params: np.ndarray      # (npairs, m) tool parameter vectors
    eps: np.ndarray         # (npairs,) normal penalties [N/mm^3]
    eps_t: np.ndarray       # (npairs,) tangential penalties [N/mm^3]
    mu: np.ndarray          # (npairs,) friction coefficients
    law: np.ndarray         # (npairs,) COULOMB | QUASI_COULOMB
    gN: np.ndarray          # (nc, 1 + dim) given gaps and normals of GENERIC tools and BODY surfaces
    dd_node: np.ndarray     # (nc, dim) BODY: the increment of the node's nearest master point over the step [mm]
    t_hist: np.ndarray      # (nc, dim) tangential tractions [MPa]
    N_hist: np.ndarray      # (nc, dim) normals
    p_hist: np.ndarray      # (nc,) pressures [MPa]
    t_scal: np.ndarray      # (nc,) tangential traction, signed (2-D) or its norm (3-D) [MPa]
    slip: np.ndarray        # (nc,) 1 where in contact and slipping
    fc: np.ndarray          # (nc, dim) nodal contact forces [N]
    acc: np.ndarray         # (npairs, 2 + dim) contact energy, tool work [N mm], impulse [N s]
    pen: np.ndarray         # (npairs,) the run's largest penetration [mm]


@_njit
def contact_forces(u, du, dt, c, trans_old, trans_new, fcon):
    """Penalty contact of nodes against rigid tools, Coulomb friction as elastoplastic slip; c the
    :class:`ContactArrays`, u, du (owned dofs) the displacement and its increment over the step [mm].

    Nodes k (all pairs concatenated): cdofs (nc, 2) their owned dofs, X (nc, 2) reference position
    [mm], cpair (nc,) pair index, area (nc,) tributary area int N_k w dA0 [mm^2]. Per pair p:
    kind the tool's shape code with its parameter vector params[p] (:func:`~fenics_plast.solvers.tool_gaps.gap_2d`)
    or GENERIC (gap and normal given in gN (nc, 3) = (g, N_x, N_y), computed by the tool's gap_np) or BODY
    (gN given, and the master point's increment dd_node (nc, 2) [mm] in place of the tool's translation);
    eps, eps_t normal and tangential penalties [N/mm^3], mu, law COULOMB | QUASI_COULOMB;
    trans_old, trans_new (npairs, 2) tool translation at t_n, t_{n+1} [mm].

    The law at each node is :func:`~fenics_plast.solvers.contact_law.node_law` (the one of both solvers):
    p = eps <-g> [MPa], the trial tangential traction from the last step's traction t_n and the slip
    s = du - dd (dd the tool's translation over the step), returned to |t| <= mu p_b (coulomb: N, p_b current;
    quasi-coulomb: N, p_b of the last step, t = 0 out of contact). Force on the body fc = area (p N + t) [N].

    History (t_hist (nc,2) [MPa], N_hist (nc,2), p_hist (nc,) [MPa], t_scal (nc,) [MPa]), the status
    slip (nc,) (1: in contact and slipping, i.e. |t_tr| > mu p_b or frictionless) and fc (nc, 2) [N]
    are updated in place; fcon (owned dofs) gets the nodal forces (zeroed first on the
    contact dofs). acc (npairs, 4) += contact energy E_c, tool work, impulse x, impulse y [N mm,
    N mm, N s, N s] (trapezoidal); pen (npairs,) running max of -g [mm].

    3-D (X (nc, 3)): :func:`contact_forces_3d`, the same law with vectors (shapes there).
    """
    if c.X.shape[1] == 3:
        contact_forces_3d(u, du, dt, c, trans_old, trans_new, fcon)
        return
    X, cdofs, cpair, area, kind, params, gN = c.X, c.dofs, c.pair, c.area, c.kind, c.params, c.gN
    eps, eps_t, mu, law, acc, pen = c.eps, c.eps_t, c.mu, c.law, c.acc, c.pen
    t_hist, N_hist, p_hist, t_scal, slip, fc = c.t_hist, c.N_hist, c.p_hist, c.t_scal, c.slip, c.fc
    nc = X.shape[0]
    N, s, f, t = np.empty(2), np.empty(2), np.empty(2), np.empty(2)
    no_dN, no_K = np.empty((2, 2)), np.empty((0, 0))
    for k in range(nc):
        fcon[cdofs[k, 0]] = 0.0
        fcon[cdofs[k, 1]] = 0.0
    for k in range(nc):
        pr = cpair[k]
        ix = cdofs[k, 0]
        iy = cdofs[k, 1]
        x = X[k, 0] + u[ix]
        y = X[k, 1] + u[iy]
        kd = kind[pr]
        if kd == BODY:
            ddx = c.dd_node[k, 0]
            ddy = c.dd_node[k, 1]
        else:
            ddx = trans_new[pr, 0] - trans_old[pr, 0]
            ddy = trans_new[pr, 1] - trans_old[pr, 1]
        if kd < 0:
            g = gN[k, 0]
            nx = gN[k, 1]
            ny = gN[k, 2]
        else:
            g, n = gap_2d(kd, params[pr], (x, y), (trans_new[pr, 0], trans_new[pr, 1]))
            nx = n[0]
            ny = n[1]
        N[0] = nx
        N[1] = ny
        s[0] = du[ix] - ddx
        s[1] = du[iy] - ddy
        tf0 = N_hist[k, 1]                # T of the friction's normal: coulomb N, quasi-coulomb N_hist
        tf1 = -N_hist[k, 0]
        if law[pr] == COULOMB:
            tf0 = ny
            tf1 = -nx
        p, sl = node_law(g, N, no_dN, s, t_hist[k], N_hist[k], p_hist[k], area[k], eps[pr], eps_t[pr], mu[pr],
                         law[pr], f, t, no_K)
        sx = s[0]
        sy = s[1]
        fx = f[0]
        fy = f[1]
        mx = 0.5 * (fc[k, 0] + fx)
        my = 0.5 * (fc[k, 1] + fy)
        acc[pr, 0] -= mx * sx + my * sy
        if kd != BODY:
            acc[pr, 1] += mx * ddx + my * ddy
        acc[pr, 2] += dt * mx
        acc[pr, 3] += dt * my
        fc[k, 0] = fx
        fc[k, 1] = fy
        fcon[ix] += fx
        fcon[iy] += fy
        t_hist[k, 0] = t[0]
        t_hist[k, 1] = t[1]
        N_hist[k, 0] = nx
        N_hist[k, 1] = ny
        p_hist[k] = p
        t_scal[k] = t[0] * tf0 + t[1] * tf1
        slip[k] = sl
        if -g > pen[pr]:
            pen[pr] = -g


@_njit
def contact_forces_3d(u, du, dt, c, trans_old, trans_new, fcon):
    """:func:`contact_forces` in 3-D: the tangential traction is a vector of the tangent plane.

    Shapes: X (nc, 3) [mm], cdofs (nc, 3), params (npairs, m) (:func:`~fenics_plast.solvers.tool_gaps.gap_3d`;
    or kind GENERIC with gN (nc, 4) = (g, N) from the tool's gap_np),
    trans_old, trans_new (npairs, 3) [mm], t_hist (nc, 3) [MPa], N_hist (nc, 3), fc (nc, 3) [N],
    acc (npairs, 5) += (E_c, tool work, impulse x, y, z) [N mm, N mm, N s x 3].

    The law of :func:`~fenics_plast.solvers.contact_law.node_law`: the trial traction P_T (t_n - eps_t s),
    s = du - dd, returned on its norm to the bound (2-D: T T^T = P_T, the same law).  t_hist gets the
    vector t, t_scal its norm |t| [MPa]; slip, fc, fcon, N_hist, p_hist, pen as in 2-D.
    """
    X, cdofs, cpair, area, kind, params, gN = c.X, c.dofs, c.pair, c.area, c.kind, c.params, c.gN
    eps, eps_t, mu, law, acc, pen = c.eps, c.eps_t, c.mu, c.law, c.acc, c.pen
    t_hist, N_hist, p_hist, t_scal, slip, fc = c.t_hist, c.N_hist, c.p_hist, c.t_scal, c.slip, c.fc
    nc = X.shape[0]
    N, s, f, t = np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    no_dN, no_K = np.empty((3, 3)), np.empty((0, 0))
    for k in range(nc):
        for j in range(3):
            fcon[cdofs[k, j]] = 0.0
    for k in range(nc):
        pr = cpair[k]
        kd = kind[pr]
        if kd == BODY:
            dd0, dd1, dd2 = c.dd_node[k, 0], c.dd_node[k, 1], c.dd_node[k, 2]
        else:
            dd0 = trans_new[pr, 0] - trans_old[pr, 0]
            dd1 = trans_new[pr, 1] - trans_old[pr, 1]
            dd2 = trans_new[pr, 2] - trans_old[pr, 2]
        if kd < 0:
            g = gN[k, 0]
            for j in range(3):
                N[j] = gN[k, 1 + j]
        else:
            x = (X[k, 0] + u[cdofs[k, 0]], X[k, 1] + u[cdofs[k, 1]], X[k, 2] + u[cdofs[k, 2]])
            g, n = gap_3d(kd, params[pr], x, (trans_new[pr, 0], trans_new[pr, 1], trans_new[pr, 2]))
            for j in range(3):
                N[j] = n[j]
        s[0] = du[cdofs[k, 0]] - dd0
        s[1] = du[cdofs[k, 1]] - dd1
        s[2] = du[cdofs[k, 2]] - dd2
        p, sl = node_law(g, N, no_dN, s, t_hist[k], N_hist[k], p_hist[k], area[k], eps[pr], eps_t[pr], mu[pr],
                         law[pr], f, t, no_K)
        s0, s1, s2 = s[0], s[1], s[2]
        f0, f1, f2 = f[0], f[1], f[2]
        t0, t1, t2 = t[0], t[1], t[2]
        m0 = 0.5 * (fc[k, 0] + f0)
        m1 = 0.5 * (fc[k, 1] + f1)
        m2 = 0.5 * (fc[k, 2] + f2)
        acc[pr, 0] -= m0 * s0 + m1 * s1 + m2 * s2
        if kd != BODY:
            acc[pr, 1] += m0 * dd0 + m1 * dd1 + m2 * dd2
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
