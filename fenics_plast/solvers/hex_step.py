r"""The explicit stable step on trilinear hexahedra: a size estimate per cell and the element's own step.

The hexahedral twins of the quadrilateral kernels of :mod:`fenics_plast.solvers.quad_step`
(``quad_size``, ``quad_eig_dt``, ``quad_lazy_min``), called by
:class:`~fenics_plast.solvers.explicit.ExplicitDynamics` when its mesh is hexahedral (geometry "3d").
Vertices in basix order (vertex a at (a & 1, (a >> 1) & 1, (a >> 2) & 1) of the unit cube); lengths
mm, masses tonne, moduli MPa, times s.

Characteristic length (:func:`hex_size`): h = V / A_max, the cell's volume over its largest face
area (LS-DYNA's choice for solid elements): the thickness of a flattened cell (V / A_max = t for a
box a x b x t, t the smallest side). Face areas are the vector areas |(p2 - p0) x (p3 - p1)| / 2 of
the faces (exact for plane faces), the volume the 2 x 2 x 2 Gauss integral of det J (exact for a
trilinear map).

Size estimate of the step (:func:`size_factor`): kappa h / c. h / c alone is not safe on
hexahedra: the unit cube's highest mode with a lumped mass is the breathing mode (nodal
displacements (+-1, +-1, +-1) away from the centre, uniform dilatation; it continues across a mesh of
cubes, so the mesh has it too) with omega^2 = 4 (3 lambda + 2 mu) / (rho h^2), a step
2 / omega = sqrt((lambda + 2 mu) / (3 lambda + 2 mu)) h / c = 0.734 h / c at nu = 0.3 (exact element
step, :func:`hex_eig_dt`; 1.0 h / c on a 1 x 1 x 0.01 plate). Hence kappa = min(sqrt((lambda + 2 mu) /
(3 lambda + 2 mu)), 0.74): exact on the cube for nu >= 0.26; at most the element's step on every
sound hexahedron of a sweep of 600 random shapes per nu (boxes of aspect ratio up to 20, vertices
moved by up to 25 % of the smallest side, det J ratio > 0.2; nu from 0 to 0.49, q1 and q1p0), whose
worst case is the cube for nu >= 0.25 and 0.75 h / c for nu < 0.25.
(tests/test_explicit_3d.py checks the unit cube and a flattened hex.)

Element step (:func:`hex_eig_dt`): omega_max^2 the largest eigenvalue of M^-1/2 K M^-1/2, K the
24 x 24 small-strain elastic stiffness of the cell in its current shape (2 x 2 x 2 Gauss; q1p0: the
volumetric part through the cell's mean dilatation, as F-bar does), M its share of its nodes'
lumped mass; exact for the element and, by Irons' theorem, an upper bound of the assembled mesh's
omega_max. Computed (a dense symmetric eigen solve) only for the few cells whose size estimate is
below the minimum found (:func:`hex_lazy_min`), whose value is then the element's step itself
(where the size estimate is a lower bound, the minimum over the cells is the element step's).
"""
from __future__ import annotations

import numba
import numpy as np

from fenics_plast.solvers.fused_force_hex import hex_shape_functions
from fenics_plast.solvers.element_step import element_step

# the 6 faces of basix's hexahedron, vertices in cyclic order
HEX_FACES = np.array([[0, 2, 6, 4], [1, 3, 7, 5], [0, 1, 5, 4], [2, 3, 7, 6], [0, 1, 3, 2], [4, 5, 7, 6]],
                     dtype=np.int64)
# the 12 edges
HEX_EDGES = np.array([[0, 1], [2, 3], [4, 5], [6, 7], [0, 2], [1, 3], [4, 6], [5, 7], [0, 4], [1, 5], [2, 6],
                      [3, 7]], dtype=np.int64)
_G = 0.5 / np.sqrt(3.0)
# 2 x 2 x 2 Gauss points on the unit cube (weights 1/8 each): shape functions and reference gradients
_GAUSS = np.array([[0.5 + sx * _G, 0.5 + sy * _G, 0.5 + sz * _G] for sz in (-1, 1) for sy in (-1, 1)
                   for sx in (-1, 1)])
_N8, _DN8 = hex_shape_functions(_GAUSS)


