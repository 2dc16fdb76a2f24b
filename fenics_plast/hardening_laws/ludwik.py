"""Ludwik hardening: sigma_y = yield_stress + K eps_p^n [MPa]; parameters [sigma_0, K, n].

Why Ludwik and not Hollomon (sigma_y = K eps_p^n): Hollomon's initial yield stress is 0, so a virgin
point has no elastic range (any load yields), which is not what the metals it is fitted to do; Ludwik
keeps the elastic range below yield_stress and is Hollomon again at yield_stress = 0. Swift
(K (eps0 + eps_p)^n) avoids the trouble below with a pre-strain, at the cost of tying the initial
yield stress to K and n; Ludwik keeps the two apart.

Safeguard at eps_p = 0: for 0 < n < 1 the slope n K eps_p^(n-1) is infinite there (and the formula
n K eps_p^n / eps_p is 0/0). The slope is read at eps_p = 0 only by the first Newton iterate of a
virgin point's return map (kernels: dg = 0), so :func:`flow` returns the slope 0 there (K at n = 1,
where it is exact): that first step is then the perfectly plastic one, dg = (q_tr - yield_stress) /
(3 mu), an upper bound of the root (the residual is -K dg^n <= 0 there); the residual is convex in dg,
so Newton continues from the other side and converges monotonically, inside the bisection safeguard
of the return map. An infinite slope would make that first step 0 and leave it to bisection.
"""
from fenics_plast.hardening_laws import HardeningLaw
from fenics_plast.scene_key import REQUIRED, Key


def flow(p, eps_p):
    """(sigma_y, dsigma_y/deps_p) [MPa] at eps_p, p = [sigma_0, K, n] (slope at eps_p = 0: see the module
    docstring)."""
    if eps_p > 0.0:
        en = eps_p ** p[2]
        return p[0] + p[1] * en, p[2] * p[1] * en / eps_p
    # eps_p = 0: eps_p^n is 1 at n = 0 (0^0) and 0 otherwise
    return p[0] + (p[1] if p[2] == 0.0 else 0.0), (p[1] if p[2] == 1.0 else 0.0)


LAW = HardeningLaw(
    "ludwik", 5, "sigma_y = yield_stress + K eqps^n (yield_stress = 0: Hollomon).",
    {"yield_stress": Key("float", REQUIRED, "Initial yield stress.", "MPa", lo=0.0, lo_open=False),
     "K": Key("float", REQUIRED, "Strength coefficient: sigma_y = yield_stress + K eqps^n.", "MPa",
              lo=0.0),
     "n": Key("float", REQUIRED, "Hardening exponent.", "", lo=0.0, lo_open=False, hi=1.0,
              hi_open=False)},
    flow)
