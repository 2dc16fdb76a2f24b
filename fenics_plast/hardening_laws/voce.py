"""Voce hardening: sigma_y = sigma_0 + Q (1 - exp(-b eps_p)) + H eps_p [MPa]; parameters [sigma_0, Q, b, H]."""
import math

from fenics_plast.hardening_laws import HardeningLaw
from fenics_plast.scene_key import REQUIRED, Key


def flow(p, eps_p):
    """(sigma_y, dsigma_y/deps_p) [MPa] at eps_p, p = [sigma_0, Q, b, H]."""
    e = math.exp(-p[2] * eps_p)
    return p[0] + p[1] * (1.0 - e) + p[3] * eps_p, p[1] * p[2] * e + p[3]


LAW = HardeningLaw(
    "voce", 2, "sigma_y = yield_stress + Q (1 - exp(-b eqps)) + modulus eqps.",
    {"yield_stress": Key("float", REQUIRED, "Initial yield stress.", "MPa", lo=0.0, lo_open=False),
     "Q": Key("float", REQUIRED, "Voce: sigma_y = yield_stress + Q (1 - exp(-b eqps)) + modulus eqps.", "MPa",
              lo=0.0, lo_open=False),
     "b": Key("float", REQUIRED, "Voce saturation rate.", "", lo=0.0),
     "modulus": Key("float", 0.0, "Added linear term.", "MPa", lo=0.0, lo_open=False)},
    flow)
