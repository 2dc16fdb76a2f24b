"""Linear hardening: sigma_y = yield_stress + modulus eps_p [MPa]; parameters [sigma_0, H].

The return map (:mod:`fenics_plast.material.kernels`) knows this law's radial-return equation is
linear and takes Newton's exact first step (it reads H = p[1]).
"""
from fenics_plast.hardening_laws import HardeningLaw
from fenics_plast.scene_key import REQUIRED, Key


def flow(p, eps_p):
    """(sigma_y, dsigma_y/deps_p) [MPa] at eps_p, p = [sigma_0, H]."""
    return p[0] + p[1] * eps_p, p[1]


LAW = HardeningLaw(
    "linear", 0, "sigma_y = yield_stress + modulus eqps.",
    {"yield_stress": Key("float", REQUIRED, "Initial yield stress.", "MPa", lo=0.0, lo_open=False),
     "modulus": Key("float", 0.0, "Linear hardening modulus.", "MPa", lo=0.0, lo_open=False)},
    flow)
