"""Tabulated hardening: sigma_y piecewise linear through (eps_i, sigma_i), the last slope continued
beyond the table [MPa]; parameters [m, eps_1..eps_m, sigma_1..sigma_m]."""
from fenics_plast.hardening_laws import HardeningLaw
from fenics_plast.scene_key import REQUIRED, Key


def flow(p, eps_p):
    """(sigma_y, dsigma_y/deps_p) [MPa] at eps_p, p = [m, eps_1..eps_m, sigma_1..sigma_m]."""
    # (indices into p, not slices: a slice is an array view, reference counted at every call)
    m = int(p[0])
    i = 0
    while i < m - 2 and eps_p > p[2 + i]:
        i += 1
    e0, e1, s0, s1 = p[1 + i], p[2 + i], p[1 + m + i], p[2 + m + i]
    slope = (s1 - s0) / (e1 - e0)
    return s0 + slope * (eps_p - e0), slope


def pack(kw: dict) -> list:
    """[m, strains..., stresses...] of the keywords ``strain`` and ``stress``."""
    strain = [float(e) for e in kw["strain"]]
    stress = [float(s) for s in kw["stress"]]
    if len(strain) != len(stress) or len(strain) < 2 or any(b <= a for a, b in zip(strain, strain[1:])):
        raise ValueError("table hardening needs >= 2 strictly increasing strains and as many stresses")
    return [len(strain), *strain, *stress]


def check(dotted: str, material, fail) -> None:
    """Scene rules (:class:`~fenics_plast.hardening_laws.HardeningLaw` ``check``): at least 2 strains, the
    first 0, strictly increasing; one stress >= 0 per strain."""
    h, d = material.hardening, f"{dotted}.hardening"
    eps, sig = h.strain, h.stress
    if len(eps) < 2:
        fail(f"{d}.strain has {len(eps)} entries: must have at least 2")
    if eps[0] != 0.0:
        fail(f"{d}.strain = {list(eps)} is not allowed: the first entry must be 0")
    if any(b <= a for a, b in zip(eps, eps[1:])):
        fail(f"{d}.strain = {list(eps)} is not allowed: must be strictly increasing")
    if len(sig) != len(eps):
        fail(f"{d}.stress has {len(sig)} entries: must have as many as {d}.strain ({len(eps)})")
    if any(x < 0 for x in sig):
        fail(f"{d}.stress = {list(sig)} is out of range: each entry must be >= 0")


LAW = HardeningLaw(
    "table", 3, "sigma_y piecewise linear through (strain, stress), the last slope continued beyond the table.",
    {"strain": Key("floats", REQUIRED, "Table: equivalent plastic strains, >= 2, strictly increasing, first 0."),
     "stress": Key("floats", REQUIRED, "Table: yield stress at each strain (piecewise linear), each >= 0.", "MPa")},
    flow, pack, check=check)
