r"""The penalty contact law of one node, compiled: the one law of every contact pair in both solvers.

Called per node by the explicit kernels (:mod:`~fenics_plast.solvers.contact_kernels`: rigid tools and master
surfaces of the body), the static solver's tool contact (:mod:`~fenics_plast.solvers.static_tool_contact`,
with the tangent) and its contact between facet groups (:mod:`~fenics_plast.solvers.static_surface_contact`).
The UFL forms of :class:`fenics_plast.contact.ContactPair` write the same law and are its definition in the
static solver (``tests/test_static_tool_contact.py`` holds the two together).

Seed eqs. 17-18 (normal) and 19-25 (friction as elastoplastic slip), slip a vector in the tangent plane:

    p = eps <-g>                                   (pressure [MPa], g the gap [mm], N the normal into the body)
    r = t_n - eps_T s,   q = P_f r,   P_f = I - N_f N_f^T       (trial tangential traction)
    t = q  if |q|^2 <= b^2  (stick),   t = b q / |q|  otherwise (slip: the return map on the norm)
    f = A (p N + t)                                (force on the node's body [N], A its tributary area)

s the slip since the history's state (the node's displacement relative to the tool or to the master point
[mm]), t_n the traction of that state; coulomb: N_f = N, b = mu p; quasi-coulomb (seed eq. 24): N_f = N_n,
b = mu p_n of that state (symmetric tangent). A node apart (g >= 0) carries no force in either law. 2-D is
the special case P_f = T T^T, T = (N_y, -N_x).

The tangent df/dx (x the node's position, s moving with it: ds/dx = I; dN/dx given, the tool's curvature):

    dp/dx = -eps N^T,   d(pN)/dx = N dp/dx + p dN/dx,
    dq/dx = -eps_T P_f - (N_f . r) dN_f/dx - N_f (dN_f/dx^T r)^T     (dN_f/dx = dN/dx coulomb, 0 quasi-coulomb)
    stick: dt/dx = dq/dx;   slip: dt/dx = q^ db/dx + (b / |q|) (I - q^ q^^T) dq/dx,  q^ = q / |q|.

Units mm, N, MPa.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

from fenics_plast.solvers.tool_gaps import FLAGS

COULOMB, QUASI_COULOMB = 0, 1


@numba.njit(cache=True, **FLAGS)
def node_law(g, N, dN, s, t_n, N_n, p_n, area, eps, eps_t, mu, law, f, t, K):
    """The law of one node (module docstring) in ``dim`` = len(N) dimensions.

    g [mm]; N (dim,) the normal; dN (dim, dim) [1/mm] dN_i/dx_j (read only when K is written); s (dim,) [mm]
    the slip; t_n (dim,) [MPa], N_n (dim,), p_n [MPa] the history's traction, normal and pressure; area
    [mm^2]; eps, eps_t [N/mm^3]; mu; law COULOMB | QUASI_COULOMB.

    Writes f (dim,) [N] the force on the body, t (dim,) [MPa] the tangential traction and, when K has
    dim rows (pass a (0, 0) array to skip it), K (dim, dim) [N/mm] = df/dx. Returns (p [MPa], slip): slip 1.0
    in contact and slipping (frictionless: in contact), else 0.0."""
    dim = N.shape[0]
    tangent = K.shape[0] == dim
    for i in range(dim):
        f[i] = 0.0
        t[i] = 0.0
    if tangent:
        K[:, :] = 0.0
    if g >= 0.0:
        return 0.0, 0.0
    p = eps * -g                                                                   # eqs. 17-18
    for i in range(dim):
        f[i] = area * p * N[i]
    if tangent:
        for i in range(dim):
            for j in range(dim):
                K[i, j] = area * (-eps * N[i] * N[j] + p * dN[i, j])               # d(pN)/dx
    if mu <= 0.0:
        return p, 1.0
    coulomb = law == COULOMB
    Nf = N if coulomb else N_n                                                     # eq. 24: N_n, p_n frozen
    b = mu * p if coulomb else mu * p_n
    rn = 0.0
    for i in range(dim):
        rn += Nf[i] * (t_n[i] - eps_t * s[i])
    qq = 0.0
    for i in range(dim):
        t[i] = t_n[i] - eps_t * s[i] - rn * Nf[i]                                  # q (eqs. 19-21), for now
        qq += t[i] * t[i]
    stick = qq <= b * b
    qn = math.sqrt(qq)
    if tangent:
        dq = np.empty((dim, dim))
        for i in range(dim):
            for j in range(dim):
                dq[i, j] = -eps_t * ((1.0 if i == j else 0.0) - Nf[i] * Nf[j])
        if coulomb:                     # the tangent plane turns with N
            for j in range(dim):
                Dr = 0.0                # (dN/dx^T r)_j
                for i in range(dim):
                    Dr += dN[i, j] * (t_n[i] - eps_t * s[i])
                for i in range(dim):
                    dq[i, j] -= rn * dN[i, j] + Nf[i] * Dr
        if stick:
            for i in range(dim):
                for j in range(dim):
                    K[i, j] += area * dq[i, j]
        else:                           # t still holds q
            for i in range(dim):
                for j in range(dim):
                    P = 0.0             # ((I - q^ q^^T) dq/dx)_ij
                    for m in range(dim):
                        P += ((1.0 if i == m else 0.0) - t[i] * t[m] / qq) * dq[m, j]
                    db = -mu * eps * N[j] if coulomb else 0.0
                    K[i, j] += area * (t[i] / qn * db + b / qn * P)
    if not stick:                                                                  # eq. 22: |t| = b
        for i in range(dim):
            t[i] *= b / qn
    for i in range(dim):
        f[i] += area * t[i]
    return p, 0.0 if stick else 1.0


class ContactNodes(NamedTuple):
    """A contact pair's owned group nodes now (each pair's ``contact_nodes()``): what the contact outputs
    (:mod:`fenics_plast.quantities.kinds.contact_area` and its siblings) and fields read."""
    x: np.ndarray        # (n, dim) current positions [mm]
    g: np.ndarray        # (n,) gaps [mm], negative: pressed in (inf: no master facet found)
    p: np.ndarray        # (n,) normal pressures [MPa]
    area: np.ndarray     # (n,) tributary reference areas [mm^2] (2 pi R included in axisymmetry)
    nodes: np.ndarray    # (n,) the nodes' indices (blocks) in the displacement's CG1 space
    slip: np.ndarray     # (n,) bool: in contact and slipping (frictionless: every node in contact)


class NodeHistory:
    """The state of a pair's nodes at the last commit that :func:`node_law` reads: traction t_n (n, dim) [MPa],
    normal N_n (n, dim) and pressure p_n (n,) [MPa], with their checkpoint keys: ``node_keys`` (n,) the key of
    each node's first displacement component (node * SLOTS, :func:`fenics_plast.checkpoint.dof_keys`), the
    history's components keyed node * SLOTS + 0 .. 2 dim (as the forms' CG1 history Function: either static
    route restarts from the other's checkpoint)."""

    def __init__(self, n, dim, node_keys):
        self.dim = dim
        self.t_n, self.N_n, self.p_n = np.zeros((n, dim)), np.zeros((n, dim)), np.zeros(n)
        self.keys = (np.asarray(node_keys, dtype=np.int64)[:, None] + np.arange(2 * dim + 1)).ravel()

    def store(self, t, N, p):
        """Commit the tractions t (n, dim), normals N (n, dim) and pressures p (n,) of the current state."""
        self.t_n[:], self.N_n[:], self.p_n[:] = t, N, p

    def keyed(self):
        """(values (n (2 dim + 1),), keys) for a checkpoint."""
        return np.concatenate([self.t_n, self.N_n, self.p_n[:, None]], axis=1).ravel(), self.keys

    def load(self, values):
        """Restore :meth:`keyed`'s values (in this history's node order)."""
        d = self.dim
        h = np.asarray(values).reshape(-1, 2 * d + 1)
        self.store(h[:, :d], h[:, d:2 * d], h[:, 2 * d])
