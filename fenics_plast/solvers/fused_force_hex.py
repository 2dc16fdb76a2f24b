r"""The fused internal-force pass on trilinear hexahedra (geometry "3d"): its kinematics and nodal force.

:func:`fenics_plast.solvers.fused_force.internal_force` runs these two passes around the material
update when its arrays are those of hexahedra (``Finv`` of shape (n, 3, 3); the quadrilateral
passes take (n, 5)), so the explicit solver's compiled step loops
(:mod:`fenics_plast.solvers.integrator`) serve 2-D and 3-D alike. Equations (DESIGN.md,
"R_u"; units mm, N, MPa):

    F       = I + Grad u  (full 3x3, u a 3-vector field),  F_n likewise from u_n
    theta_c = sum_q J_q W_q / sum_q W_q                       mean dilatation of cell c (Q1/P0)
    Fu      = ((theta J_n) / (theta_n J))^(1/3) F F_n^-1       F-bar increment (seed eq. 10)
    f_ai    = sum_q (J / theta) (tau F^-T)_ij Grad_j N_a W_q   nodal force [N]

with W_q = |det J0(X_q)| q_w (weight 1 in 3-D) and Grad the reference gradient; element "q1" uses
theta = J. The points are the default basix rule of degree 2 on the hexahedron (2 x 2 x 2 Gauss,
the rule of ``QuadratureMap`` and ``Kinematics.dx``), the vertex order basix's tensor-product one
(vertex a at (a & 1, (a >> 1) & 1, (a >> 2) & 1) of the unit cube).

The definition is the UFL residual ``Kinematics.internal_virtual_work`` (assembled by dolfinx on
the explicit solver's ``internal_force = "ufl"`` route); ``tests/test_fused_force_3d.py`` holds
this pass's force, stress and state to it to 1e-12 on a yielding state of distorted hexahedra
(both elements, both material models).
"""
from __future__ import annotations

import math

import numba
import numpy as np

from fenics_plast.material import kernels
from fenics_plast.solvers.fused_cells import erodes, fbar_points, record_fold, sum_is_finite

_njit = numba.njit(cache=True, nogil=True, fastmath={"contract", "arcp", "nsz"})

#: the reference coordinates (0 or 1) of the 8 vertices of basix's hexahedron, (8, 3)
HEX_VERTICES = np.array([[a & 1, (a >> 1) & 1, (a >> 2) & 1] for a in range(8)], dtype=float)


def hex_shape_functions(points):
    """Trilinear shape functions N (nq, 8) and their reference gradients dN/dxi (nq, 8, 3) at the
    reference points (nq, 3) of the unit cube, basix vertex order."""
    points = np.asarray(points, dtype=float)
    nq = points.shape[0]
    N = np.ones((nq, 8))
    dN = np.ones((nq, 8, 3))
    for a in range(8):
        for k in range(3):
            one = HEX_VERTICES[a, k] == 1.0
            f = points[:, k] if one else 1.0 - points[:, k]       # the factor of direction k
            df = 1.0 if one else -1.0
            N[:, a] *= f
            for m in range(3):
                dN[:, a, m] *= df if m == k else f
    return N, dN


def hex_quadrature(degree):
    """Points (nq, 3) and weights (nq,) of the default basix rule on the reference hexahedron."""
    from fenics_plast.dolfinx_compat import quadrature_rule    # basix's call differs by version
    return quadrature_rule("hexahedron", degree)


class HexGeometry:
    """Reference-configuration data of trilinear hexahedra at the quadrature points.

    dNdX : (nc, nq, 8, 3) reference gradients of the 8 shape functions [1/mm].
    N : (nq, 8) shape function values.
    Rinv : (nc, nq) zeros (no hoop term in 3-D; kept so that the fused pass's arguments have the
        same layout as on quadrilaterals).
    W : (nc, nq) quadrature weights |det J0| q_w [mm^3].
    """

    def __init__(self, X_cells, points, weights):
        X_cells = np.asarray(X_cells, dtype=float)              # (nc, 8, 3), basix vertex order
        self.N, dN = hex_shape_functions(points)
        J0 = np.einsum("cak,qal->cqkl", X_cells, dN)             # dX_k / dxi_l
        det = np.linalg.det(J0)
        if (det <= 0).any():
            raise ValueError("inverted or degenerate hexahedron in the reference mesh (or vertices not in "
                             "basix order)")
        J0inv = np.linalg.inv(J0)                                # dxi_l / dX_k
        self.dNdX = np.ascontiguousarray(np.einsum("qal,cqlk->cqak", dN, J0inv))
        self.W = np.ascontiguousarray(det * weights[None, :])
        self.Rinv = np.zeros_like(self.W)


