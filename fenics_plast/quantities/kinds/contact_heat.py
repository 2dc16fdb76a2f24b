"""contact_heat: the heat that crosses a contact pair's conductance from the group's side into the master's (a
run with [thermal]; contact.<name>.conductance): since t = 0 [J] and its rate over the last heat step [W].
With a tool: the heat the tool takes from the body (the friction heat's share into the tool, 1 -
friction_heat_fraction, is not in it: the tool is rigid and isothermal); between two facet groups of the
body: the heat the master group's body takes from the group's."""
from __future__ import annotations

from .contact_force import check as check_pair

NAME, ORDER = "contact_heat", 83
DOC = "contact_heat: heat through a contact pair's conductance into its master side ([thermal])"
TAKES = ("contact",)
MJ_TO_J = 1e-3


def columns(name, o):
    return [f"{name}_J", f"{name}_W"]


def check(d, o, ctx, fail):
    if not ctx["thermal"]:
        fail(f"{d}.quantity = 'contact_heat' needs a [thermal] table (heat conduction)")
        return
    check_pair(d, o, ctx, fail)
    if ctx["contacts"][o.contact].get("conductance") is None:
        fail(f"{d}.contact = {o.contact!r}: the pair has no conductance (contact.{o.contact}.conductance): no heat "
             f"crosses it")


def value(name, o, q, time, row):
    heat = q.body.heat
    if o.contact in heat.exchanged:             # two facet groups of the body
        return [heat.exchanged[o.contact] * MJ_TO_J, heat.exchange_rate[o.contact] * MJ_TO_J]
    return [-heat.heat[o.contact] * MJ_TO_J, -heat.last_rate[o.contact] * MJ_TO_J]
