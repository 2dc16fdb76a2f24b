"""Hockett-Sherby hardening: sigma_y = sigma_sat - (sigma_sat - sigma_0) exp(-b eps_p^n) [MPa]; parameters
[sigma_0, sigma_sat, b, n].

A saturating law for large plastic strains (Hockett and Sherby, J. Mech. Phys. Solids 23 (1975) 87-98),
used in sheet and bulk forming where Swift's power law overshoots the measured stress at large strains and
Voce's exponential (the case n = 1, Q = sigma_sat - sigma_0, no linear term) saturates too early.

Slope (sigma_sat - sigma_0) b n eps_p^(n-1) exp(-b eps_p^n): infinite at eps_p = 0 for n < 1. As for Ludwik
(:mod:`~fenics_plast.hardening_laws.ludwik`), :func:`flow` returns the slope 0 there (exact at n = 1): it
is read only by the first Newton iterate of a virgin point's return map, which then takes the perfectly
plastic step, an upper bound of the root; the residual is convex in the increment (sigma_y is concave), so
Newton continues monotonically inside the return map's bisection bracket.
"""
import math

from fenics_plast.hardening_laws import HardeningLaw
from fenics_plast.scene_key import REQUIRED, Key, number_text


def flow(p, eps_p):
    """(sigma_y, dsigma_y/deps_p) [MPa] at eps_p, p = [sigma_0, sigma_sat, b, n] (slope at eps_p = 0: see the
    module docstring)."""
    if eps_p > 0.0:
        en = eps_p ** p[3]
        e = math.exp(-p[2] * en)
        return p[1] - (p[1] - p[0]) * e, (p[1] - p[0]) * p[2] * p[3] * en / eps_p * e
    return p[0], ((p[1] - p[0]) * p[2] if p[3] == 1.0 else 0.0)


def check(dotted: str, material, fail) -> None:
    """Scene rule: the saturation stress is at least the initial yield stress (hardening, not softening)."""
    h, d = material.hardening, f"{dotted}.hardening"
    if h.saturation_stress < h.yield_stress:
        fail(f"{d}.saturation_stress = {number_text(h.saturation_stress)} is out of range: must be at least "
             f"{d}.yield_stress = {number_text(h.yield_stress)} [MPa]")


LAW = HardeningLaw(
    "hockett_sherby", 6, "sigma_y = saturation_stress - (saturation_stress - yield_stress) exp(-b eqps^n).",
    {"yield_stress": Key("float", REQUIRED, "Initial yield stress.", "MPa", lo=0.0, lo_open=False),
     "saturation_stress": Key("float", REQUIRED, "Hockett-Sherby: the flow stress at large strains.", "MPa",
                              lo=0.0, lo_open=False),
     "b": Key("float", REQUIRED, "Hockett-Sherby saturation rate.", "", lo=0.0),
     "n": Key("float", REQUIRED, "Hardening exponent.", "", lo=0.0, lo_open=False, hi=1.0, hi_open=False)},
    flow, check=check)
