"""Isotropic hardening laws: flow stress sigma_y(eps_p) [MPa] and slope dsigma_y/deps_p [MPa].

A law is packed into an integer code and a float parameter vector so that the numba
kernels can evaluate it without Python objects:

=======  ======================================================  =========================
code     flow stress                                              params
=======  ======================================================  =========================
LINEAR   sigma_0 + H eps_p                                        [sigma_0, H]
SWIFT    K (eps_0 + eps_p)^n                                      [K, eps_0, n]
VOCE     sigma_0 + Q (1 - exp(-b eps_p)) + H eps_p                [sigma_0, Q, b, H]
TABLE    piecewise linear through (eps_i, sigma_i), last slope    [m, eps_1..eps_m, sig_1..sig_m]
         continued beyond the table
JC       Johnson-Cook (A + B eps_p^n)(1 + C ln r*)(1 - T*^m)      [A, B, n, C, rate_0, m, T_melt,
         (rate and temperature: see below)                        T_room, chi, T_0]
=======  ======================================================  =========================

Johnson-Cook (``JOHNSON_COOK``): the flow stress depends on the equivalent plastic strain rate and
the temperature besides eps_p,

    sigma_y = (A + B eps_p^n) (1 + C ln(max(rate, rate_0) / rate_0)) (1 - T*^m),
    T* = (T - T_room) / (T_melt - T_room) clamped to [0, 1],

so no strengthening below the reference rate rate_0 [1/s] or below room temperature, and no strength
at or above melting. The temperature T [K] is a state variable of each point, raised by adiabatic
heating dT = chi sigma_y d eps_p with chi = beta / (rho c_p) [K/MPa] (Taylor-Quinney beta, reference
density rho, specific heat c_p). The return map (kernels.py) evaluates the law through
:func:`johnson_cook`, with the rate and temperature of the increment; :func:`flow_stress` gives
the curve at the reference rate and the initial temperature T_0 (the quasi-static isothermal curve).
"""
from __future__ import annotations

import math

import numba
import numpy as np

from fenics_plast.schema import default

LINEAR, SWIFT, VOCE, TABLE, JOHNSON_COOK = 0, 1, 2, 3, 4
_CODES = {"linear": LINEAR, "swift": SWIFT, "voce": VOCE, "table": TABLE, "johnson_cook": JOHNSON_COOK}
# Johnson-Cook parameter positions
JC_A, JC_B, JC_N, JC_C, JC_RATE0, JC_M, JC_TMELT, JC_TROOM, JC_CHI, JC_T0 = range(10)
#: rho [tonne/mm^3] x c_p [J/(kg K)] x this = rho c_p [MPa/K] (1 tonne = 1e3 kg, 1 J = 1e3 N mm)
RHO_CP_TO_MPA_PER_K = 1e6


@numba.njit(cache=True, fastmath=False)
def flow_stress(law: int, p: np.ndarray, eps_p: float):
    """Return (sigma_y, dsigma_y/deps_p) in MPa at equivalent plastic strain eps_p."""
    if law == LINEAR:
        return p[0] + p[1] * eps_p, p[1]
    if law == SWIFT:
        base = p[1] + eps_p
        s = p[0] * base ** p[2]
        return s, p[2] * s / base
    if law == VOCE:
        e = math.exp(-p[2] * eps_p)
        return p[0] + p[1] * (1.0 - e) + p[3] * eps_p, p[1] * p[2] * e + p[3]
    if law == JOHNSON_COOK:
        # reference rate, initial temperature: the quasi-static isothermal curve
        s, h, _ = johnson_cook(p, eps_p, 0.0, 0.0, p[JC_T0])
        return s, h
    # TABLE
    # (indices into p, not slices: a slice is an array view, reference counted at every call)
    m = int(p[0])
    i = 0
    while i < m - 2 and eps_p > p[2 + i]:
        i += 1
    e0, e1, s0, s1 = p[1 + i], p[2 + i], p[1 + m + i], p[2 + m + i]
    slope = (s1 - s0) / (e1 - e0)
    return s0 + slope * (eps_p - e0), slope


@numba.njit(cache=True, fastmath=False)
def jc_strain_rate(p, eps_p, dg, dt):
    """Johnson-Cook strain and rate terms G = (A + B eps_p^n)(1 + C ln(max(dg / dt, rate_0) / rate_0))
    at the end of an increment dg = d eps_p over the time dt [s] (dt <= 0: no physical time, the rate
    term is 1), and dG/ddg (eps_p = eps_n + dg; the rate term contributes C / dg = C / (rate dt)
    above the reference rate). [MPa, MPa]"""
    A, B, n, C = p[JC_A], p[JC_B], p[JC_N], p[JC_C]
    # strain hardening A + B eps^n (slope infinite at eps = 0 for n < 1: never used there, the
    # return map starts its iteration at dg > 0)
    if eps_p > 0.0:
        en = eps_p ** n
        g1 = A + B * en
        dg1 = B * n * en / eps_p
    else:
        g1 = A + (B if n == 0.0 else 0.0)
        dg1 = B if n == 1.0 else 0.0
    if dt > 0.0 and C != 0.0 and dg > 0.0:
        r = dg / (dt * p[JC_RATE0])
        if r > 1.0:
            rf = 1.0 + C * math.log(r)
            return g1 * rf, dg1 * rf + g1 * C / dg
    return g1, dg1


