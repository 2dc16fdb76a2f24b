"""energy: one of the energies [J] (or all five), or the relative balance error: the explicit solver's, or in
static runs :class:`fenics_plast.static_energy.StaticEnergy`'s (kinetic 0; tool and boundary work, contact
work, internal work, elastic energy, plastic dissipation; not with tractions, pressure or contact between two
groups of the body, whose work it does not count)."""
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
    if ctx["explicit"]:
        return
    if ctx["loads"]:
        fail(f"{d}: static energies do not count the work of tractions and pressure (boundary.{ctx['loads'][0]})")
    body_pairs = [n for n, c in ctx["contacts"].items() if c.get("master") is not None]
    if body_pairs:
        fail(f"{d}: static energies do not count contact between two groups of the body (contact.{body_pairs[0]})")


def value(name, o, q, time, row):
    e = q.body.energies()
    keys = ENERGIES if o.energy == "all" else (o.energy,)
    return [e[k] if k == "balance_error" else o.scale * e[k] * N_MM_TO_J for k in keys]
