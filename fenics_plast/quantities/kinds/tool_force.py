"""tool_force: the force of a rigid tool on the body, one component [N or kN]."""
from __future__ import annotations

NAME, ORDER = "tool_force", 20
DOC = "tool_force: force of a tool on the body"
TAKES = ("tool", "component", "unit", "scale")


def columns(name, o):
    return [f"{name}_{o.unit}"]


def check(d, o, ctx, fail):
    if o.tool not in ctx["tools"]:
        fail(f"{d}.tool = {o.tool!r} is not a tool: tools are {', '.join(ctx['tools']) or 'none'}")


def value(name, o, q, time, row):
    b = q.body
    f = b.tool_force(o.tool)[b.component(o.component)]
    return [o.scale * f / (1e3 if o.unit == "kN" else 1.0)]
