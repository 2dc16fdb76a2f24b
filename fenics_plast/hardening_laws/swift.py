"""Swift hardening: sigma_y = K (eps0 + eps_p)^n [MPa]; parameters [K, eps_0, n]."""
from fenics_plast.hardening_laws import HardeningLaw
from fenics_plast.scene_key import REQUIRED, Key


def flow(p, eps_p):
    """(sigma_y, dsigma_y/deps_p) [MPa] at eps_p, p = [K, eps_0, n]."""
    base = p[1] + eps_p
    s = p[0] * base ** p[2]
    return s, p[2] * s / base


LAW = HardeningLaw(
    "swift", 1, "sigma_y = K (eps0 + eqps)^n.",
    {"K": Key("float", REQUIRED, "Strength coefficient: sigma_y = K (eps0 + eqps)^n.", "MPa", lo=0.0),
     "eps0": Key("float", REQUIRED, "Swift pre-strain.", "", lo=0.0),
     "n": Key("float", REQUIRED, "Hardening exponent.", "", lo=0.0, lo_open=False, hi=1.0, hi_open=False)},
    flow)