@numba.njit(cache=True)
def _jacobian(x, nodes, dN, q, Jm):
    """dx_k / dxi_l at Gauss point q into Jm (3, 3); returns det."""
    for k in range(3):
        for m in range(3):
            Jm[k, m] = 0.0
    for a in range(8):
        i = nodes[a]
        for k in range(3):
            for m in range(3):
                Jm[k, m] += x[i, k] * dN[q, a, m]
    return (Jm[0, 0] * (Jm[1, 1] * Jm[2, 2] - Jm[1, 2] * Jm[2, 1])
            - Jm[0, 1] * (Jm[1, 0] * Jm[2, 2] - Jm[1, 2] * Jm[2, 0])
            + Jm[0, 2] * (Jm[1, 0] * Jm[2, 1] - Jm[1, 1] * Jm[2, 0]))


@numba.njit(cache=True)
def _hex_size(x, cell_dofs, faces, dN, out):
    Jm = np.empty((3, 3))
    for c in range(cell_dofs.shape[0]):
        nodes = cell_dofs[c]
        vol = 0.0
        for q in range(8):
            vol += 0.125 * _jacobian(x, nodes, dN, q, Jm)
        amax = 0.0
        for k in range(6):
            p0, p1, p2, p3 = nodes[faces[k, 0]], nodes[faces[k, 1]], nodes[faces[k, 2]], nodes[faces[k, 3]]
            d1x, d1y, d1z = x[p2, 0] - x[p0, 0], x[p2, 1] - x[p0, 1], x[p2, 2] - x[p0, 2]
            d2x, d2y, d2z = x[p3, 0] - x[p1, 0], x[p3, 1] - x[p1, 1], x[p3, 2] - x[p1, 2]
            cx = d1y * d2z - d1z * d2y
            cy = d1z * d2x - d1x * d2z
            cz = d1x * d2y - d1y * d2x
            amax = max(amax, 0.5 * np.sqrt(cx * cx + cy * cy + cz * cz))
        out[c] = max(vol, 0.0) / max(amax, 1e-300)      # an inverted cell: size 0
    return out


def hex_size(x, cell_dofs, out=None):
    """Characteristic length V / A_max [mm] of each cell: x (n_nodes, 3) node positions,
    cell_dofs (nc, 8) int64 node indices (basix order); out (nc,) or None. An inverted cell
    (V <= 0) gets 0."""
    cell_dofs = np.ascontiguousarray(cell_dofs, dtype=np.int64)
    out = np.empty(cell_dofs.shape[0]) if out is None else out
    return _hex_size(np.ascontiguousarray(x, dtype=float), cell_dofs, HEX_FACES, _DN8, out)


def size_factor(lam, mu):
    """kappa (see the module doc): the size estimate of a cell's step is kappa h / c, h = V / A_max.
    lam, mu [MPa] (numbers or arrays)."""
    lam, mu = np.asarray(lam, dtype=float), np.asarray(mu, dtype=float)
    return np.minimum(np.sqrt((lam + 2.0 * mu) / (3.0 * lam + 2.0 * mu)), 0.74)


def hex_volume(P):
    """Volume [mm^3] of hexahedra P (n, 8, 3) (basix order; exact for trilinear cells)."""
    J = np.einsum("cak,qal->cqkl", np.asarray(P, dtype=float), _DN8)
    return np.linalg.det(J).sum(axis=1) / 8.0


def hex_edge_lengths(P):
    """(n, 12) edge lengths [mm] of hexahedra P (n, 8, 3)."""
    P = np.asarray(P, dtype=float)
    return np.linalg.norm(P[:, HEX_EDGES[:, 1]] - P[:, HEX_EDGES[:, 0]], axis=2)


