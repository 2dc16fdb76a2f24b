"""Isotropic hardening laws, compiled: flow stress sigma_y(eps_p) [MPa] and slope dsigma_y/deps_p [MPa].

Each law is declared in its own module of :mod:`fenics_plast.hardening_laws` (name, integer code, scene
keys, packing into a float parameter vector, flow function; the module's docstring gives the formula and
the vector's layout). The numba kernels evaluate a law from its code and vector, without Python objects:
:func:`flow_stress` dispatches on the code over every registered law (a chain of compiled links, built
here from the registry and cached like any kernel). ``LINEAR`` ... ``JOHNSON_COOK``: the codes the
kernels single out.

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

from fenics_plast.hardening_laws import laws
from fenics_plast.hardening_laws.johnson_cook import (JC_A, JC_B, JC_C, JC_CHI, JC_M, JC_N, JC_RATE0, JC_T0,
                                                      JC_TMELT, JC_TROOM)
from fenics_plast.hardening_laws.hensel_spittel import (CELSIUS, HS_A, HS_EMIN, HS_M1, HS_M2, HS_M3, HS_M4, HS_M5,
                                                        HS_M7, HS_M8, HS_M9, HS_RMIN, HS_T0)

_LAWS = laws()
LINEAR, SWIFT, VOCE, TABLE, JOHNSON_COOK, HENSEL_SPITTEL = (
    _LAWS[name].code for name in ("linear", "swift", "voce", "table", "johnson_cook", "hensel_spittel"))
#: the parameter holding a temperature-dependent law's initial temperature [K]
_T0 = {"johnson_cook": JC_T0, "hensel_spittel": HS_T0}


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


@numba.njit(cache=True, fastmath=False)
def johnson_cook_curve(p, eps_p):
    """Johnson-Cook flow stress and slope [MPa] at the reference rate and the initial temperature T_0
    (the quasi-static isothermal curve): the law's ``flow`` in :func:`flow_stress`."""
    s, h, _ = johnson_cook(p, eps_p, 0.0, 0.0, p[JC_T0])
    return s, h


@numba.njit(cache=True, fastmath=False)
def hensel_spittel(p, eps_p, dg, dt, T):
    """Hensel-Spittel flow stress and its slope in dg [MPa, MPa] at the end of an increment dg = d eps_p over
    dt [s] (eps_p = eps_n + dg; rate dg / dt, dt <= 0: the minimum rate), at T [K] (hardening_laws.hensel_spittel:
    the formula, the floors of strain and rate, below which the slope's part is 0)."""
    Tc = T - CELSIUS
    e_min, r_min = p[HS_EMIN], p[HS_RMIN]
    e = eps_p if eps_p > e_min else e_min
    rate = dg / dt if dt > 0.0 else 0.0
    r = rate if rate > r_min else r_min
    ln_s = (math.log(p[HS_A]) + p[HS_M1] * Tc + p[HS_M9] * math.log(Tc) + p[HS_M2] * math.log(e) + p[HS_M4] / e
            + p[HS_M5] * Tc * math.log(1.0 + e) + p[HS_M7] * e + (p[HS_M3] + p[HS_M8] * Tc) * math.log(r))
    s = math.exp(ln_s)
    slope = 0.0
    if eps_p > e_min:
        slope += p[HS_M2] / e - p[HS_M4] / (e * e) + p[HS_M5] * Tc / (1.0 + e) + p[HS_M7]
    if dt > 0.0 and rate > r_min:
        slope += (p[HS_M3] + p[HS_M8] * Tc) / dg
    return s, s * slope


@numba.njit(cache=True, fastmath=False)
def hensel_spittel_curve(p, eps_p):
    """Hensel-Spittel flow stress and slope [MPa] at the minimum rate and the initial temperature T_0: the law's
    ``flow`` in :func:`flow_stress`."""
    return hensel_spittel(p, eps_p, 0.0, 0.0, p[HS_T0])