@_njit
def _adjugate(A, adj):
    """adj (3,3) = the adjugate of A (3,3) (the transposed cofactors: A adj = det A I); returns det A."""
    adj[0, 0] = A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1]
    adj[0, 1] = A[0, 2] * A[2, 1] - A[0, 1] * A[2, 2]
    adj[0, 2] = A[0, 1] * A[1, 2] - A[0, 2] * A[1, 1]
    adj[1, 0] = A[1, 2] * A[2, 0] - A[1, 0] * A[2, 2]
    adj[1, 1] = A[0, 0] * A[2, 2] - A[0, 2] * A[2, 0]
    adj[1, 2] = A[0, 2] * A[1, 0] - A[0, 0] * A[1, 2]
    adj[2, 0] = A[1, 0] * A[2, 1] - A[1, 1] * A[2, 0]
    adj[2, 1] = A[0, 1] * A[2, 0] - A[0, 0] * A[2, 1]
    adj[2, 2] = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
    return A[0, 0] * adj[0, 0] + A[0, 1] * adj[1, 0] + A[0, 2] * adj[2, 0]


@_njit
def _freeze_hex(c, nq, Fu, Finv, factor):
    """An eroded cell's points: Fu = F^-1 = I (the material update keeps the committed state and
    stress) and factor 0 (no nodal force)."""
    for q in range(nq):
        p = c * nq + q
        for i in range(3):
            for j in range(3):
                Fu[p, i, j] = 1.0 if i == j else 0.0
                Finv[p, i, j] = 1.0 if i == j else 0.0
        factor[p] = 0.0


@_njit
def hex_kinematics(u, u_n, cell_dofs, dNdX, W, fbar, alive, erosion_ratio, Fu, Finv, factor, theta):
    """Pass 1 on hexahedra: Fu (n,3,3) at every point, F^-1 (n,3,3), J/theta (n,), theta (nc,).

    u, u_n (3 n_nodes,) current and previous displacements [mm] (entry 3 node + component);
    cell_dofs (nc, 8) node indices (basix order); fbar: Q1/P0 F-bar (False: theta = J, factor 1);
    alive (nc,) uint8: 0 = eroded (frozen, :func:`_freeze_hex`); a cell that
    :func:`~fenics_plast.solvers.fused_cells.erodes` (erosion_ratio) now gets alive[c] = 0.
    Returns -1, or the first living cell, not eroded now, with a point where det F <= 0 (or not
    finite): it folds, and the pass stops there (the caller writes no state).
    """
    nc, nq = W.shape
    J = np.empty(nq)
    J_n = np.empty(nq)
    ue = np.empty((8, 3))
    ue_n = np.empty((8, 3))
    F = np.empty((3, 3))
    G = np.empty((3, 3))
    adjF = np.empty((3, 3))
    adjG = np.empty((3, 3))
    for c in range(nc):
        if not alive[c]:
            _freeze_hex(c, nq, Fu, Finv, factor)
            continue
        for a in range(8):
            node = cell_dofs[c, a]
            for i in range(3):
                ue[a, i] = u[3 * node + i]
                ue_n[a, i] = u_n[3 * node + i]
        th = 0.0
        th_n = 0.0
        wsum = 0.0
        folds = False
        for q in range(nq):
            p = c * nq + q
            for i in range(3):
                for j in range(3):
                    F[i, j] = 0.0
                    G[i, j] = 0.0
            for a in range(8):
                for j in range(3):
                    g = dNdX[c, q, a, j]
                    for i in range(3):
                        F[i, j] += ue[a, i] * g
                        G[i, j] += ue_n[a, i] * g
            for i in range(3):
                F[i, i] += 1.0
                G[i, i] += 1.0
            det = _adjugate(F, adjF)            # F^-1 = adj F / det F
            det_n = _adjugate(G, adjG)
            if not det > 0.0:
                folds = True
            J[q] = det
            J_n[q] = det_n
            ir = 1.0 / det
            irn = 1.0 / det_n
            for i in range(3):
                for j in range(3):
                    Finv[p, i, j] = adjF[i, j] * ir
                    Fu[p, i, j] = (F[i, 0] * adjG[0, j] + F[i, 1] * adjG[1, j] + F[i, 2] * adjG[2, j]) * irn
            th += det * W[c, q]
            th_n += det_n * W[c, q]
            wsum += W[c, q]
        th /= wsum
        th_n /= wsum
        if erodes(J, th, erosion_ratio):
            alive[c] = 0
            _freeze_hex(c, nq, Fu, Finv, factor)
            continue
        if folds:
            return c
        theta[c] = th
        fbar_points(c, th, th_n, J, J_n, fbar, Fu, factor)
    return -1


