"""heat: the heat balance of a run with [thermal] [J], accumulated from t = 0
(:meth:`fenics_plast.thermal.heat.HeatConduction.heat_balance`): the heat stored in the body
(int rho c (T - T_0) dV), the plastic heat released (Taylor-Quinney), the friction heat released in the
body (its share of the dissipation), the heat in through the thermal boundaries and tool contacts (their
sum; into the body positive), or the balance's relative error |stored - plastic - friction - boundaries| /
the largest of them."""
from __future__ import annotations

from fenics_plast.scene_key import REQUIRED, Key

NAME, ORDER = "heat", 82
DOC = "heat: the heat balance ([thermal])"
TAKES = ("scale",)
KEYS = {
    "heat": Key("str", REQUIRED, "stored (in the body since t = 0), plastic (released by plastic work), friction "
                "(the friction's share released in the body), boundaries (in through the thermal boundaries and "
                "the tool contacts), balance_error (relative) or all (the five).",
                choices=("stored", "plastic", "friction", "boundaries", "balance_error", "all")),
}
MJ_TO_J = 1e-3
HEATS = ("stored", "plastic", "friction", "boundaries", "balance_error")
COLUMNS = {"stored": "stored_heat_J", "plastic": "plastic_heat_J", "friction": "friction_heat_J",
           "boundaries": "boundary_heat_J", "balance_error": "heat_balance_error"}


def columns(name, o):
    return [COLUMNS[h] for h in (HEATS if o.heat == "all" else (o.heat,))]


def check(d, o, ctx, fail):
    if not ctx["thermal"]:
        fail(f"{d}.quantity = 'heat' needs a [thermal] table (heat conduction)")


def value(name, o, q, time, row):
    h = q.body.heat.heat_balance()
    keys = HEATS if o.heat == "all" else (o.heat,)
    return [h[k] if k == "balance_error" else o.scale * h[k] * MJ_TO_J for k in keys]
