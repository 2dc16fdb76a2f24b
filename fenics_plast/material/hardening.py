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
=======  ======================================================  =========================
"""
from __future__ import annotations

import math

import numba
import numpy as np

LINEAR, SWIFT, VOCE, TABLE = 0, 1, 2, 3
_CODES = {"linear": LINEAR, "swift": SWIFT, "voce": VOCE, "table": TABLE}


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
    # TABLE
    m = int(p[0])
    strain = p[1:1 + m]
    stress = p[1 + m:1 + 2 * m]
    i = 0
    while i < m - 2 and eps_p > strain[i + 1]:
        i += 1
    slope = (stress[i + 1] - stress[i]) / (strain[i + 1] - strain[i])
    return stress[i] + slope * (eps_p - strain[i]), slope


class Hardening:
    """An isotropic hardening law (see the module docstring for the formulas).

    >>> Hardening("linear", yield_stress=400.0, modulus=100.0)      # MPa
    >>> Hardening("swift", K=589.0, eps0=1e-4, n=0.216)
    >>> Hardening("voce", yield_stress=300.0, Q=200.0, b=10.0, modulus=50.0)
    >>> Hardening("table", strain=[0, 0.1, 1.0], stress=[200, 300, 400])
    """

    def __init__(self, law: str, **kw):
        if law not in _CODES:
            raise ValueError(f"unknown hardening law {law!r}; allowed: {sorted(_CODES)}")
        self.law = law
        self.code = _CODES[law]
        if law == "linear":
            params = [kw["yield_stress"], kw.get("modulus", 0.0)]
        elif law == "swift":
            params = [kw["K"], kw["eps0"], kw["n"]]
        elif law == "voce":
            params = [kw["yield_stress"], kw["Q"], kw["b"], kw.get("modulus", 0.0)]
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
    def initial_yield_stress(self) -> float:
        return float(flow_stress(self.code, self.params, 0.0)[0])

    def __repr__(self):
        return f"Hardening({self.law!r}, params={self.params.tolist()})"
