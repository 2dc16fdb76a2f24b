"""Johnson-Cook hardening: sigma_y = (A + B eps_p^n)(1 + C ln r*)(1 - T*^m) [MPa], rate and temperature
dependent; parameters [A, B, n, C, rate_0, m, T_melt, T_room, chi, T_0] (positions ``JC_*``).

Not strain-only, so it has no ``flow`` here: :mod:`fenics_plast.material.hardening` holds its compiled
functions (the formulas are in its docstring) and :mod:`fenics_plast.material.kernels` its own return
map. This module declares its scene keys and packs them: chi = taylor_quinney / (rho c_p) [K/MPa], with
rho the material's density [tonne/mm^3] (keyword ``density``, from ``materials.<name>.density``).
"""
from fenics_plast.hardening_laws import HardeningLaw
from fenics_plast.scene_key import OPTIONAL, REQUIRED, Key, number_text

# parameter positions
JC_A, JC_B, JC_N, JC_C, JC_RATE0, JC_M, JC_TMELT, JC_TROOM, JC_CHI, JC_T0 = range(10)
#: rho [tonne/mm^3] x c_p [J/(kg K)] x this = rho c_p [MPa/K] (1 tonne = 1e3 kg, 1 J = 1e3 N mm)
RHO_CP_TO_MPA_PER_K = 1e6


def pack(kw: dict) -> list:
    """The parameter list; ``density`` [tonne/mm^3] besides the law's keys."""
    t_room, t_melt = float(kw["room_temperature"]), float(kw["melting_temperature"])
    t0 = kw.get("initial_temperature")
    t0 = t_room if t0 is None else float(t0)
    beta = float(kw["taylor_quinney"])
    rho, cp = float(kw["density"]), float(kw["specific_heat"])
    if not t_melt > t_room:
        raise ValueError(f"johnson_cook: melting_temperature {t_melt} K must exceed room_temperature "
                         f"{t_room} K")
    if not (rho > 0 and cp > 0 and 0.0 <= beta <= 1.0 and kw["reference_strain_rate"] > 0):
        raise ValueError("johnson_cook: density, specific_heat and reference_strain_rate must be > 0 "
                         "and 0 <= taylor_quinney <= 1")
    chi = beta / (rho * cp * RHO_CP_TO_MPA_PER_K)
    return [kw["A"], kw["B"], kw["n"], kw["C"], kw["reference_strain_rate"], kw["m"], t_melt, t_room, chi, t0]


def check(dotted: str, material, fail) -> None:
    """Scene rules (:class:`~fenics_plast.hardening_laws.HardeningLaw` ``check``): the material's density is
    given (adiabatic heating), melting above room temperature, the initial temperature below melting."""
    h, d = material.hardening, f"{dotted}.hardening"
    if material.density is None:
        fail(f"{dotted}.density is missing: required by {d}.law = 'johnson_cook' (adiabatic heating) [kg/m³]")
    if h.melting_temperature <= h.room_temperature:
        fail(f"{d}.melting_temperature = {number_text(h.melting_temperature)} is out of range: must exceed "
             f"{d}.room_temperature = {number_text(h.room_temperature)} [K]")
    if h.initial_temperature is not None and h.initial_temperature >= h.melting_temperature:
        fail(f"{d}.initial_temperature = {number_text(h.initial_temperature)} is out of range: must be below "
             f"{d}.melting_temperature = {number_text(h.melting_temperature)} [K]")


_POS = dict(lo=0.0)
LAW = HardeningLaw(
    "johnson_cook", 4,
    "sigma_y = (A + B eqps^n)(1 + C ln(max(rate, reference_strain_rate) / "
    "reference_strain_rate))(1 - T*^m), T* = (T - room_temperature) / (melting_temperature - "
    "room_temperature) clamped to [0, 1], rate the plastic strain rate, T the temperature of each "
    "quadrature point (a state variable, in fields.xdmf and checkpoints). Explicit analyses, and static ones "
    "with analysis.duration: the rate is the increment over its time and T rises by adiabatic heating dT = "
    "taylor_quinney sigma_y d eqps / (density specific_heat); with [thermal] (static) T is the temperature "
    "field's at the point instead (the field takes the plastic heat; specific_heat and taylor_quinney must be "
    "the material's, initial_temperature is [thermal]'s); static analyses without duration: no rate term and "
    "no heating, T stays initial_temperature. Needs materials.<name>.density.",
    {"A": Key("float", REQUIRED, "Johnson-Cook yield stress (at the reference rate and room temperature).", "MPa",
              lo=0.0, lo_open=False),
     "B": Key("float", REQUIRED, "Johnson-Cook strain-hardening modulus.", "MPa", lo=0.0, lo_open=False),
     "n": Key("float", REQUIRED, "Strain-hardening exponent (B eqps^n).", "", lo=0.0, lo_open=False,
              hi=1.0, hi_open=False),
     "C": Key("float", REQUIRED, "Johnson-Cook strain-rate sensitivity.", "", lo=0.0, lo_open=False),
     "reference_strain_rate": Key("float", 1.0, "Johnson-Cook reference plastic strain rate (no strengthening "
                                  "below it).", "1/s", **_POS),
     "m": Key("float", REQUIRED, "Johnson-Cook thermal-softening exponent.", "", **_POS),
     "melting_temperature": Key("float", REQUIRED, "Johnson-Cook melting temperature (no strength at or above "
                                "it).", "K", **_POS),
     "room_temperature": Key("float", REQUIRED, "Johnson-Cook reference (room) temperature: no thermal "
                             "softening at or below it.", "K", **_POS),
     "initial_temperature": Key("float", OPTIONAL, "Temperature at the start; absent = room_temperature.", "K",
                                **_POS),
     "specific_heat": Key("float", REQUIRED, "Specific heat c_p of the adiabatic heating dT = taylor_quinney "
                          "sigma_y d eqps / (density c_p).", "J/(kg K)", **_POS),
     "taylor_quinney": Key("float", 0.9, "Taylor-Quinney coefficient beta: the fraction of plastic work that "
                           "heats (0: no heating).", "", lo=0.0, lo_open=False, hi=1.0, hi_open=False)},
    pack=pack, thermal=True, check=check)
