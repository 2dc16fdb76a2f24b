"""Hensel-Spittel hardening, the hot flow stress of the forging codes: temperature and strain-rate dependent,

    sigma_y = A exp(m1 T) T^m9 eps^m2 exp(m4 / eps) (1 + eps)^(m5 T) exp(m7 eps) rate^(m3 + m8 T)   [MPa]

with T in degrees Celsius (the temperature field's, T [K] - 273.15; it must exceed 0 C), eps the equivalent
plastic strain and rate its rate [1/s], each taken at least ``minimum_strain`` and ``minimum_strain_rate``
(the law vanishes at eps = 0 and rate = 0: below these floors the flow stress is theirs). Parameters
[A, m1, m2, m3, m4, m5, m7, m8, m9, minimum_strain, minimum_strain_rate, T_0] (positions ``HS_*``); T_0 [K]
the temperature of a virgin point (the run's thermal.initial_temperature).

Not strain-only, so it has no ``flow`` here: :mod:`fenics_plast.material.hardening` holds its compiled
function and :mod:`fenics_plast.material.kernels` its return map (the temperature of the increment fixed:
the staggered split of [thermal], which this law needs).
"""
from fenics_plast.hardening_laws import HardeningLaw
from fenics_plast.scene_key import REQUIRED, Key

HS_A, HS_M1, HS_M2, HS_M3, HS_M4, HS_M5, HS_M7, HS_M8, HS_M9, HS_EMIN, HS_RMIN, HS_T0 = range(12)
#: T [K] - this = T [C]
CELSIUS = 273.15


def pack(kw: dict) -> list:
    """The parameter list; ``initial_temperature`` [K] besides the law's keys (the run's, 293.15 K absent)."""
    t0 = kw.get("initial_temperature")
    return [kw["A"], kw["m1"], kw["m2"], kw["m3"], kw["m4"], kw["m5"], kw["m7"], kw["m8"], kw["m9"],
            kw["minimum_strain"], kw["minimum_strain_rate"], 293.15 if t0 is None else float(t0)]


def _exponent(doc):
    return Key("float", 0.0, doc, "")


LAW = HardeningLaw(
    "hensel_spittel", 7,
    "sigma_y = A exp(m1 T) T^m9 eqps^m2 exp(m4 / eqps) (1 + eqps)^(m5 T) exp(m7 eqps) rate^(m3 + m8 T), T the "
    "temperature in degrees Celsius (above 0), eqps and rate (the plastic strain rate, 1/s) at least "
    "minimum_strain and minimum_strain_rate: the hot flow stress of the forging codes. Needs [thermal] (the "
    "temperature field, the physical time of the rate).",
    {"A": Key("float", REQUIRED, "Hensel-Spittel amplitude A.", "MPa", lo=0.0, lo_open=False),
     "m1": _exponent("Hensel-Spittel m1, of exp(m1 T) [1/C]."),
     "m2": _exponent("Hensel-Spittel m2, of eqps^m2."),
     "m3": _exponent("Hensel-Spittel m3, of rate^m3."),
     "m4": _exponent("Hensel-Spittel m4, of exp(m4 / eqps)."),
     "m5": _exponent("Hensel-Spittel m5, of (1 + eqps)^(m5 T) [1/C]."),
     "m7": _exponent("Hensel-Spittel m7, of exp(m7 eqps)."),
     "m8": _exponent("Hensel-Spittel m8, of rate^(m8 T) [1/C]."),
     "m9": _exponent("Hensel-Spittel m9, of T^m9."),
     "minimum_strain": Key("float", 0.01, "Hensel-Spittel: below this plastic strain the flow stress is its.", "",
                           lo=0.0),
     "minimum_strain_rate": Key("float", 0.01, "Hensel-Spittel: below this plastic strain rate the flow stress is "
                                "its.", "1/s", lo=0.0)},
    pack=pack, thermal=True)
