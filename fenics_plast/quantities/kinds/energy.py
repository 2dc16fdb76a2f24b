"""energy: one of the explicit solver's energies [J] (or all five), or the relative balance error."""
from __future__ import annotations

from fenics_plast.scene_key import REQUIRED, Key

NAME, ORDER = "energy", 80
DOC = "energy: one of the energies"
TAKES = ("scale",)
KEYS = {
    "energy": Key("str", REQUIRED, "kinetic, elastic, plastic (dissipation), external_work, "
                  "balance_error (relative) or all (the five).",
                  choices=("kinetic", "elastic", "plastic", "external_work", "balance_error", "all")),
}
N_MM_TO_J = 1e-3
ENERGIES = ("kinetic", "elastic", "plastic", "external_work", "balance_error")
ENERGY_COLUMNS = {"kinetic": "kinetic_energy_J", "elastic": "elastic_energy_J",
                  "plastic": "plastic_dissipation_J", "external_work": "external_work_J",
                  "balance_error": "energy_balance_error"}


def columns(name, o):
    if o.energy == "all":
        return [ENERGY_COLUMNS[e] for e in ENERGIES]
    return [ENERGY_COLUMNS[o.energy]]


def check(d, o, ctx, fail):
    if not ctx["explicit"]:
        fail(f"{d}: energies are recorded in explicit analyses only")


def value(name, o, q, time, row):
    e = q.body.energies()
    keys = ENERGIES if o.energy == "all" else (o.energy,)
    return [e[k] if k == "balance_error" else o.scale * e[k] * N_MM_TO_J for k in keys]
