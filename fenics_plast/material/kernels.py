r"""The Simo-Ortiz elastoplastic update at quadrature points (numba kernels).

State per point: the elastic Finger tensor :math:`b_e^{-1} = F_e^{-T} F_e^{-1}` and the
equivalent plastic strain :math:`\bar\varepsilon_p`.  Input: the incremental deformation
gradient :math:`F_u = F_{n+1} F_n^{-1}` (seed eq. 10).  Output: Kirchhoff stress
:math:`\tau = J\sigma`, updated state and the spatial consistent tangent
:math:`a_{ijkl}`, defined by :math:`\delta\tau_{ij} = a_{ijkl}\,(\delta F F^{-1})_{kl}`.

Equation numbers are those of García Garino, Oliver & Botello (the seed, ``shared/seed``).

Elastic predictor (both models)
    ``bt = Fu^-T  binv_n  Fu^-1``                                     (11)

Seed model (``SEED``): Almansi elastic strain, quadratic energy
    ``e   = 1/2 (I - bt)``                                             (Table 1)
    ``psi = 1/2 lmbda (tr e)^2 + mu e:e``                                (9)
    ``tau = d psi / d e = lmbda tr(e) I + 2 mu e``                       (7)
    plastic corrector: ``binv = bt + 2 dgamma n``, ``n = 3/2 s/q``     (14)
    The additive update of b_e^-1 with a deviatoric n does not keep det b_e^-1: plastic
    flow changes the volume (first order in the increment, ~1 % per unit strain in copper).

Isochoric variant (``ISOCHORIC``, Simo 1992): logarithmic elastic strain, exponential map
    ``eps = 1/2 ln b_e = -1/2 ln bt``  (spectral decomposition of bt)
    ``psi = 1/2 lmbda (tr eps)^2 + mu eps:eps``, ``tau = lmbda tr(eps) I + 2 mu eps``
    plastic corrector: ``eps = eps_tr - dgamma n``  <=>  ``binv = exp(2 dgamma n) bt``
    (coaxial), exactly volume preserving since tr n = 0.
    Computed in the eigenbasis of bt (the definition); full 3-D states without tangent take the same
    functions of bt as series in dev(bt) instead (``_isochoric_series``, no eigenvectors).

Both: von Mises yield on the Kirchhoff stress, ``f = q - sigma_y(eps_p)``,
``q = sqrt(3/2 s:s)``, ``s = dev tau``, associative flow (5), radial return
``q_tr - 3 mu dgamma - sigma_y(eps_p_n + dgamma) = 0``, ``eps_p = eps_p_n + dgamma``.
(The seed writes f in terms of sigma = tau/J; yielding on tau is Simo's choice: for metals
J_e = 1 + O(1e-3) and, unlike sigma, tau does not depend on the spurious plastic dilatation.)

Johnson-Cook (``hardening.JOHNSON_COOK``): sigma_y also depends on the plastic strain rate and the
temperature T, a state variable of each point (``temp_n`` in, ``temp`` out), and the increment's
time ``dt`` [s] enters. Backward Euler in all three, T implicit (end of the increment):
    ``sigma_y = S(dg) = G(eps_n + dg, dg / dt) theta(T(dg))``,  G: strain and rate terms,
    theta = 1 - T*^m;  ``T(dg) = T_n + chi dg S(dg)`` (adiabatic heating, chi = beta / (rho c_p)),
    solved for T at each dg (monotone in T, bracketed Newton), and the radial return
    ``q_tr - 3 mu dg - S(dg) = 0`` by bracketed Newton with the total slope
    ``H = S'(dg) = G_dg theta + G theta' dT/ddg``, ``dT/ddg = chi theta (G + dg G_dg) / (1 - chi dg G theta')``,
    where ``G_dg`` carries the rate term's ``C / dg = C / (rate dt)`` above the reference rate.
    ``dt <= 0`` (static analyses, no physical time): no rate term and no heating (T = T_n), i.e. the
    quasi-static isothermal law at the point's temperature. The tangent below takes this H, so it
    is consistent with the implicit T (dt and T_n are fixed data of the increment).

Algorithmic modulus w.r.t. the trial strain (same form for both models; Simo & Hughes, Box 3.2):
    ``D = kappa I(x)I + 2 mu rr_factor I_dev - c  N(x)N``   (rr_factor: the radial-return factor)
    ``rr_factor = 1 - 3 mu dgamma / q_tr``, ``c = 6 mu^2 (1/(3 mu + H) - dgamma/q_tr)``,
    ``N = s_tr/|s_tr|``, ``H = sigma_y'``  (elastic: rr_factor = 1, c = 0)
Spatial tangent, from ``delta bt = -(l^T bt + bt l)``, ``l = delta F F^-1``:
    seed:      ``a_ijkl = sum_m D_ijlm bt_mk``
    isochoric: ``a_ijkl = sum_m (D : dln(bt)/dbt)_ijlm bt_mk``, built in the eigenbasis of bt.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from .hardening import (HENSEL_SPITTEL, JC_C, JC_CHI, JC_RATE0, JOHNSON_COOK, LINEAR, flow_stress, hensel_spittel,
                        jc_softening, jc_strain_rate)

SEED, ISOCHORIC = 0, 1
ELASTIC = -1  # hardening code meaning "no plasticity"

_njit = numba.njit(cache=True, fastmath={"contract", "arcp", "nsz"}, nogil=True)
# The per-point functions take the whole arrays and the point index q: array views such as tau[q]
# cost reference counting (atomic NRT calls) per point.  (numba-level inline="always" of the point
# functions gave no measurable gain and multiplied the cold compile time by 8: not used.)


@_njit
def _ln_stretch(b):
    """ln b. The eigenvalues of a metal's trial b_e^-1 lie within a few 1e-2 of 1: there
    ln b = 2 atanh(y), y = (b - 1) / (b + 1), |y| < 0.02, summed to y^9 (the first term left out,
    2 y^11 / 11, is below 1e-18 of the sum): exact to round-off and 2-3x cheaper than log."""
    y = (b - 1.0) / (b + 1.0)
    if abs(y) < 0.02:
        y2 = y * y
        return 2.0 * y * (1.0 + y2 * (1.0 / 3.0 + y2 * (0.2 + y2 * (1.0 / 7.0 + y2 * (1.0 / 9.0)))))
    return math.log(b)


@_njit
def _exp_small(x):
    """exp(x); for |x| < 1e-3 (a step's plastic strain increment) its series to x^5 (error below
    x^6 / 720 < 2e-21): exact to round-off and cheaper than exp."""
    if abs(x) < 1e-3:
        return 1.0 + x * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x * (1.0 / 24.0 + x * (1.0 / 120.0)))))
    return math.exp(x)


@_njit
def _inverse3(F, q):
    """Inverse of the 3x3 matrix A = F[q] by cofactors, as the tuple (row-major) of its 9 entries."""
    a00, a01, a02 = F[q, 0, 0], F[q, 0, 1], F[q, 0, 2]
    a10, a11, a12 = F[q, 1, 0], F[q, 1, 1], F[q, 1, 2]
    a20, a21, a22 = F[q, 2, 0], F[q, 2, 1], F[q, 2, 2]
    c00 = a11 * a22 - a12 * a21
    c01 = a12 * a20 - a10 * a22
    c02 = a10 * a21 - a11 * a20
    r = 1.0 / (a00 * c00 + a01 * c01 + a02 * c02)  # 1/det A
    return (c00 * r, (a02 * a21 - a01 * a22) * r, (a01 * a12 - a02 * a11) * r,
            c01 * r, (a00 * a22 - a02 * a20) * r, (a02 * a10 - a00 * a12) * r,
            c02 * r, (a01 * a20 - a00 * a21) * r, (a00 * a11 - a01 * a10) * r)


@_njit
def _predictor(Fu, Bn, q):
    """Elastic predictor (11) at point q: bt = Fi^T Bn[q] Fi, Fi = Fu[q]^-1, symmetric by construction.

    Returns its upper triangle (bt00, bt01, bt02, bt11, bt12, bt22).  Scalar code (no
    scratch arrays, no array views) so that everything stays in registers.
    """
    f00, f01, f02, f10, f11, f12, f20, f21, f22 = _inverse3(Fu, q)
    # G = Bn Fi
    g00 = Bn[q, 0, 0] * f00 + Bn[q, 0, 1] * f10 + Bn[q, 0, 2] * f20
    g01 = Bn[q, 0, 0] * f01 + Bn[q, 0, 1] * f11 + Bn[q, 0, 2] * f21
    g02 = Bn[q, 0, 0] * f02 + Bn[q, 0, 1] * f12 + Bn[q, 0, 2] * f22
    g10 = Bn[q, 1, 0] * f00 + Bn[q, 1, 1] * f10 + Bn[q, 1, 2] * f20
    g11 = Bn[q, 1, 0] * f01 + Bn[q, 1, 1] * f11 + Bn[q, 1, 2] * f21
    g12 = Bn[q, 1, 0] * f02 + Bn[q, 1, 1] * f12 + Bn[q, 1, 2] * f22
    g20 = Bn[q, 2, 0] * f00 + Bn[q, 2, 1] * f10 + Bn[q, 2, 2] * f20
    g21 = Bn[q, 2, 0] * f01 + Bn[q, 2, 1] * f11 + Bn[q, 2, 2] * f21
    g22 = Bn[q, 2, 0] * f02 + Bn[q, 2, 1] * f12 + Bn[q, 2, 2] * f22
    # bt_ij = sum_k Fi_ki G_kj, i <= j
    return (f00 * g00 + f10 * g10 + f20 * g20, f00 * g01 + f10 * g11 + f20 * g21,
            f00 * g02 + f10 * g12 + f20 * g22, f01 * g01 + f11 * g11 + f21 * g21,
            f01 * g02 + f11 * g12 + f21 * g22, f02 * g02 + f12 * g12 + f22 * g22)


@_njit
def _eigh3(S, w, Q):
    """Eigen-decomposition of a symmetric 3x3 matrix by cyclic Jacobi rotations.

    S is not modified; w (3,) receives the eigenvalues, the columns of Q (3,3) the
    eigenvectors: S = Q diag(w) Q^T.  Robust for (nearly) repeated eigenvalues.
    """
    a00, a11, a22 = S[0, 0], S[1, 1], S[2, 2]
    a01, a02, a12 = S[0, 1], S[0, 2], S[1, 2]
    for i in range(3):
        for j in range(3):
            Q[i, j] = 1.0 if i == j else 0.0
    scale = abs(a00) + abs(a11) + abs(a22) + 1e-300
    if a02 == 0.0 and a12 == 0.0:
        # block diagonal (axisymmetric and plane-strain states): the first Jacobi rotation below
        # is exact; done here without the sweep loop (same operations, same result, 2x cheaper)
        if abs(a01) > 1e-17 * scale:
            cot2 = (a11 - a00) / (2.0 * a01)
            t = (1.0 if cot2 >= 0.0 else -1.0) / (abs(cot2) + math.sqrt(cot2 * cot2 + 1.0))
            c = 1.0 / math.sqrt(t * t + 1.0)
            s = t * c
            a00, a11 = a00 - t * a01, a11 + t * a01
            Q[0, 0], Q[0, 1], Q[1, 0], Q[1, 1] = c, s, -s, c
        w[0], w[1], w[2] = a00, a11, a22
        return
    for _sweep in range(30):
        off = abs(a01) + abs(a02) + abs(a12)
        if off <= 1e-17 * scale:
            break
        for pq in range(3):
            if pq == 0:
                p, q = 0, 1
                apq, app, aqq = a01, a00, a11
            elif pq == 1:
                p, q = 0, 2
                apq, app, aqq = a02, a00, a22
            else:
                p, q = 1, 2
                apq, app, aqq = a12, a11, a22
            if apq == 0.0:
                continue
            cot2 = (aqq - app) / (2.0 * apq)
            t = (1.0 if cot2 >= 0.0 else -1.0) / (abs(cot2) + math.sqrt(cot2 * cot2 + 1.0))
            c = 1.0 / math.sqrt(t * t + 1.0)
            s = t * c
            # rotate the symmetric matrix held in (a00, a11, a22, a01, a02, a12)
            if pq == 0:
                a00, a11 = app - t * apq, aqq + t * apq
                a01 = 0.0
                r2 = a02
                a02 = c * r2 - s * a12
                a12 = s * r2 + c * a12
            elif pq == 1:
                a00, a22 = app - t * apq, aqq + t * apq
                a02 = 0.0
                r1 = a01
                a01 = c * r1 - s * a12
                a12 = s * r1 + c * a12
            else:
                a11, a22 = app - t * apq, aqq + t * apq
                a12 = 0.0
                r0 = a01
                a01 = c * r0 - s * a02
                a02 = s * r0 + c * a02
            for k in range(3):
                qkp, qkq = Q[k, p], Q[k, q]
                Q[k, p] = c * qkp - s * qkq
                Q[k, q] = s * qkp + c * qkq
    w[0], w[1], w[2] = a00, a11, a22


@_njit
def _jc_temperature(hp, eps, dg, dt, T_n, th_n, T_start):
    """End-of-increment temperature of the Johnson-Cook law, its flow stress and total slope in dg.

    With G, G_dg the strain and rate terms (:func:`~fenics_plast.material.hardening.jc_strain_rate`)
    at eps = eps_n + dg and a = chi dg G, solves h(T) = T - T_n - a theta(T) = 0: h' = 1 - a theta'
    >= 1, the root lies in [T_n, T_n + a theta_n] (th_n = theta(T_n)). Newton from T_start (the
    previous iterate of the return map; the upper end when outside), bisection if a step leaves the
    bracket; a Newton step below 1e-10 T is taken and the loop ends (the error left is of the order
    a theta'' step^2 / 2, ~1e-20 K), theta updated to first order. dt <= 0, chi = 0 or dg = 0:
    T = T_n. Returns (T, S, dS/ddg, dT/ddg) [K, MPa, MPa, K], S = G theta(T), the slope along T(dg)
    with dT/ddg = chi theta (G + dg G_dg) / (1 - a theta').
    """
    chi = hp[JC_CHI]
    G, G_dg = jc_strain_rate(hp, eps, dg, dt)
    if dt <= 0.0 or chi == 0.0 or dg <= 0.0:
        th, dth = jc_softening(hp, T_n)
        return T_n, G * th, G_dg * th, 0.0
    a = chi * dg * G
    lo, hi = T_n, T_n + a * th_n
    T = T_start if lo <= T_start <= hi else hi
    th, dth = th_n, 0.0
    for _it in range(60):
        th, dth = jc_softening(hp, T)
        h = T - T_n - a * th
        step = -h / (1.0 - a * dth)
        if abs(step) <= 1e-10 * abs(T):
            T += step
            th += dth * step
            break
        if h > 0.0:
            hi = T
        else:
            lo = T
        nxt = T + step
        if not (lo <= nxt <= hi):
            nxt = 0.5 * (lo + hi)
        if nxt == T:
            break
        T = nxt
    else:
        th, dth = jc_softening(hp, T)
    dT = chi * th * (G + dg * G_dg) / (1.0 - a * dth)
    return T, G * th, G_dg * th + G * dth * dT, dT


@_njit
def _jc_rate_guess(q_tr, sy_n, C, x0, mu3, dg_pp):
    """Initial dg of the Johnson-Cook return map with the rate term: the root of
    q_tr - 3 mu dg = sy_n (1 + C ln(dg / x0)), x0 = dt rate_0 (hardening and heating over the increment
    left out). With u = 3 mu dg / (sy_n C) it reads u + ln(u) = K, K = (q_tr - sy_n) / (sy_n C) -
    ln(sy_n C / (3 mu x0)); solved by Newton in v = ln(u) (convex, increasing: 3-5 iterations of an exp).
    Returns dg_pp (the perfectly plastic estimate) when the root lies below the reference rate."""
    K = (q_tr - sy_n) / (sy_n * C) - math.log(sy_n * C / (mu3 * x0))
    v = math.log(K) if K > 1.0 else K - 1.0
    for _it in range(8):
        ev = math.exp(v)
        f = ev + v - K
        v -= f / (ev + 1.0)
        if abs(f) <= 1e-6 * (abs(K) + 1.0):
            break
    dg = math.exp(v) * sy_n * C / mu3
    return dg if dg > x0 else dg_pp


# inlined by numba: a call per Newton iteration made the strain-only return map ~5 % slower (measured)
@numba.njit(cache=True, fastmath={"contract", "arcp", "nsz"}, nogil=True, inline="always")
def _end_flow_stress(law, hp, eps_n, dg, dt, T_n, th_n, T_start):
    """Flow stress at the end of an increment dg of the law ``law``: (T, S, H, dT/ddg) [K, MPa, MPa, K].

    Johnson-Cook: S(dg) at the implicit temperature T(dg) (:func:`_jc_temperature`, T_n, th_n, T_start
    as there), H its total slope. Other laws: S = sigma_y(eps_n + dg), H = sigma_y', T = T_n, dT/ddg = 0.
    """
    if law == JOHNSON_COOK:
        return _jc_temperature(hp, eps_n + dg, dg, dt, T_n, th_n, T_start)
    if law == HENSEL_SPITTEL:           # the increment's temperature fixed (the staggered split of [thermal])
        sy, h = hensel_spittel(hp, eps_n + dg, dg, dt, T_n)
        return T_n, sy, h, 0.0
    sy, h = flow_stress(law, hp, eps_n + dg)
    return T_n, sy, h, 0.0


@_njit
def _plastic_multiplier(q_tr, mu, dg, log_newton, law, hp, eps_n, T_n, dt, th_n):
    """Solve the radial-return equation g(dg) = q_tr - 3 mu dg - S(dg) = 0 for dg >= 0 from the start dg,
    S = sigma_y at the end of the increment (:func:`_end_flow_stress`; T_n, dt, th_n: Johnson-Cook only).

    Newton safeguarded by bisection on [0, q_tr/(3 mu)] (g(0) > 0, g(hi) = -S <= 0); log_newton:
    Newton in x = ln(dg), dg <- dg exp(g / (g' dg)) (for S nearly linear in ln(dg), the rate term).
    Returns (dg, H, T) with H = S'(dg) and T the end-of-increment temperature [K] (T_n if not thermal).
    """
    lo, hi = 0.0, q_tr / (3.0 * mu)
    # T_guess: where the inner solve for T starts, the last T moved along dT/ddg
    T_guess = T_n
    for _it in range(100):
        T, sy, h, dT = _end_flow_stress(law, hp, eps_n, dg, dt, T_n, th_n, T_guess)
        g = q_tr - 3.0 * mu * dg - sy
        if abs(g) <= 1e-14 * q_tr:
            break
        if g > 0.0:
            lo = dg
        else:
            hi = dg
        slope = 3.0 * mu + h
        if slope <= 0.0:
            nxt = -1.0
        elif log_newton:
            nxt = dg * math.exp(g / (slope * dg))
        else:
            nxt = dg + g / slope
        if not (lo < nxt < hi):
            nxt = 0.5 * (lo + hi)
        if nxt == dg:
            break
        T_guess = T + dT * (nxt - dg)
        dg = nxt
    else:
        T, sy, h, dT = _end_flow_stress(law, hp, eps_n, dg, dt, T_n, th_n, T_guess)
    return dg, h, T


@_njit
def _return_map(q_tr, eps_n, mu, law, hp, yield_tol):
    """Von Mises check and radial return for a trial equivalent stress q_tr [MPa] (strain-only laws).

    Returns (dgamma, rr_factor, c) of the algorithmic modulus; dgamma = 0 if elastic.
    """
    if law == ELASTIC:
        return 0.0, 1.0, 0.0
    sy_n = flow_stress(law, hp, eps_n)[0]
    if q_tr - sy_n <= yield_tol * max(sy_n, 1e-300) or q_tr == 0.0:
        return 0.0, 1.0, 0.0
    if law == LINEAR:
        # g(dg) = q_tr - 3 mu dg - sigma_0 - H (eps_n + dg) is linear: Newton's first step is exact
        h = hp[1]
        dg = (q_tr - sy_n) / (3.0 * mu + h)
    else:
        # from dg = 0 (g(0) > 0), Newton in dg; no temperature (T_n, th_n unused)
        dg, h, _T = _plastic_multiplier(q_tr, mu, 0.0, False, law, hp, eps_n, 0.0, 0.0, 0.0)
    rr_factor = 1.0 - 3.0 * mu * dg / q_tr
    c = 6.0 * mu * mu * (1.0 / (3.0 * mu + h) - dg / q_tr)
    return dg, rr_factor, c


@_njit
def _return_map_jc(q_tr, eps_n, T_n, dt, mu, hp, yield_tol):
    """Johnson-Cook return map (module docstring): (dgamma, rr_factor, c, T), T the end-of-increment
    temperature [K]. The yield check uses the flow stress at dg = 0: reference rate, T_n."""
    th_n = jc_softening(hp, T_n)[0]
    sy_n = jc_strain_rate(hp, eps_n, 0.0, dt)[0] * th_n
    if q_tr - sy_n <= yield_tol * max(sy_n, 1e-300) or q_tr == 0.0:
        return 0.0, 1.0, 0.0, T_n
    # Start from the perfectly plastic estimate (never from 0: S'(0) may be infinite, eps^n at eps = 0
    # and C / dg of the rate term) or, with the rate term, from the smaller root of the rate term alone
    # (_jc_rate_guess: 2-4 iterations left instead of ~7). With the rate term S is nearly linear in
    # ln(dg): Newton in ln(dg) (Newton in dg creeps up the logarithm).
    dg = (q_tr - sy_n) / (3.0 * mu)
    log_newton = dt > 0.0 and hp[JC_C] != 0.0
    if log_newton and sy_n > 0.0:
        dg = min(dg, _jc_rate_guess(q_tr, sy_n, hp[JC_C], dt * hp[JC_RATE0], 3.0 * mu, dg))
    dg, h, T = _plastic_multiplier(q_tr, mu, dg, log_newton, JOHNSON_COOK, hp, eps_n, T_n, dt, th_n)
    rr_factor = 1.0 - 3.0 * mu * dg / q_tr
    c = 6.0 * mu * mu * (1.0 / (3.0 * mu + h) - dg / q_tr)
    return dg, rr_factor, c, T


@_njit
def _return_map_hs(q_tr, eps_n, T_n, dt, mu, hp, yield_tol):
    """Hensel-Spittel return map at the increment's temperature T_n [K]: (dgamma, rr_factor, c). The yield check
    takes the flow stress at dg = 0 (the minimum rate); from the perfectly plastic estimate, Newton in ln(dg)
    (the rate term is a power of dg)."""
    sy_n = hensel_spittel(hp, eps_n, 0.0, dt, T_n)[0]
    if q_tr - sy_n <= yield_tol * max(sy_n, 1e-300) or q_tr == 0.0:
        return 0.0, 1.0, 0.0
    dg = (q_tr - sy_n) / (3.0 * mu)
    dg, h, _T = _plastic_multiplier(q_tr, mu, dg, dt > 0.0, HENSEL_SPITTEL, hp, eps_n, T_n, dt, 0.0)
    rr_factor = 1.0 - 3.0 * mu * dg / q_tr
    c = 6.0 * mu * mu * (1.0 / (3.0 * mu + h) - dg / q_tr)
    return dg, rr_factor, c


@_njit
def _seed_points(Fu, Bn, eps_n, T_n, lmbda, mu, law, hp, tol, dt, tau, Bout, a, want_tangent, bt, nb, eqps,
                 T_out):
    """Seed model for all points: reads Fu, Bn = binv_n, eps_n (and T_n); writes tau, Bout = binv,
    eqps, a (and T_out: Johnson-Cook only; other laws leave it alone).

    The loop over points lives here, not in the caller: a call per point costs more than the
    point's arithmetic (measured 3x).  Symmetric tensors are held as their upper triangles in
    scalars (bt01 = bt10, ...); bt, nb (3,3) are scratch arrays for the tangent (trial b_e^-1 and
    N bt).  Returns the number of points that yielded.
    """
    nplastic = 0
    for q in range(Fu.shape[0]):
        ia = q if want_tangent else 0
        # elastic predictor (11)
        bt00, bt01, bt02, bt11, bt12, bt22 = _predictor(Fu, Bn, q)
        # Almansi strain and trial Kirchhoff stress (7), (9): e = 1/2 (I - bt), tau = lmbda tr(e) I + 2 mu e
        tr_e = 0.5 * (3.0 - bt00 - bt11 - bt22)
        p = (lmbda + 2.0 * mu / 3.0) * tr_e  # Kirchhoff mean stress
        s00, s11, s22 = -mu * bt00 + mu, -mu * bt11 + mu, -mu * bt22 + mu  # 2 mu e
        s01, s02, s12 = -mu * bt01, -mu * bt02, -mu * bt12
        mean = (s00 + s11 + s22) / 3.0
        s00, s11, s22 = s00 - mean, s11 - mean, s22 - mean  # s = dev(2 mu e)
        ss = s00 * s00 + s11 * s11 + s22 * s22 + 2.0 * (s01 * s01 + s02 * s02 + s12 * s12)  # s:s
        q_tr = math.sqrt(1.5 * ss)
        if law == JOHNSON_COOK:
            dg, rr_factor, c, T_q = _return_map_jc(q_tr, eps_n[q], T_n[q], dt, mu, hp, tol)
            T_out[q] = T_q
        elif law == HENSEL_SPITTEL:
            dg, rr_factor, c = _return_map_hs(q_tr, eps_n[q], T_n[q], dt, mu, hp, tol)
            T_out[q] = T_n[q]
        else:
            dg, rr_factor, c = _return_map(q_tr, eps_n[q], mu, law, hp, tol)
        eqps[q] = eps_n[q] + dg
        nplastic += dg > 0.0
        # plastic corrector (14): binv = bt + 2 dg n,  n = 3/2 s_tr/q_tr;  tau = tau_tr - 2 mu dg n
        fac = 3.0 * dg / q_tr if dg > 0.0 else 0.0
        t = 1.0 - mu * fac
        Bout[q, 0, 0], Bout[q, 1, 1], Bout[q, 2, 2] = bt00 + fac * s00, bt11 + fac * s11, bt22 + fac * s22
        Bout[q, 0, 1] = Bout[q, 1, 0] = bt01 + fac * s01
        Bout[q, 0, 2] = Bout[q, 2, 0] = bt02 + fac * s02
        Bout[q, 1, 2] = Bout[q, 2, 1] = bt12 + fac * s12
        tau[q, 0, 0], tau[q, 1, 1], tau[q, 2, 2] = t * s00 + p, t * s11 + p, t * s22 + p
        tau[q, 0, 1] = tau[q, 1, 0] = t * s01
        tau[q, 0, 2] = tau[q, 2, 0] = t * s02
        tau[q, 1, 2] = tau[q, 2, 1] = t * s12
        if not want_tangent:
            continue
        # a_ijkl = (kappa - 2 mu rr_factor/3) d_ij bt_lk + mu rr_factor (d_il bt_jk + d_jl bt_ik) - c N_ij (N bt)_lk
        kap = lmbda + 2.0 * mu / 3.0
        c1 = kap - 2.0 * mu * rr_factor / 3.0
        c2 = mu * rr_factor
        bt[0, 0], bt[1, 1], bt[2, 2] = bt00, bt11, bt22
        bt[0, 1] = bt[1, 0] = bt01
        bt[0, 2] = bt[2, 0] = bt02
        bt[1, 2] = bt[2, 1] = bt12
        # N = s/|s|, c N_ij = cn s_ij;  nb = N bt (not symmetric); both zero when elastic (c = 0)
        cn = 0.0
        if c != 0.0:
            r = 1.0 / math.sqrt(ss)
            cn = c * r
            n00, n01, n02, n11, n12, n22 = s00 * r, s01 * r, s02 * r, s11 * r, s12 * r, s22 * r
            for k in range(3):
                nb[0, k] = n00 * bt[0, k] + n01 * bt[1, k] + n02 * bt[2, k]
                nb[1, k] = n01 * bt[0, k] + n11 * bt[1, k] + n12 * bt[2, k]
                nb[2, k] = n02 * bt[0, k] + n12 * bt[1, k] + n22 * bt[2, k]
        else:
            s00 = s01 = s02 = s11 = s12 = s22 = 0.0
            for l in range(3):
                for k in range(3):
                    nb[l, k] = 0.0
        # one (i, j) row of 9 entries at a time, i <= j; the tangent is symmetric in (i, j)
        for i in range(3):
            for j in range(i, 3):
                if i == j:
                    sij = s00 if i == 0 else (s11 if i == 1 else s22)
                else:
                    sij = s01 if i + j == 1 else (s02 if i + j == 2 else s12)
                cij = c1 if i == j else 0.0
                nij = cn * sij  # c N_ij
                for k in range(3):
                    for l in range(3):
                        v = (cij * bt[l, k] + (c2 if i == l else 0.0) * bt[j, k]
                             + (c2 if j == l else 0.0) * bt[i, k] - nij * nb[l, k])
                        a[ia, i, j, k, l] = v
                        a[ia, j, i, k, l] = v
    return nplastic


@_njit
def _g_log(b1, b2):
    """(ln b1 - ln b2)/(b1 - b2), the divided difference of ln, stable for b1 ~ b2."""
    d = (b1 - b2) / b2
    if abs(d) < 1e-5:
        return (1.0 - 0.5 * d + d * d / 3.0) / b2
    return math.log1p(d) / (b1 - b2)


@_njit
def _spectral(Q, v0, v1, v2, out, q):
    """out[q] = Q diag(v0, v1, v2) Q^T (symmetric)."""
    for i in range(3):
        for j in range(i, 3):
            v = v0 * Q[i, 0] * Q[j, 0] + v1 * Q[i, 1] * Q[j, 1] + v2 * Q[i, 2] * Q[j, 2]
            out[q, i, j] = v
            out[q, j, i] = v


# --- Explicit full 3-D states without eigenvectors -------------------------------------------------
# The trial elastic strain of a metal is small: bt = c (I + Z), c = tr(bt)/3, with Z = dev(bt)/c
# traceless and of spectral radius rho(Z) ~ 2 |dev eps_e| < 2e-2 (bounded by the yield stress).
# Every tensor function of the update is then a power series in Z, and Cayley-Hamilton,
# Z^3 = J2 Z + J3 I (J2 = tr(Z^2)/2, J3 = det Z = tr(Z^3)/3), folds it onto f0 I + f1 Z + f2 Z^2
# with scalar coefficients: no eigenvectors, no divided differences at repeated eigenvalues.
SERIES_RHO = 0.03  # the largest rho(Z) admitted
# rho(Z)^2 <= 4/3 J2 for traceless symmetric Z, so J2 <= 3/4 SERIES_RHO^2 admits only rho(Z) <= SERIES_RHO
SERIES_J2_MAX = 0.75 * SERIES_RHO ** 2
# terms of ln(1 + z) = z - z^2/2 + ...: the first left out, rho^13 / 13 < 1e-19 rho at rho = 0.03
LOG_TERMS = 12
# terms of exp(w), rho(w) <= 1.05 rho(Z) (w = -2 r dev eps): the first left out, w^9 / 9! < 1e-17 w
EXP_TERMS = 8


@_njit
def _sym_square(x00, x01, x02, x11, x12, x22):
    """X^2 of a symmetric X, both as upper triangles (00, 01, 02, 11, 12, 22)."""
    return (x00 * x00 + x01 * x01 + x02 * x02, x00 * x01 + x01 * x11 + x02 * x12,
            x00 * x02 + x01 * x12 + x02 * x22, x01 * x01 + x11 * x11 + x12 * x12,
            x01 * x02 + x11 * x12 + x12 * x22, x02 * x02 + x12 * x12 + x22 * x22)


@_njit
def _log1p_traceless(J2, J3):
    """(l0, l1, l2) with ln(I + Z) = l0 I + l1 Z + l2 Z^2, for Z symmetric, traceless, with invariants
    J2 = tr(Z^2)/2 and J3 = det Z, rho(Z) <= SERIES_RHO: sum of (-1)^(k+1) Z^k / k, k <= LOG_TERMS,
    each power Z^k = al I + be Z + ga Z^2 from the last by Cayley-Hamilton:
    Z^(k+1) = ga J3 I + (al + ga J2) Z + be Z^2."""
    al, be, ga = 0.0, 1.0, 0.0  # Z^1
    l0, l1, l2 = 0.0, 1.0, 0.0
    for k in range(2, LOG_TERMS + 1):
        al, be, ga = ga * J3, al + ga * J2, be
        w = (1.0 if k % 2 == 1 else -1.0) / k
        l0 += w * al
        l1 += w * be
        l2 += w * ga
    return l0, l1, l2


@_njit
def _exp_traceless(J2, J3):
    """(e0, e1, e2) with exp(W) = e0 I + e1 W + e2 W^2, for W symmetric, traceless, with invariants
    J2 = tr(W^2)/2 and J3 = det W, rho(W) <= 1.05 SERIES_RHO: sum of W^k / k!, k <= EXP_TERMS, the
    powers as in :func:`_log1p_traceless`."""
    al, be, ga = 0.0, 1.0, 0.0  # W^1
    e0, e1, e2 = 1.0, 1.0, 0.0
    w = 1.0
    for k in range(2, EXP_TERMS + 1):
        al, be, ga = ga * J3, al + ga * J2, be
        w /= k
        e0 += w * al
        e1 += w * be
        e2 += w * ga
    return e0, e1, e2


@_njit
def _isochoric_series(bt00, bt01, bt02, bt11, bt12, bt22, eps_n, T_n, lmbda, mu, law, hp, tol, dt, tau, Bout,
                      eqps, T_out, q):
    """Isochoric update of point q (no tangent) from its trial bt (upper triangle) without eigenvectors.

    The same equations as the spectral path of :func:`_isochoric_points`, which is the definition;
    the two agree to round-off (tests/test_isochoric_series.py). With c = tr(bt)/3, Z = dev(bt)/c:
        ``eps_tr = -1/2 ln bt = -1/2 (ln c I + ln(I + Z))``,  ``theta = tr eps_tr``,  ``D = dev eps_tr``
        ``tau = kappa theta I + r 2 mu D``                 (r: radial-return factor, n = 3/2 s/q)
        ``eps = eps_tr - dgamma n = theta/3 I + r D``  =>  ``binv = c exp(t/3) exp(-2 r D)``,
        ``t = tr ln(I + Z) = -2 theta - 3 ln c``  (``exp(-2 theta/3) = c exp(t/3)``)
    Returns -1 (nothing written; the caller takes the spectral path) when rho(Z) may exceed
    SERIES_RHO, else 1 if the point yielded, 0 if not.
    """
    c = (bt00 + bt11 + bt22) / 3.0
    ic = 1.0 / c
    z00, z11, z22 = (bt00 - c) * ic, (bt11 - c) * ic, (bt22 - c) * ic
    z01, z02, z12 = bt01 * ic, bt02 * ic, bt12 * ic
    y00, y01, y02, y11, y12, y22 = _sym_square(z00, z01, z02, z11, z12, z22)  # Z^2
    J2 = 0.5 * (y00 + y11 + y22)
    if not J2 <= SERIES_J2_MAX:  # (NaN too: the spectral path's behaviour)
        return -1
    J3 = (z00 * y00 + z11 * y11 + z22 * y22 + 2.0 * (z01 * y01 + z02 * y02 + z12 * y12)) / 3.0  # tr(Z^3)/3
    l0, l1, l2 = _log1p_traceless(J2, J3)
    # eps_tr = -1/2 (ln c I + l0 I + l1 Z + l2 Z^2);  tr Z = 0, tr Z^2 = 2 J2, so tr ln(I + Z) = t
    t = 3.0 * l0 + 2.0 * l2 * J2
    theta = -0.5 * (3.0 * _ln_stretch(c) + t)
    h1, h2 = -0.5 * l1, -0.5 * l2
    y_mean = 2.0 * J2 / 3.0
    d00, d11, d22 = h1 * z00 + h2 * (y00 - y_mean), h1 * z11 + h2 * (y11 - y_mean), h1 * z22 + h2 * (y22 - y_mean)
    d01, d02, d12 = h1 * z01 + h2 * y01, h1 * z02 + h2 * y02, h1 * z12 + h2 * y12  # D = dev eps_tr
    p = (lmbda + 2.0 * mu / 3.0) * theta
    dd = d00 * d00 + d11 * d11 + d22 * d22 + 2.0 * (d01 * d01 + d02 * d02 + d12 * d12)  # D:D
    q_tr = 2.0 * mu * math.sqrt(1.5 * dd)  # s_tr = 2 mu D
    if law == JOHNSON_COOK:
        dg, rr_factor, c_mod, T_q = _return_map_jc(q_tr, eps_n[q], T_n[q], dt, mu, hp, tol)
        T_out[q] = T_q
    elif law == HENSEL_SPITTEL:
        dg, rr_factor, c_mod = _return_map_hs(q_tr, eps_n[q], T_n[q], dt, mu, hp, tol)
        T_out[q] = T_n[q]
    else:
        dg, rr_factor, c_mod = _return_map(q_tr, eps_n[q], mu, law, hp, tol)
    eqps[q] = eps_n[q] + dg
    fac = 1.5 * dg / q_tr if dg > 0.0 else 0.0  # dg n = fac s_tr
    r2mu = 2.0 * mu * (1.0 - 2.0 * mu * fac)  # r 2 mu
    tau[q, 0, 0], tau[q, 1, 1], tau[q, 2, 2] = p + r2mu * d00, p + r2mu * d11, p + r2mu * d22
    tau[q, 0, 1] = tau[q, 1, 0] = r2mu * d01
    tau[q, 0, 2] = tau[q, 2, 0] = r2mu * d02
    tau[q, 1, 2] = tau[q, 2, 1] = r2mu * d12
    if dg > 0.0:
        # exponential map: binv = exp(-2 theta/3) exp(W), W = -2 r D = w D, J2(W) = w^2 J2(D), J3(W) = w^3 J3(D)
        w = -2.0 * (1.0 - 2.0 * mu * fac)
        x00, x01, x02, x11, x12, x22 = _sym_square(d00, d01, d02, d11, d12, d22)  # D^2
        J3d = (d00 * x00 + d11 * x11 + d22 * x22 + 2.0 * (d01 * x01 + d02 * x02 + d12 * x12)) / 3.0
        e0, e1, e2 = _exp_traceless(w * w * 0.5 * dd, w * w * w * J3d)
        f = c * _exp_small(t / 3.0)  # exp(-2 theta/3) = c exp(t/3), t = O(J2)
        f0, f1, f2 = f * e0, f * e1 * w, f * e2 * w * w
        Bout[q, 0, 0] = f0 + f1 * d00 + f2 * x00
        Bout[q, 1, 1] = f0 + f1 * d11 + f2 * x11
        Bout[q, 2, 2] = f0 + f1 * d22 + f2 * x22
        Bout[q, 0, 1] = Bout[q, 1, 0] = f1 * d01 + f2 * x01
        Bout[q, 0, 2] = Bout[q, 2, 0] = f1 * d02 + f2 * x02
        Bout[q, 1, 2] = Bout[q, 2, 1] = f1 * d12 + f2 * x12
        return 1
    # elastic: binv = bt (the exponential map is the identity)
    Bout[q, 0, 0], Bout[q, 1, 1], Bout[q, 2, 2] = bt00, bt11, bt22
    Bout[q, 0, 1] = Bout[q, 1, 0] = bt01
    Bout[q, 0, 2] = Bout[q, 2, 0] = bt02
    Bout[q, 1, 2] = Bout[q, 2, 1] = bt12
    return 0


@_njit
def _isochoric_points(Fu, Bn, eps_n, T_n, lmbda, mu, law, hp, tol, dt, tau, Bout, a, want_tangent, bt, Q, beta,
                      dtau, eqps, T_out):
    """Isochoric (exponential map, logarithmic strain) model for all points (as _seed_points).

    The spectral path below (eigen-decomposition of bt) is the definition. Full 3-D states (bt02 or
    bt12 non-zero) without tangent take :func:`_isochoric_series` instead (the same equations as
    series in dev(bt), no eigenvectors, ~3x cheaper), held to the spectral path to round-off by
    tests/test_isochoric_series.py; it hands back states with a large deviatoric elastic strain.
    Block-diagonal (2-D) states and the tangent always take the spectral path.
    """
    nplastic = 0
    for q in range(Fu.shape[0]):
        ia = q if want_tangent else 0
        b00, b01, b02, b11, b12, b22 = _predictor(Fu, Bn, q)  # (11)
        if not want_tangent and (b02 != 0.0 or b12 != 0.0):
            yielded = _isochoric_series(b00, b01, b02, b11, b12, b22, eps_n, T_n, lmbda, mu, law, hp, tol, dt, tau,
                                        Bout, eqps, T_out, q)
            if yielded >= 0:
                nplastic += yielded
                continue
        bt[0, 0], bt[0, 1], bt[0, 2], bt[1, 1], bt[1, 2], bt[2, 2] = b00, b01, b02, b11, b12, b22
        bt[1, 0], bt[2, 0], bt[2, 1] = bt[0, 1], bt[0, 2], bt[1, 2]
        _eigh3(bt, beta, Q)
        # principal logarithmic elastic strains eps_A = -1/2 ln beta_A and Kirchhoff stresses
        e0, e1, e2 = -0.5 * _ln_stretch(beta[0]), -0.5 * _ln_stretch(beta[1]), -0.5 * _ln_stretch(beta[2])
        tr_e = e0 + e1 + e2
        p = (lmbda + 2.0 * mu / 3.0) * tr_e
        # principal trial deviator s_A
        s0 = 2.0 * mu * (e0 - tr_e / 3.0)
        s1 = 2.0 * mu * (e1 - tr_e / 3.0)
        s2 = 2.0 * mu * (e2 - tr_e / 3.0)
        q_tr = math.sqrt(1.5 * (s0 * s0 + s1 * s1 + s2 * s2))
        if law == JOHNSON_COOK:
            dg, rr_factor, c, T_q = _return_map_jc(q_tr, eps_n[q], T_n[q], dt, mu, hp, tol)
            T_out[q] = T_q
        elif law == HENSEL_SPITTEL:
            dg, rr_factor, c = _return_map_hs(q_tr, eps_n[q], T_n[q], dt, mu, hp, tol)
            T_out[q] = T_n[q]
        else:
            dg, rr_factor, c = _return_map(q_tr, eps_n[q], mu, law, hp, tol)
        eqps[q] = eps_n[q] + dg
        nplastic += dg > 0.0
        fac = 1.5 * dg / q_tr if dg > 0.0 else 0.0  # n_A = 3/2 s_A / q_tr
        r = 1.0 - 2.0 * mu * fac
        _spectral(Q, p + r * s0, p + r * s1, p + r * s2, tau, q)
        if dg > 0.0:
            # exponential map: eps_A <- eps_A - dg n_A ;  binv = Q diag(exp(-2 eps_A)) Q^T
            # exp(-2 (eps_A - dg n_A)) = beta_A exp(2 dg n_A): dg n_A is the step's small plastic increment
            _spectral(Q, beta[0] * _exp_small(2.0 * fac * s0), beta[1] * _exp_small(2.0 * fac * s1),
                      beta[2] * _exp_small(2.0 * fac * s2), Bout, q)
        else:                       # elastic: binv = bt (the exponential map is the identity)
            for i in range(3):
                for j in range(3):
                    Bout[q, i, j] = bt[i, j]
        if not want_tangent:
            continue
        # tangent, built in the eigenbasis of bt for each unit l = e_k (x) e_l:
        #   delta eps'_AA = Q_kA Q_lA ;  delta eps'_AB = g_AB (beta_B Q_lA Q_kB + beta_A Q_kA Q_lB)/2
        #   delta tau' = D' delta eps' ;  a_ijkl = (Q delta tau' Q^T)_ij
        kap = lmbda + 2.0 * mu / 3.0
        nrm = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
        N0 = s0 / nrm if nrm > 0.0 else 0.0
        N1 = s1 / nrm if nrm > 0.0 else 0.0
        N2 = s2 / nrm if nrm > 0.0 else 0.0
        g01 = _g_log(beta[0], beta[1])
        g02 = _g_log(beta[0], beta[2])
        g12 = _g_log(beta[1], beta[2])
        for k in range(3):
            for l in range(3):
                d0 = Q[k, 0] * Q[l, 0]
                d1 = Q[k, 1] * Q[l, 1]
                d2 = Q[k, 2] * Q[l, 2]
                tr = d0 + d1 + d2
                nd = c * (N0 * d0 + N1 * d1 + N2 * d2)
                vol = kap * tr - 2.0 * mu * rr_factor * tr / 3.0
                dtau[0, 0] = vol + 2.0 * mu * rr_factor * d0 - nd * N0
                dtau[1, 1] = vol + 2.0 * mu * rr_factor * d1 - nd * N1
                dtau[2, 2] = vol + 2.0 * mu * rr_factor * d2 - nd * N2
                # shear: 2 mu rr_factor delta eps'_AB ; the symmetric off-diagonal pair shares the value
                v01 = mu * rr_factor * g01 * (beta[1] * Q[l, 0] * Q[k, 1] + beta[0] * Q[k, 0] * Q[l, 1])
                v02 = mu * rr_factor * g02 * (beta[2] * Q[l, 0] * Q[k, 2] + beta[0] * Q[k, 0] * Q[l, 2])
                v12 = mu * rr_factor * g12 * (beta[2] * Q[l, 1] * Q[k, 2] + beta[1] * Q[k, 1] * Q[l, 2])
                dtau[0, 1] = v01
                dtau[1, 0] = v01
                dtau[0, 2] = v02
                dtau[2, 0] = v02
                dtau[1, 2] = v12
                dtau[2, 1] = v12
                for i in range(3):
                    for j in range(i, 3):
                        v = 0.0
                        for A in range(3):
                            qa = Q[i, A]
                            for B in range(3):
                                v += qa * dtau[A, B] * Q[j, B]
                        a[ia, i, j, k, l] = v
                        a[ia, j, i, k, l] = v
    return nplastic


@_njit
def update_points(model, Fu, binv_n, eqps_n, temp_n, lmbda, mu, law, hp, yield_tol, dt, tau, binv, eqps, temp, a,
                  want_tangent):
    """Update n points: Fu, binv_n (n,3,3), eqps_n (n,) -> tau, binv (n,3,3), eqps (n,), a (n,3,3,3,3).

    temp_n -> temp (n,): temperature [K], read and written by the Johnson-Cook law only (other laws:
    may be dummy (1,) arrays); dt: the increment's time [s] (Johnson-Cook rate and heating; <= 0:
    none, the static convention).
    a is ignored (may be a dummy (1,3,3,3,3) array) when want_tangent is False.
    binv may be binv_n, eqps may be eqps_n and temp may be temp_n (update in place): each point is read
    before it is written. Returns the number of points that yielded in this update.
    """
    bt = np.empty((3, 3))
    Q = np.empty((3, 3))
    beta = np.empty(3)
    dtau = np.empty((3, 3))
    nb = np.empty((3, 3))
    if model == SEED:
        return _seed_points(Fu, binv_n, eqps_n, temp_n, lmbda, mu, law, hp, yield_tol, dt, tau, binv, a,
                            want_tangent, bt, nb, eqps, temp)
    return _isochoric_points(Fu, binv_n, eqps_n, temp_n, lmbda, mu, law, hp, yield_tol, dt, tau, binv, a,
                             want_tangent, bt, Q, beta, dtau, eqps, temp)


@_njit
def energy_points(model, binv, lmbda, mu, out):
    """Stored elastic energy psi [MPa = mJ/mm^3 of reference volume] of n points, eq. (9)."""
    Q = np.empty((3, 3))
    beta = np.empty(3)
    e = np.empty(3)
    for q in range(binv.shape[0]):
        B = binv[q]
        if model == SEED:
            tr = 0.5 * (3.0 - B[0, 0] - B[1, 1] - B[2, 2])
            ee = 0.0
            for i in range(3):
                for j in range(3):
                    eij = 0.5 * ((1.0 if i == j else 0.0) - B[i, j])
                    ee += eij * eij
        else:
            _eigh3(B, beta, Q)
            for A in range(3):
                e[A] = -0.5 * math.log(beta[A])
            tr = e[0] + e[1] + e[2]
            ee = e[0] ** 2 + e[1] ** 2 + e[2] ** 2
        out[q] = 0.5 * lmbda * tr * tr + mu * ee
