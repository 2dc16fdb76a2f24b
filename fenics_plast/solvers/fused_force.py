r"""Explicit internal force in one compiled pass: kinematics, F-bar, material update, nodal force.

The compiled-loop twin of the UFL path (``Kinematics.Fu`` + ``QuadratureMap.update`` +
``Kinematics.internal_virtual_work``, assembled by dolfinx), for bilinear quadrilaterals
(axisymmetric or plane strain) and, with the passes of :mod:`fenics_plast.solvers.fused_force_hex`,
trilinear hexahedra (geometry "3d", 2 x 2 x 2 Gauss points; chosen by the arrays' shapes when numba
compiles, so the step loops of integrator.py serve both). Same quadrature points, same material kernels
(:mod:`fenics_plast.material.kernels`), same equations (DESIGN.md, "R_u"):

    F       = I + Grad u,  hoop F_hh = 1 + u_r / R  (axisymmetric; 1 in plane strain)
    theta_c = sum_q J_q W_q / sum_q W_q                      mean dilatation of cell c (Q1/P0)
    Fu      = ((theta J_n) / (theta_n J))^(1/3) F F_n^-1      F-bar increment (seed eq. 10)
    tau     = material(Fu, b_e^-1_n, eps_p_n, T_n, dt)        seed eqs. (11)-(14) / isochoric (T, dt:
                                                              Johnson-Cook rate and heating)
    f_ai    = sum_q (J / theta) tau_ij (Grad N_a F^-1)_j W_q  (+ tau_hh N_a / (R F_hh) for i = r)

with W_q = w(X_q) |det J0(X_q)| q_w the reference quadrature weights (w = 2 pi R in
axisymmetry) and Grad the reference gradient. Element "q1" uses theta = J (no F-bar).

Pass 1 (kinematics) also checks that each living cell keeps det F > 0 (and F_hh > 0) at its points:
a cell that folds there stops the call before the material update (:func:`folded_cell`), so that
nothing of the state, stress or force is written and the explicit solver can stop at the last
finite state (the material update has no answer for an inverted point: NaN before).

This pass is the default route of the explicit solver (``solver.internal_force = "fused"``): the
dolfinx route costs ~0.7 ms per explicit step on the 216-cell Taylor bar (generated kernels ~1 us
per cell, packing and Python overhead per call); this pass costs a fraction of that. The UFL
residual stays the definition the pass is held to: ``tests/test_fused_force.py`` (2-D) and
``tests/test_fused_force_3d.py`` (hexahedra) check that both give the same force, stress and state
(and, in 2-D, the same run) to round-off; ``solver.internal_force =
"ufl"`` selects the dolfinx route.

Several materials (:class:`~fenics_plast.material.regions.MaterialRegions`): the material update runs
per material on its own points (``regions``); one material takes the plain call, compiled as before.

This module holds the internal-force pass only; the time integration that calls it (step loop,
velocity-Verlet updates, prescribed motion, loads, contact) is
:mod:`fenics_plast.solvers.integrator`; what the passes of both cell kinds share cell by cell (F-bar,
erosion, the fold checks' bookkeeping) is :mod:`fenics_plast.solvers.fused_cells`.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np
from numba.core import types
from numba.extending import overload

from fenics_plast.material import kernels
from fenics_plast.material.regions import update_regions
from fenics_plast.solvers.fused_cells import erodes, fbar_points, record_fold, sum_is_finite
from fenics_plast.solvers.fused_force_hex import hex_force, hex_kinematics, hex_update_force_blocked

_njit = numba.njit(cache=True, nogil=True, fastmath={"contract", "arcp", "nsz"})


class CellGeometry:
    """Reference-configuration data of bilinear quadrilaterals at the quadrature points.

    dNdX : (nc, nq, 4, 2) reference gradients of the 4 shape functions [1/mm].
    N : (nq, 4) shape function values.
    Rinv : (nc, nq) 1/R at the points (axisymmetric) or 0 (plane strain: no hoop strain).
    W : (nc, nq) quadrature weights w |det J0| q_w [mm^3 per radian x 2 pi, i.e. mm^3 in total
        for axisymmetry; mm^2 per unit depth in plane strain].
    """

    def __init__(self, X_cells, points, weights, axisymmetric):
        X_cells = np.asarray(X_cells, dtype=float)           # (nc, 4, 2), basix vertex order
        xi, eta = points[:, 0], points[:, 1]
        # basix Q1 vertex order: (0,0) (1,0) (0,1) (1,1)
        self.N = np.stack([(1 - xi) * (1 - eta), xi * (1 - eta), (1 - xi) * eta, xi * eta], axis=1)
        dN = np.zeros((len(xi), 4, 2))                          # d N_a / d(xi, eta)
        dN[:, 0] = np.stack([-(1 - eta), -(1 - xi)], axis=1)
        dN[:, 1] = np.stack([(1 - eta), -xi], axis=1)
        dN[:, 2] = np.stack([-eta, (1 - xi)], axis=1)
        dN[:, 3] = np.stack([eta, xi], axis=1)
        J0 = np.einsum("cak,qal->cqkl", X_cells, dN)           # dX_k / dxi_l
        det = J0[..., 0, 0] * J0[..., 1, 1] - J0[..., 0, 1] * J0[..., 1, 0]
        if (det <= 0).any():
            raise ValueError("inverted or degenerate quadrilateral in the reference mesh")
        J0inv = np.linalg.inv(J0)                               # dxi_l / dX_k
        self.dNdX = np.ascontiguousarray(np.einsum("qal,cqlk->cqak", dN, J0inv))
        R = np.einsum("qa,ca->cq", self.N, X_cells[:, :, 0])
        w = 2.0 * math.pi * R if axisymmetric else np.ones_like(R)
        self.W = np.ascontiguousarray(w * np.abs(det) * weights[None, :])
        self.Rinv = np.ascontiguousarray(1.0 / R if axisymmetric else np.zeros_like(R))


def quadrature(degree, cell="quadrilateral"):
    """Points (nq, tdim) and weights (nq,) of the default basix rule on the reference cell
    ("quadrilateral" or "hexahedron")."""
    from fenics_plast.dolfinx_compat import quadrature_rule    # basix's call differs by version
    return quadrature_rule(cell, degree)


@_njit
def _deformation(ue, dNdX, N, Rinv, c, q):
    """F at point q of cell c from the cell's nodal displacements ue (8,) = (u_r, u_z) per node.
    Returns (F_rr, F_rz, F_zr, F_zz, F_hh)."""
    frr = 1.0
    frz = 0.0
    fzr = 0.0
    fzz = 1.0
    fhh = 1.0
    for a in range(4):
        ur = ue[2 * a]
        uz = ue[2 * a + 1]
        gr = dNdX[c, q, a, 0]
        gz = dNdX[c, q, a, 1]
        frr += ur * gr
        frz += ur * gz
        fzr += uz * gr
        fzz += uz * gz
        fhh += ur * N[q, a] * Rinv[c, q]
    return frr, frz, fzr, fzz, fhh


@_njit
def _freeze_quad(c, nq, Fu, Finv, factor):
    """An eroded cell's points: Fu = I (the material update keeps the committed state and stress),
    F^-1 = I and factor 0 (no nodal force)."""
    for q in range(nq):
        p = c * nq + q
        Fu[p, 0, 0] = 1.0
        Fu[p, 0, 1] = 0.0
        Fu[p, 1, 0] = 0.0
        Fu[p, 1, 1] = 1.0
        Fu[p, 2, 2] = 1.0
        Finv[p, 0] = 1.0
        Finv[p, 1] = 0.0
        Finv[p, 2] = 0.0
        Finv[p, 3] = 1.0
        Finv[p, 4] = 1.0
        factor[p] = 0.0


@_njit
def _kinematics(u, u_n, cell_dofs, dNdX, N, Rinv, W, fbar, alive, erosion_ratio, Fu, Finv, factor, theta):
    """Pass 1: Fu (n,3,3) at every point, F^-1 (n,5: rr, rz, zr, zz, hh), J/theta (n,), theta (nc,).
    Cells with alive[c] = 0 are eroded (frozen: :func:`_freeze_quad`); a cell that :func:`erodes` now
    gets alive[c] = 0. Returns -1, or the first living cell that is not eroded and folds: a point
    with det F <= 0 or F_hh <= 0 (or not finite), where the material update cannot go (the pass stops
    there: the caller writes no state)."""
    nc, nq = W.shape
    J = np.empty(nq)
    J_n = np.empty(nq)
    ue = np.empty(8)
    ue_n = np.empty(8)
    for c in range(nc):
        if not alive[c]:
            _freeze_quad(c, nq, Fu, Finv, factor)
            continue
        for a in range(4):
            node = cell_dofs[c, a]
            ue[2 * a] = u[2 * node]
            ue[2 * a + 1] = u[2 * node + 1]
            ue_n[2 * a] = u_n[2 * node]
            ue_n[2 * a + 1] = u_n[2 * node + 1]
        th = 0.0
        th_n = 0.0
        wsum = 0.0
        folds = False
        for q in range(nq):
            p = c * nq + q
            frr, frz, fzr, fzz, fhh = _deformation(ue, dNdX, N, Rinv, c, q)
            grr, grz, gzr, gzz, ghh = _deformation(ue_n, dNdX, N, Rinv, c, q)
            det = frr * fzz - frz * fzr
            det_n = grr * gzz - grz * gzr
            if not (det > 0.0 and fhh > 0.0):
                folds = True
            J[q] = det * fhh
            J_n[q] = det_n * ghh
            # F F_n^-1 (2x2 block and hoop)
            ir = 1.0 / det_n
            Fu[p, 0, 0] = (frr * gzz - frz * gzr) * ir
            Fu[p, 0, 1] = (-frr * grz + frz * grr) * ir
            Fu[p, 1, 0] = (fzr * gzz - fzz * gzr) * ir
            Fu[p, 1, 1] = (-fzr * grz + fzz * grr) * ir
            Fu[p, 2, 2] = fhh / ghh
            # F^-1 for the force pass
            Finv[p, 0] = fzz / det
            Finv[p, 1] = -frz / det
            Finv[p, 2] = -fzr / det
            Finv[p, 3] = frr / det
            Finv[p, 4] = 1.0 / fhh
            th += J[q] * W[c, q]
            th_n += J_n[q] * W[c, q]
            wsum += W[c, q]
        th /= wsum
        th_n /= wsum
        if erodes(J, th, erosion_ratio):
            alive[c] = 0
            _freeze_quad(c, nq, Fu, Finv, factor)
            continue
        if folds:
            return c
        theta[c] = th
        fbar_points(c, th, th_n, J, J_n, fbar, Fu, factor)
    return -1


@_njit
def quad_folded_cells(u, cell_dofs, dNdX, N, Rinv, W, alive, erosion_ratio, jmin):
    """The fold check of :func:`_kinematics` alone (no array but jmin written): returns the first
    living, not eroding cell with a point where det F <= 0 or F_hh <= 0 (or not finite), -1 if none.
    jmin (nc,) or (0,): each cell's smallest point Jacobian J = det F F_hh (the volume ratio there;
    +inf for an eroded or eroding cell, -inf where not finite), when given. Arguments as
    :func:`internal_force` (quadrilaterals)."""
    nc, nq = W.shape
    J = np.empty(nq)
    ue = np.empty(8)
    first = -1
    for c in range(nc):
        if jmin.shape[0]:
            jmin[c] = np.inf
        if not alive[c]:
            continue
        for a in range(4):
            node = cell_dofs[c, a]
            ue[2 * a] = u[2 * node]
            ue[2 * a + 1] = u[2 * node + 1]
        th = 0.0
        wsum = 0.0
        folds = False
        lo = np.inf
        for q in range(nq):
            frr, frz, fzr, fzz, fhh = _deformation(ue, dNdX, N, Rinv, c, q)
            det = frr * fzz - frz * fzr
            J[q] = det * fhh
            jq = J[q]
            if not (det > 0.0 and fhh > 0.0):
                folds = True
                jq = -abs(jq)
            lo = min(lo, jq) if math.isfinite(jq) else -np.inf
            th += J[q] * W[c, q]
            wsum += W[c, q]
        th /= wsum
        first, done = record_fold(c, J, th, erosion_ratio, lo, folds, jmin, first)
        if done:
            return first
    return first


@_njit
def _force(tau, cell_dofs, dNdX, N, Rinv, W, Finv, factor, f):
    """Pass 3: f[2 node + i] += sum_q (J/theta) tau_ij (Grad N_a F^-1)_j W_q (+ hoop). f is zeroed first.
    Returns False if f is not finite."""
    nc, nq = W.shape
    f[:] = 0.0
    for c in range(nc):
        for q in range(nq):
            p = c * nq + q
            s = factor[p] * W[c, q]
            t00 = tau[p, 0, 0] * s
            t01 = tau[p, 0, 1] * s
            t10 = tau[p, 1, 0] * s
            t11 = tau[p, 1, 1] * s
            thh = tau[p, 2, 2] * s * Rinv[c, q] * Finv[p, 4]
            i00, i01, i10, i11 = Finv[p, 0], Finv[p, 1], Finv[p, 2], Finv[p, 3]
            for a in range(4):
                dr = dNdX[c, q, a, 0]
                dz = dNdX[c, q, a, 1]
                g0 = dr * i00 + dz * i10
                g1 = dr * i01 + dz * i11
                node = cell_dofs[c, a]
                f[2 * node] += t00 * g0 + t01 * g1 + thh * N[q, a]
                f[2 * node + 1] += t10 * g0 + t11 * g1
    return sum_is_finite(f)


class FusedPass(NamedTuple):
    """The arrays of one compiled force pass (:func:`internal_force`), persistent and updated in place.

    Quadrilaterals (``CellGeometry``) or hexahedra (``fused_force_hex.HexGeometry``), told apart by the
    shape of Finv when numba compiles (see :func:`_cell_kinematics`).
    """
    u: np.ndarray               # (gdim n_nodes,) current displacement (owned + ghost) [mm]
    u_n: np.ndarray             # (gdim n_nodes,) displacement of the last step [mm]
    cell_dofs: np.ndarray       # (nc, 4 | 8) node indices of the owned cells (basix order)
    dNdX: np.ndarray            # the geometry's arrays (CellGeometry / HexGeometry) ...
    N: np.ndarray
    Rinv: np.ndarray
    W: np.ndarray               # ... quadrature weights x reference volume [mm^3]
    fbar: bool                  # q1p0: the mean dilatation of each cell replaces the points'
    alive: np.ndarray           # (nc,) uint8, 0 for an eroded cell: its points keep their committed
    #                             state and stress and it adds no force
    erosion_ratio: float        # a living cell whose smallest point Jacobian falls below erosion_ratio x
    #                             its mean dilatation (about to fold) is eroded in this pass (0: never);
    #                             element erosion is of this pass only: the UFL route has none
    model: object               # model, lmbda, mu, law, hp, yield_tol: Material.kernel_args() (one
    lmbda: object               # material), or the per-material tables of MaterialRegions.kernel_args()
    mu: object                  # together with regions
    law: object
    hp: object
    yield_tol: float
    regions: object             # None (one material) or MaterialRegions.point_layout(nq): the points of each
    #                             material and work arrays (fenics_plast.material.regions.update_regions)
    binv: np.ndarray            # (n, 3, 3) committed b_e^-1, updated in place (explicit steps commit every update)
    eqps: np.ndarray            # (n,) committed equivalent plastic strain
    temp: np.ndarray            # (n,) committed temperature [K] (Johnson-Cook)
    dt: np.ndarray              # (1,) the step's time increment [s] (Johnson-Cook rate and heating; 0 at start)
    tau: np.ndarray             # (n, 3, 3) Kirchhoff stress out [MPa]
    Fu: np.ndarray              # (n, 3, 3) work array (quadrilaterals: its off-block entries stay 0)
    Finv: np.ndarray            # work array: (n, 5) on quadrilaterals (rr, rz, zr, zz, hh), (n, 3, 3) on hexahedra
    factor: np.ndarray          # (n,) work array
    theta: np.ndarray           # (nc,) mean dilatation out
    f: np.ndarray               # (gdim n_nodes,) nodal internal force out [N]


@_njit
def internal_force(p):
    """Kinematics, material update and commit, nodal internal force, in one call on the arrays of the
    :class:`FusedPass` p. Returns True if the stress and the force are finite.

    It is :func:`folded_cell` and, when no cell folds, :func:`update_and_force`: a step that would
    fold a cell (a point Jacobian <= 0, where the material update has no answer) returns False
    before anything of the state, the stress or the force is written (``alive`` aside: a cell eroded
    before the folding one stays eroded), so that the caller can go back to the last finite state.
    """
    if _first_pass(*p) >= 0:
        return False
    return _other_passes(*p)


@_njit
def folded_cell(p):
    """The first part of :func:`internal_force` (same record): -1, or the first owned cell that
    folds at u (a living cell, not eroded now, with a point where det F <= 0 or, in axisymmetry,
    F_hh <= 0, or not finite). It is pass 1 over all cells (Fu, F^-1, factor, theta, erosion), which
    stops at that cell: no state, stress or force is written. Call :func:`update_and_force` next
    when it returns -1 (the MPI step: all ranks agree in between)."""
    return _first_pass(*p)


@_njit
def update_and_force(p):
    """The rest of :func:`internal_force` after :func:`folded_cell` returned -1 (same record):
    material update and commit, nodal force. Returns True if the stress and the force are finite."""
    return _other_passes(*p)


def _first_pass(u, u_n, cell_dofs, dNdX, N, Rinv, W, fbar, alive, erosion_ratio, model, lmbda, mu, law, hp,
                yield_tol, regions, binv, eqps, temp, dt, tau, Fu, Finv, factor, theta, f):
    """:func:`folded_cell` (compiled: see the overload below)."""
    raise NotImplementedError("compiled code only")


def _other_passes(u, u_n, cell_dofs, dNdX, N, Rinv, W, fbar, alive, erosion_ratio, model, lmbda, mu, law, hp,
                  yield_tol, regions, binv, eqps, temp, dt, tau, Fu, Finv, factor, theta, f):
    """:func:`update_and_force` (compiled: see the overload below)."""
    raise NotImplementedError("compiled code only")


@overload(_first_pass)
def _first_pass_impl(u, u_n, cell_dofs, dNdX, N, Rinv, W, fbar, alive, erosion_ratio, model, lmbda, mu, law, hp,
                     yield_tol, regions, binv, eqps, temp, dt, tau, Fu, Finv, factor, theta, f):
    def pass1(u, u_n, cell_dofs, dNdX, N, Rinv, W, fbar, alive, erosion_ratio, model, lmbda, mu, law, hp,
              yield_tol, regions, binv, eqps, temp, dt, tau, Fu, Finv, factor, theta, f):
        return _cell_kinematics(u, u_n, cell_dofs, dNdX, N, Rinv, W, fbar, alive, erosion_ratio, Fu, Finv, factor,
                                theta)
    return pass1


@overload(_other_passes)
def _other_passes_impl(u, u_n, cell_dofs, dNdX, N, Rinv, W, fbar, alive, erosion_ratio, model, lmbda, mu, law, hp,
                       yield_tol, regions, binv, eqps, temp, dt, tau, Fu, Finv, factor, theta, f):
    """Hexahedra of one material: the material update and the force block by block of cells
    (:func:`fenics_plast.solvers.fused_force_hex.hex_update_force_blocked`, the same numbers; 3-D
    arrays are large); otherwise each pass over all cells (numba types, at compile time)."""
    if Finv.ndim == 3 and isinstance(regions, types.NoneType):
        def blocked(u, u_n, cell_dofs, dNdX, N, Rinv, W, fbar, alive, erosion_ratio, model, lmbda, mu, law, hp,
                    yield_tol, regions, binv, eqps, temp, dt, tau, Fu, Finv, factor, theta, f):
            return hex_update_force_blocked(cell_dofs, dNdX, W, model, lmbda, mu, law, hp, yield_tol, binv, eqps,
                                            temp, dt[0], tau, Fu, Finv, factor, f)
        return blocked

    def whole(u, u_n, cell_dofs, dNdX, N, Rinv, W, fbar, alive, erosion_ratio, model, lmbda, mu, law, hp, yield_tol,
              regions, binv, eqps, temp, dt, tau, Fu, Finv, factor, theta, f):
        # pass 1 (Fu, F^-1, factor, theta) ran in _first_pass
        _material_update(regions, model, lmbda, mu, law, hp, yield_tol, Fu, binv, eqps, temp, dt[0], tau)
        return _nodal_force(tau, cell_dofs, dNdX, N, Rinv, W, Finv, factor, f)
    return whole


def _cell_kinematics(u, u_n, cell_dofs, dNdX, N, Rinv, W, fbar, alive, erosion_ratio, Fu, Finv, factor, theta):
    """Pass 1 of the cells' kind (compiled: see the overload below); returns -1 or the first folding
    cell."""
    raise NotImplementedError("compiled code only")


def _nodal_force(tau, cell_dofs, dNdX, N, Rinv, W, Finv, factor, f):
    """Pass 3 of the cells' kind (compiled: see the overload below)."""
    raise NotImplementedError("compiled code only")


