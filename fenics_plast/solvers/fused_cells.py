"""What the fused internal-force passes of quadrilaterals and hexahedra share, cell by cell.

The passes are :mod:`fenics_plast.solvers.fused_force` (bilinear quadrilaterals, and the calls that pick
the cells' kind) and :mod:`fenics_plast.solvers.fused_force_hex` (trilinear hexahedra). Shared here:

* :func:`fbar_points`: the F-bar scaling of a cell's points, Fu *= ((theta J_n) / (theta_n J))^(1/3),
  and the factor J / theta of the nodal force (seed eq. 10);
* :func:`erodes`: whether a cell is eroded (element erosion: its smallest point Jacobian below
  erosion_ratio x its mean dilatation);
* :func:`record_fold`: the bookkeeping of the fold checks (``quad_folded_cells``, ``hex_folded_cells``)
  after a cell's points;
* :func:`sum_is_finite`: whether a nodal force vector is finite.

Arrays as in :func:`fenics_plast.solvers.fused_force.internal_force`: points p = c nq + q, Fu (n, 3, 3),
factor (n,), J and J_n (nq,) the point Jacobians (volume ratios) of one cell now and at the last step.
"""
from __future__ import annotations

import math

import numba

_njit = numba.njit(cache=True, nogil=True, fastmath={"contract", "arcp", "nsz"})


@_njit
def _cbrt(r):
    """r^(1/3). Per step, F-bar ratios differ from 1 by ~1e-4: there one Halley step from the
    linearised root is exact to round-off (error < 5e-16 for |r - 1| < 1e-3) and 2-3x cheaper than pow."""
    if abs(r - 1.0) < 1e-3:
        y = 1.0 + (r - 1.0) / 3.0
        y3 = y * y * y
        return y * (y3 + 2.0 * r) / (2.0 * y3 + r)
    return r ** (1.0 / 3.0)


@_njit
def erodes(J, th, erosion_ratio):
    """Whether a cell with point Jacobians J (nq,) and mean dilatation th is eroded: erosion on
    (ratio > 0) and its smallest J below ratio x th (a cell about to fold; th <= 0 always qualifies)."""
    if erosion_ratio <= 0.0:
        return False
    jmin = J[0]
    for q in range(1, J.shape[0]):
        jmin = min(jmin, J[q])
    return jmin < erosion_ratio * th or th <= 0.0


@_njit
def fbar_points(c, th, th_n, J, J_n, fbar, Fu, factor):
    """The F-bar part of pass 1 at the points of cell c (quadrilaterals and hexahedra): with fbar,
    Fu *= ((theta J_n) / (theta_n J))^(1/3) (seed eq. 10; on quadrilaterals Fu's off-block entries are 0
    and stay 0) and factor = J / theta; without, factor = 1. J, J_n (nq,): the points' Jacobians now and
    at the last step; th, th_n: the cell's mean dilatation now and then."""
    nq = J.shape[0]
    for q in range(nq):
        p = c * nq + q
        if fbar:
            s = _cbrt((th * J_n[q]) / (th_n * J[q]))
            for i in range(3):
                for j in range(3):
                    Fu[p, i, j] *= s
            factor[p] = J[q] / th
        else:
            factor[p] = 1.0



@_njit
def record_fold(c, J, th, erosion_ratio, lo, folds, jmin, first):
    """The fold checks' bookkeeping after cell c's points: J (nq,) its point Jacobians, th its mean
    dilatation, lo its smallest point Jacobian (-inf where not finite), folds whether a point folds;
    jmin (nc,) or (0,) and first (the first folding cell so far, -1 if none) as in the checks. A cell
    that :func:`erodes` is passed over; otherwise jmin[c] = lo (when jmin is given) and a folding cell
    becomes ``first`` if none was found before. Returns (first, done): done when the check can stop
    (a cell folds and there is no jmin to fill)."""
    if erodes(J, th, erosion_ratio):
        return first, False
    if jmin.shape[0]:
        jmin[c] = lo
    if folds:
        if first < 0:
            first = c
        if not jmin.shape[0]:
            return first, True
    return first, False


@_njit
def sum_is_finite(f):
    """Whether the entries of f are all finite (their sum is: a NaN or an infinity carries through)."""
    total = 0.0
    for i in range(f.shape[0]):
        total += f[i]
    return math.isfinite(total)