@numba.njit(cache=True, fastmath=False)
def jc_softening(p, T):
    """Johnson-Cook thermal factor theta = 1 - T*^m, T* = (T - T_room) / (T_melt - T_room) clamped to
    [0, 1], and d theta / dT [1/K] at the temperature T [K]."""
    span = p[JC_TMELT] - p[JC_TROOM]
    ts = (T - p[JC_TROOM]) / span
    if ts <= 0.0:
        return 1.0, 0.0
    if ts >= 1.0:
        return 0.0, 0.0
    tm = ts ** p[JC_M]
    return 1.0 - tm, -p[JC_M] * tm / (ts * span)


@numba.njit(cache=True, fastmath=False)
def johnson_cook(p, eps_p, dg, dt, T):
    """Johnson-Cook flow stress at the end of an increment dg = d eps_p over the time dt [s], at the
    temperature T [K] (:func:`jc_strain_rate` x :func:`jc_softening`).

    Returns (sigma_y, d sigma_y / d dg at fixed T, d sigma_y / d T) [MPa, MPa, MPa/K].
    """
    g, g_dg = jc_strain_rate(p, eps_p, dg, dt)
    th, dth = jc_softening(p, T)
    return g * th, g_dg * th, g * dth


class Hardening:
    """An isotropic hardening law (see the module docstring for the formulas).

    >>> Hardening("linear", yield_stress=400.0, modulus=100.0)      # MPa
    >>> Hardening("swift", K=589.0, eps0=1e-4, n=0.216)
    >>> Hardening("voce", yield_stress=300.0, Q=200.0, b=10.0, modulus=50.0)
    >>> Hardening("table", strain=[0, 0.1, 1.0], stress=[200, 300, 400])
    >>> Hardening("johnson_cook", A=90.0, B=292.0, n=0.31, C=0.025, reference_strain_rate=1.0, m=1.09,
    ...           melting_temperature=1356.0, room_temperature=294.0, specific_heat=383.0,
    ...           density=8.96e-9)        # taylor_quinney, initial_temperature (= room) by default

    Johnson-Cook: rates in 1/s, temperatures in K, specific heat in J/(kg K), density in
    tonne/mm^3; ``thermal`` is True and ``initial_temperature`` [K] the temperature of a virgin point.
    Parameters left out take the schema's defaults (``materials.<name>.hardening.*``,
    :func:`fenics_plast.schema.default`).
    """

    def __init__(self, law: str, **kw):
        if law not in _CODES:
            raise ValueError(f"unknown hardening law {law!r}; allowed: {sorted(_CODES)}")
        self.law = law
        self.code = _CODES[law]
        if law == "linear":
            params = [kw["yield_stress"], kw.get("modulus", default("materials.*.hardening.modulus"))]
        elif law == "swift":
            params = [kw["K"], kw["eps0"], kw["n"]]
        elif law == "voce":
            params = [kw["yield_stress"], kw["Q"], kw["b"], kw.get("modulus", default("materials.*.hardening.modulus"))]
        elif law == "johnson_cook":
            t_room, t_melt = float(kw["room_temperature"]), float(kw["melting_temperature"])
            t0 = kw.get("initial_temperature")
            t0 = t_room if t0 is None else float(t0)
            beta = float(kw.get("taylor_quinney", default("materials.*.hardening.taylor_quinney")))
            rho, cp = float(kw["density"]), float(kw["specific_heat"])
            if not t_melt > t_room:
                raise ValueError(f"johnson_cook: melting_temperature {t_melt} K must exceed room_temperature "
                                 f"{t_room} K")
            if not (rho > 0 and cp > 0 and 0.0 <= beta <= 1.0 and kw["reference_strain_rate"] > 0):
                raise ValueError("johnson_cook: density, specific_heat and reference_strain_rate must be > 0 "
                                 "and 0 <= taylor_quinney <= 1")
            chi = beta / (rho * cp * RHO_CP_TO_MPA_PER_K)
            params = [kw["A"], kw["B"], kw["n"], kw["C"], kw["reference_strain_rate"], kw["m"], t_melt, t_room,
                      chi, t0]
        else:
            strain = np.asarray(kw["strain"], dtype=float)
            stress = np.asarray(kw["stress"], dtype=float)
            if strain.shape != stress.shape or strain.size < 2 or np.any(np.diff(strain) <= 0):
                raise ValueError("table hardening needs >= 2 strictly increasing strains and as many stresses")
            params = [strain.size, *strain, *stress]
        self.params = np.asarray(params, dtype=float)

    def __call__(self, eps_p):
        """Flow stress and slope [MPa] at eps_p (scalar or array)."""
        eps = np.atleast_1d(np.asarray(eps_p, dtype=float))
        out = np.array([flow_stress(self.code, self.params, e) for e in eps])
        return out[:, 0].reshape(np.shape(eps_p)), out[:, 1].reshape(np.shape(eps_p))

    @property
    def thermal(self) -> bool:
        """True for a law with a temperature state (Johnson-Cook)."""
        return self.code == JOHNSON_COOK

    @property
    def initial_temperature(self) -> float:
        """Temperature of a virgin point [K] (Johnson-Cook; 0 for the other laws: no temperature)."""
        return float(self.params[JC_T0]) if self.thermal else 0.0

    def johnson_cook(self, eps_p, rate=0.0, T=None):
        """Johnson-Cook flow stress [MPa] at eps_p, the plastic strain rate ``rate`` [1/s] (below the
        reference rate: no rate term) and T [K] (default: the initial temperature)."""
        if not self.thermal:
            raise ValueError(f"{self.law!r} is not the johnson_cook law")
        T = self.initial_temperature if T is None else float(T)
        return float(johnson_cook(self.params, float(eps_p), float(rate), 1.0, T)[0])

    @property
    def initial_yield_stress(self) -> float:
        return float(flow_stress(self.code, self.params, 0.0)[0])

    def __repr__(self):
        return f"Hardening({self.law!r}, params={self.params.tolist()})"