@overload(_cell_kinematics)
def _cell_kinematics_impl(u, u_n, cell_dofs, dNdX, N, Rinv, W, fbar, alive, erosion_ratio, Fu, Finv, factor, theta):
    """Chosen by Finv's dimension when numba compiles: 2, quadrilaterals (:func:`_kinematics`);
    3, hexahedra (:func:`fenics_plast.solvers.fused_force_hex.hex_kinematics`)."""
    if Finv.ndim == 3:
        def hexahedra(u, u_n, cell_dofs, dNdX, N, Rinv, W, fbar, alive, erosion_ratio, Fu, Finv, factor, theta):
            return hex_kinematics(u, u_n, cell_dofs, dNdX, W, fbar, alive, erosion_ratio, Fu, Finv, factor, theta)
        return hexahedra

    def quadrilaterals(u, u_n, cell_dofs, dNdX, N, Rinv, W, fbar, alive, erosion_ratio, Fu, Finv, factor, theta):
        return _kinematics(u, u_n, cell_dofs, dNdX, N, Rinv, W, fbar, alive, erosion_ratio, Fu, Finv, factor, theta)
    return quadrilaterals


@overload(_nodal_force)
def _nodal_force_impl(tau, cell_dofs, dNdX, N, Rinv, W, Finv, factor, f):
    """Chosen by Finv's dimension when numba compiles, as :func:`_cell_kinematics_impl`."""
    if Finv.ndim == 3:
        def hexahedra(tau, cell_dofs, dNdX, N, Rinv, W, Finv, factor, f):
            return hex_force(tau, cell_dofs, dNdX, W, Finv, factor, f)
        return hexahedra

    def quadrilaterals(tau, cell_dofs, dNdX, N, Rinv, W, Finv, factor, f):
        return _force(tau, cell_dofs, dNdX, N, Rinv, W, Finv, factor, f)
    return quadrilaterals