@_njit
def hex_folded_cells(u, cell_dofs, dNdX, W, alive, erosion_ratio, jmin):
    """The fold check of :func:`hex_kinematics` alone (nothing but jmin written; the explicit solver's
    diagnosis of a fold and the ufl route's check): the first living cell, not eroding, with a point
    where det F <= 0 (or not finite), -1 if none. jmin (nc,) or
    (0,): each cell's smallest point Jacobian det F (+inf for an eroded or eroding cell, -inf where
    not finite), when given. Arguments as :func:`hex_kinematics`."""
    nc, nq = W.shape
    J = np.empty(nq)
    ue = np.empty((8, 3))
    F = np.empty((3, 3))
    adjF = np.empty((3, 3))
    first = -1
    for c in range(nc):
        if jmin.shape[0]:
            jmin[c] = np.inf
        if not alive[c]:
            continue
        for a in range(8):
            node = cell_dofs[c, a]
            for i in range(3):
                ue[a, i] = u[3 * node + i]
        th = 0.0
        wsum = 0.0
        folds = False
        lo = np.inf
        for q in range(nq):
            for i in range(3):
                for j in range(3):
                    F[i, j] = 0.0
            for a in range(8):
                for j in range(3):
                    g = dNdX[c, q, a, j]
                    for i in range(3):
                        F[i, j] += ue[a, i] * g
            for i in range(3):
                F[i, i] += 1.0
            det = _adjugate(F, adjF)
            if not det > 0.0:
                folds = True
            J[q] = det
            lo = min(lo, det) if math.isfinite(det) else -np.inf
            th += det * W[c, q]
            wsum += W[c, q]
        th /= wsum
        first, done = record_fold(c, J, th, erosion_ratio, lo, folds, jmin, first)
        if done:
            return first
    return first


@_njit
def hex_force(tau, cell_dofs, dNdX, W, Finv, factor, f):
    """Pass 3 on hexahedra: f[3 node + i] = sum_q (J/theta) W_q (tau F^-T)_ij Grad_j N_a (the first
    Piola-Kirchhoff stress on the reference gradient) [N], f (3 n_nodes,) zeroed first.
    Returns False if f is not finite."""
    f[:] = 0.0
    hex_force_add(tau, cell_dofs, dNdX, W, Finv, factor, f)
    return sum_is_finite(f)


#: cells per block of :func:`hex_update_force_blocked`: the block's points' tau, b_e^-1, F^-1 and its
#: cells' gradients stay in the core's cache between the material update and the force
CELLS_PER_BLOCK = 32


@_njit
def hex_update_force_blocked(cell_dofs, dNdX, W, model, lmbda, mu, law, hp, yield_tol, binv, eqps, temp, dt, tau,
                             Fu, Finv, factor, f):
    """Passes 2 and 3 (material update and commit, nodal force) block by block of
    :data:`CELLS_PER_BLOCK` cells, one material, after pass 1 (:func:`hex_kinematics`) over all
    cells (arguments as ``fused_force.internal_force``; temp (n,) or a dummy (1,) array). Each
    cell's arithmetic and the order in which the cells add to f are those of the passes over all
    cells, so the result is the same to the bit; the block's stress and state are read again by the
    force pass while still in cache (two ranks on two cores share the memory bandwidth). Returns
    False if f is not finite."""
    nc, nq = W.shape
    no_tangent = np.empty((1, 3, 3, 3, 3))
    per_point_temp = temp.shape[0] == binv.shape[0]
    f[:] = 0.0
    for c0 in range(0, nc, CELLS_PER_BLOCK):
        c1 = min(c0 + CELLS_PER_BLOCK, nc)
        p0, p1 = c0 * nq, c1 * nq
        T = temp[p0:p1] if per_point_temp else temp
        kernels.update_points(model, Fu[p0:p1], binv[p0:p1], eqps[p0:p1], T, lmbda, mu, law, hp, yield_tol, dt,
                              tau[p0:p1], binv[p0:p1], eqps[p0:p1], T, no_tangent, False)
        hex_force_add(tau[p0:p1], cell_dofs[c0:c1], dNdX[c0:c1], W[c0:c1], Finv[p0:p1], factor[p0:p1], f)
    return sum_is_finite(f)


@_njit
def hex_force_add(tau, cell_dofs, dNdX, W, Finv, factor, f):
    """Adds the cells' nodal forces of :func:`hex_force` to f (not zeroed)."""
    nc, nq = W.shape
    P = np.empty((3, 3))
    for c in range(nc):
        for q in range(nq):
            p = c * nq + q
            s = factor[p] * W[c, q]
            for i in range(3):
                t0 = tau[p, i, 0] * s
                t1 = tau[p, i, 1] * s
                t2 = tau[p, i, 2] * s
                for k in range(3):
                    P[i, k] = t0 * Finv[p, k, 0] + t1 * Finv[p, k, 1] + t2 * Finv[p, k, 2]
            for a in range(8):
                d0 = dNdX[c, q, a, 0]
                d1 = dNdX[c, q, a, 1]
                d2 = dNdX[c, q, a, 2]
                node = cell_dofs[c, a]
                for i in range(3):
                    f[3 * node + i] += P[i, 0] * d0 + P[i, 1] * d1 + P[i, 2] * d2
