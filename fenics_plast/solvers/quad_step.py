"""The explicit stable step on bilinear quadrilaterals: a size estimate per cell and the element's own step.

Called by :class:`~fenics_plast.solvers.cell_steps.CellSteps` when the explicit solver's mesh is
quadrilateral (the hexahedral twins are in :mod:`fenics_plast.solvers.hex_step`). Lengths mm, masses
tonne, moduli MPa, times s.

* :data:`QUAD_CYCLE`: basix's vertex order of a quadrilateral is tensor-product, (0,0) (1,0) (0,1)
  (1,1); its columns in this order give the cyclic order that the kernels here (and the solver's
  cell arrays, the Cells figures) take.
* Size (:func:`quad_size`, :func:`quad_min_size`): the smallest edge or altitude (distance of a vertex
  from an opposite edge's line) of each deformed cell; the solver divides it by the wave speed.
* Element step (:func:`quad_eig_dt`): 2 / omega_max of the cell's small-strain elastic element in its
  current shape with its share of the lumped mass (:func:`fenics_plast.solvers.element_step.element_step`),
  computed only for the few cells whose size estimate is below the minimum found (:func:`quad_lazy_min`).
"""
from __future__ import annotations

import numba
import numpy as np

from fenics_plast.solvers.element_step import element_step

#: basix's quadrilateral vertices (0,0) (1,0) (0,1) (1,1) taken in cyclic order
QUAD_CYCLE = np.array([0, 1, 3, 2])


@numba.njit(cache=True)
def quad_size(x, cell_dofs, out):
    """out[c] = the smallest edge or altitude [mm] of each cell c of ``cell_dofs`` (nc, 4) (node indices,
    cyclic order :data:`QUAD_CYCLE`) with node positions x (n_nodes, 2) [mm]; returns out (nc,)."""
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
    return quad_size(P.reshape(-1, 2), cd, np.empty(n))


_G = 1.0 / np.sqrt(3.0)
_XI = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])    # cyclic vertex order


@numba.njit(cache=True)
def quad_eig_dt(x, cell_dofs, cells, mass, lam, mu, axisymmetric, fbar, out):
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
def quad_lazy_min(d, order, x, cell_dofs, mass, lam, mu, scale_sqrt, axisymmetric, fbar):
    """min over the cells of max(d[c], e[c] sqrt(s_c)) (e: :func:`quad_eig_dt`), visiting the cells in
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
        quad_eig_dt(x, cell_dofs, one, mass, lam, mu, axisymmetric, fbar, e)
        v = max(d[c], e[0] * scale_sqrt[c])
        if v < best:
            best = v
            arg = c
    return best, arg

