"""The thermal boundary types a scene's ``[thermal_boundary.<name>]`` tables name: a registry
(:data:`TYPES`, name -> :class:`ThermalBoundaryType`), read by the schema (each type's keys, with
their units and ranges) and by :class:`fenics_plast.thermal.heat.HeatConduction` (what each type adds
to the heat equation). An unknown type is refused by the schema's choices; there is no default branch.

Sign convention: heat INTO the body is positive. Units inside the package: temperature K, heat flux
mW/mm^2 (1 W/m^2 = 1e-3 mW/mm^2: the scale of the scene keys), film coefficient mW/(mm^2 K),
time s; the heat of a step mJ (= N mm).

Each type's boundary term over its group, in the current configuration (da: the current area
element, in axisymmetry of the whole revolved surface), for the backward-Euler step from T_n to T
over dt (``HeatConduction`` multiplies by dt):

* ``temperature``: T = temperature on the group's nodes (a Dirichlet condition; its heat is the reaction
  of the heat equation there);
* ``heat_flux``: q = flux into the body: + int q v da;
* ``convection``: q = h (T_ambient - T): + int h (T_ambient - T) v da (implicit in T);
* ``radiation``: q = emissivity sigma (T_ambient^4 - T^4), linearised about T_n
  (T^4 ~ T_n^4 + 4 T_n^3 (T - T_n): first order in dt like the step itself, so the scheme stays
  linear and unconditionally stable).

Standard library only (the schema imports it).
"""
from __future__ import annotations

from dataclasses import dataclass

from fenics_plast.scene_key import REQUIRED, Key

__all__ = ["ThermalBoundaryType", "TYPES", "STEFAN_BOLTZMANN", "W_M2"]

#: scene heat fluxes and film coefficients are written per m^2 in W: x this -> mW/mm^2
W_M2 = 1e-3
#: Stefan-Boltzmann constant [mW/(mm^2 K^4)] (5.670374419e-8 W/(m^2 K^4))
STEFAN_BOLTZMANN = 5.670374419e-8 * W_M2


@dataclass(frozen=True)
class ThermalBoundaryType:
    """One kind of thermal boundary: ``name`` (the scene's ``type``), ``doc``, its scene ``keys``
    ({name: Key}), and how it enters the heat equation: ``dirichlet`` (a prescribed temperature) or
    a flux into the body that is affine in T, q = a(T_n) + b(T_n) T, given by ``flux_terms(spec, T_n)``
    -> (a, b) of UFL expressions [mW/mm^2, mW/(mm^2 K)]."""
    name: str
    doc: str
    keys: dict
    dirichlet: bool = False
    flux_terms: object = None


def _heat_flux(spec, T_n):
    return spec.flux, 0.0


def _convection(spec, T_n):
    return spec.film_coefficient * spec.ambient_temperature, -spec.film_coefficient


def _radiation(spec, T_n):
    c = spec.emissivity * STEFAN_BOLTZMANN
    return c * (spec.ambient_temperature ** 4 + 3.0 * T_n ** 4), -4.0 * c * T_n ** 3


_AMBIENT = Key("float", REQUIRED, "Temperature of the surroundings.", "K", lo=0.0)

TYPES = {t.name: t for t in (
    ThermalBoundaryType("temperature", "temperature: the group's nodes held at `temperature`",
                        {"temperature": Key("float", REQUIRED, "The prescribed temperature.", "K", lo=0.0)},
                        dirichlet=True),
    ThermalBoundaryType("heat_flux", "heat_flux: `flux` into the body (negative: out of it)",
                        {"flux": Key("float", REQUIRED, "Heat flux into the body (negative: out of it).", "W/m²",
                                     scale=W_M2)},
                        flux_terms=_heat_flux),
    ThermalBoundaryType("convection", "convection: q = film_coefficient (ambient_temperature - T) into the body",
                        {"film_coefficient": Key("float", REQUIRED, "Heat transfer (film) coefficient h.",
                                                 "W/(m² K)", scale=W_M2, lo=0.0),
                         "ambient_temperature": _AMBIENT},
                        flux_terms=_convection),
    ThermalBoundaryType("radiation", "radiation: q = emissivity sigma (ambient_temperature^4 - T^4) into the body "
                        "(sigma the Stefan-Boltzmann constant)",
                        {"emissivity": Key("float", REQUIRED, "Emissivity of the surface.", "", lo=0.0,
                                           hi=1.0, hi_open=False),
                         "ambient_temperature": _AMBIENT},
                        flux_terms=_radiation),
)}
