"""boundary_heat: the heat that leaves the body through one thermal boundary (a run with [thermal];
``[thermal_boundary.<name>]``): since t = 0 [J] and its rate over the last heat step [W]; positive: the body
loses heat there (convection and radiation to cooler surroundings, a colder prescribed temperature, a flux
out). :mod:`contact_heat` is the same for a tool contact's conductance."""
from __future__ import annotations

from fenics_plast.scene_key import REQUIRED, Key

NAME, ORDER = "boundary_heat", 84
DOC = "boundary_heat: heat lost through a thermal boundary ([thermal])"
TAKES = ()
KEYS = {
    "boundary": Key("str", REQUIRED, "Name of a [thermal_boundary.<name>] table."),
}
MJ_TO_J = 1e-3


def columns(name, o):
    return [f"{name}_J", f"{name}_W"]


def check(d, o, ctx, fail):
    if not ctx["thermal"]:
        fail(f"{d}.quantity = 'boundary_heat' needs a [thermal] table (heat conduction)")
    elif o.boundary not in ctx["thermal_boundaries"]:
        fail(f"{d}.boundary = {o.boundary!r} is not a thermal boundary: they are "
             f"{', '.join(ctx['thermal_boundaries']) or 'none'}")


def value(name, o, q, time, row):
    heat = q.body.heat
    return [-heat.heat[o.boundary] * MJ_TO_J, -heat.last_rate[o.boundary] * MJ_TO_J]