@numba.njit(cache=True)
def _hex_eig_dt(x, cell_dofs, cells, mass, lam, mu, fbar, dN, out):
    """2 / omega_max of the listed cells' elastic elements: out[k] for cell ``cells[k]``.

    x (n_nodes, 3) current positions [mm]; mass (nc, 8) each cell's share of its nodes' lumped mass
    [tonne]; lam, mu (nc,) [MPa]; fbar: mean-dilatation volumetric part (q1p0)."""
    g = np.empty((8, 8, 3))             # current gradients per point, node
    W = np.empty(8)
    Jm = np.empty((3, 3))
    K = np.empty((24, 24))
    bbar = np.empty((8, 3))
    for k in range(cells.shape[0]):
        c = cells[k]
        nodes = cell_dofs[c]
        lm, m = lam[c], mu[c]
        kap = lm + 2.0 * m / 3.0
        vol = 0.0
        for q in range(8):
            det = _jacobian(x, nodes, dN, q, Jm)
            W[q] = abs(det) * 0.125
            vol += W[q]
            # inverse of Jm: d xi / d x
            i00 = (Jm[1, 1] * Jm[2, 2] - Jm[1, 2] * Jm[2, 1]) / det
            i01 = (Jm[0, 2] * Jm[2, 1] - Jm[0, 1] * Jm[2, 2]) / det
            i02 = (Jm[0, 1] * Jm[1, 2] - Jm[0, 2] * Jm[1, 1]) / det
            i10 = (Jm[1, 2] * Jm[2, 0] - Jm[1, 0] * Jm[2, 2]) / det
            i11 = (Jm[0, 0] * Jm[2, 2] - Jm[0, 2] * Jm[2, 0]) / det
            i12 = (Jm[0, 2] * Jm[1, 0] - Jm[0, 0] * Jm[1, 2]) / det
            i20 = (Jm[1, 0] * Jm[2, 1] - Jm[1, 1] * Jm[2, 0]) / det
            i21 = (Jm[0, 1] * Jm[2, 0] - Jm[0, 0] * Jm[2, 1]) / det
            i22 = (Jm[0, 0] * Jm[1, 1] - Jm[0, 1] * Jm[1, 0]) / det
            for a in range(8):
                d0, d1, d2 = dN[q, a, 0], dN[q, a, 1], dN[q, a, 2]
                g[q, a, 0] = d0 * i00 + d1 * i10 + d2 * i20
                g[q, a, 1] = d0 * i01 + d1 * i11 + d2 * i21
                g[q, a, 2] = d0 * i02 + d1 * i12 + d2 * i22
        for a in range(8):
            for i in range(3):
                s = 0.0
                for q in range(8):
                    s += g[q, a, i] * W[q]
                bbar[a, i] = s / vol
        K[:] = 0.0
        for q in range(8):
            w = W[q]
            for a in range(8):
                for b in range(8):
                    gg = g[q, a, 0] * g[q, b, 0] + g[q, a, 1] * g[q, b, 1] + g[q, a, 2] * g[q, b, 2]
                    for i in range(3):
                        for j in range(3):
                            # deviatoric: mu (g_aj g_bi + d_ij g_a.g_b) - 2 mu / 3 g_ai g_bj
                            v = m * g[q, a, j] * g[q, b, i] - (2.0 * m / 3.0) * g[q, a, i] * g[q, b, j]
                            if i == j:
                                v += m * gg
                            if fbar:
                                v += kap * bbar[a, i] * bbar[b, j]
                            else:
                                v += kap * g[q, a, i] * g[q, b, j]
                            K[3 * a + i, 3 * b + j] += v * w
        out[k] = element_step(K, mass[c], 3)
    return out


def hex_eig_dt(x, cell_dofs, cells, mass, lam, mu, fbar, out=None):
    """2 / omega_max [s] of the elastic elements of ``cells`` (see the module doc): x (n_nodes, 3)
    current positions [mm], cell_dofs (nc, 8), mass (nc, 8) [tonne], lam, mu (nc,) [MPa]."""
    cells = np.ascontiguousarray(cells, dtype=np.int64)
    out = np.empty(cells.size) if out is None else out
    return _hex_eig_dt(np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(cell_dofs, dtype=np.int64),
                       cells, np.ascontiguousarray(mass, dtype=float), np.ascontiguousarray(lam, dtype=float),
                       np.ascontiguousarray(mu, dtype=float), bool(fbar), _DN8, out)


@numba.njit(cache=True)
def _hex_lazy_min(d, order, x, cell_dofs, mass, lam, mu, scale_sqrt, fbar, dN):
    best = np.inf
    arg = -1
    one = np.empty(1, dtype=np.int64)
    e = np.empty(1)
    for k in range(order.shape[0]):
        c = order[k]
        if d[c] >= best * (1.0 - 1e-12):      # (a tie of equal cells ends the search too)
            break
        one[0] = c
        _hex_eig_dt(x, cell_dofs, one, mass, lam, mu, fbar, dN, e)
        v = e[0] * scale_sqrt[c]
        if v < best:
            best = v
            arg = c
    return best, arg


def hex_lazy_min(d, x, cell_dofs, mass, lam, mu, scale_sqrt, fbar):
    """(min over the cells of e[c] sqrt(s_c), its cell) with e the element step (:func:`hex_eig_dt`),
    s_c the cell's mass-scaling factor, visiting the cells in ascending d (size estimates, (nc,) [s],
    a lower bound of e sqrt(s)) and stopping when d reaches the minimum found to 1e-12 relative (so
    that a mesh of equal cells stops after the first): e is computed for the few cells whose size
    estimate is below the result. Quadrilaterals: ``quad_step.quad_lazy_min`` (which takes the
    larger of d and e)."""
    return _hex_lazy_min(d, np.argsort(d), x, cell_dofs, mass, lam, mu, scale_sqrt, bool(fbar), _DN8)