#: compiled flow of the laws that declare none (their flow stress needs more than eps_p)
_OWN_FLOWS = {"johnson_cook": johnson_cook_curve, "hensel_spittel": hensel_spittel_curve}


@numba.njit(cache=True, fastmath=False)
def _no_law(law, p, eps_p):
    return math.nan, math.nan


def _link(code, flow, rest):
    """A compiled dispatcher: ``flow(p, eps_p)`` for the law ``code``, else ``rest(law, p, eps_p)``
    (numba caches a closure by the contents of its cells: one cache entry per link)."""
    @numba.njit(cache=True, fastmath=False)
    def dispatch(law, p, eps_p):
        if law == code:
            return flow(p, eps_p)
        return rest(law, p, eps_p)
    return dispatch


def _chain():
    """The dispatcher over every registered law, first code tested first."""
    chain = _no_law
    for law in reversed(tuple(_LAWS.values())):
        flow = _OWN_FLOWS[law.name] if law.flow is None else numba.njit(cache=True, fastmath=False)(law.flow)
        chain = _link(law.code, flow, chain)
    return chain


_dispatch = _chain()


@numba.njit(cache=True, fastmath=False)
def flow_stress(law: int, p: np.ndarray, eps_p: float):
    """Return (sigma_y, dsigma_y/deps_p) in MPa at equivalent plastic strain eps_p of the law with code
    ``law`` (NaN for an unknown code)."""
    return _dispatch(law, p, eps_p)


class Hardening:
    """An isotropic hardening law (see the module docstring for the formulas).

    >>> Hardening("linear", yield_stress=400.0, modulus=100.0)      # MPa
    >>> Hardening("swift", K=589.0, eps0=1e-4, n=0.216)
    >>> Hardening("voce", yield_stress=300.0, Q=200.0, b=10.0, modulus=50.0)
    >>> Hardening("table", strain=[0, 0.1, 1.0], stress=[200, 300, 400])
    >>> Hardening("ludwik", yield_stress=200.0, K=500.0, n=0.3)
    >>> Hardening("johnson_cook", A=90.0, B=292.0, n=0.31, C=0.025, reference_strain_rate=1.0, m=1.09,
    ...           melting_temperature=1356.0, room_temperature=294.0, specific_heat=383.0,
    ...           density=8.96e-9)        # taylor_quinney, initial_temperature (= room) by default

    Johnson-Cook: rates in 1/s, temperatures in K, specific heat in J/(kg K), density in
    tonne/mm^3; ``thermal`` is True and ``initial_temperature`` [K] the temperature of a virgin point.
    Parameters left out take their declared defaults (the law's module in
    :mod:`fenics_plast.hardening_laws`, the schema's ``materials.<name>.hardening.*``).
    """

    def __init__(self, law: str, **kw):
        if law not in _LAWS:
            raise ValueError(f"unknown hardening law {law!r}; allowed: {sorted(_LAWS)}")
        self.law = law
        self.code = _LAWS[law].code
        params = _LAWS[law].vector(kw)
        self.params = np.asarray(params, dtype=float)

    def __call__(self, eps_p):
        """Flow stress and slope [MPa] at eps_p (scalar or array)."""
        eps = np.atleast_1d(np.asarray(eps_p, dtype=float))
        out = np.array([flow_stress(self.code, self.params, e) for e in eps])
        return out[:, 0].reshape(np.shape(eps_p)), out[:, 1].reshape(np.shape(eps_p))

    @property
    def thermal(self) -> bool:
        """True for a law with a temperature state (Johnson-Cook, Hensel-Spittel)."""
        return _LAWS[self.law].thermal

    @property
    def initial_temperature(self) -> float:
        """Temperature of a virgin point [K] (the thermal laws: Johnson-Cook, Hensel-Spittel; 0 for the
        other laws: no temperature)."""
        return float(self.params[_T0[self.law]]) if self.thermal else 0.0

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