def _material_update(regions, model, lmbda, mu, law, hp, yield_tol, Fu, binv, eqps, temp, dt, tau):
    """Material update and commit of every point (compiled: see the overload below)."""
    raise NotImplementedError("compiled code only")


@overload(_material_update)
def _material_update_impl(regions, model, lmbda, mu, law, hp, yield_tol, Fu, binv, eqps, temp, dt, tau):
    """Chosen by the type of ``regions`` when numba compiles: None (or left out), one material
    (``kernels.update_points`` over all points, the call of a one-material body); a tuple, several
    materials (:func:`update_regions` with the per-material tables in model..yield_tol)."""
    if isinstance(regions, types.NoneType):
        def one(regions, model, lmbda, mu, law, hp, yield_tol, Fu, binv, eqps, temp, dt, tau):
            no_tangent = np.empty((1, 3, 3, 3, 3))
            kernels.update_points(model, Fu, binv, eqps, temp, lmbda, mu, law, hp, yield_tol, dt, tau, binv, eqps,
                                  temp, no_tangent, False)
        return one

    def several(regions, model, lmbda, mu, law, hp, yield_tol, Fu, binv, eqps, temp, dt, tau):
        no_tangent = np.empty((1, 3, 3, 3, 3))
        order, offsets, Fu_b, B_b, e_b, T_b, tau_b = regions
        update_regions(order, offsets, model, lmbda, mu, law, hp, yield_tol, Fu, binv, eqps, temp, dt, tau, binv,
                       eqps, temp, no_tangent, False, Fu_b, B_b, e_b, T_b, tau_b, no_tangent)
    return several
