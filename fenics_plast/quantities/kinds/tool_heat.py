"""tool_heat: the heat a contact pair's tool takes from the body through its conductance (a run with
[thermal]; contact.<name>.conductance): since t = 0 [J] and its rate over the last heat step [W]; positive:
the body heats the tool. The friction heat's share into the tool (1 - friction_heat_fraction) is not in it:
the tool is rigid and isothermal."""
from __future__ import annotations

from .contact_force import check as check_pair

NAME, ORDER = "tool_heat", 83
DOC = "tool_heat: heat into a contact pair's tool through its conductance ([thermal])"
TAKES = ("contact",)
MJ_TO_J = 1e-3


def columns(name, o):
    return [f"{name}_J", f"{name}_W"]


def check(d, o, ctx, fail):
    if not ctx["thermal"]:
        fail(f"{d}.quantity = 'tool_heat' needs a [thermal] table (heat conduction)")
        return
    check_pair(d, o, ctx, fail)
    if ctx["contacts"][o.contact].get("conductance") is None:
        fail(f"{d}.contact = {o.contact!r}: the pair has no conductance (contact.{o.contact}.conductance): no heat "
             f"crosses it")


def value(name, o, q, time, row):
    heat = q.body.heat
    return [-heat.heat[o.contact] * MJ_TO_J, -heat.last_rate[o.contact] * MJ_TO_J]
