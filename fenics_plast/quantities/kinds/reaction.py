"""reaction: the sum of the reactions on a constrained facet group, one component [N or kN] (static)."""
from __future__ import annotations

NAME, ORDER = "reaction", 10
DOC = ("reaction: sum of the reactions on a constrained group (a node that another group also constrains in "
       "the same component is left out: its reaction belongs to both, e.g. a corner on a symmetry line)")
TAKES = ("group", "component", "unit", "scale")


def columns(name, o):
    return [f"{name}_{o.unit}"]


def check(d, o, ctx, fail):
    if o.group is None:
        fail(f"{d}.group is missing: required for a reaction")


def check_boundary(d, o, ctx, fail):
    if o.group is None:
        return
    if ctx["explicit"]:
        fail(f"{d}.quantity = 'reaction' is for static analyses (explicit: tool_force, energy)")
    c = ctx["components"].get(o.component)
    if c is not None and (o.group, c) not in ctx["holder"] and o.group not in ctx["symmetric"]:
        fail(f"{d}: group {o.group!r} has no boundary condition on component {o.component}: there "
             f"is no reaction to record")


def value(name, o, q, time, row):
    f = q.body.reaction(q.reactions[(o.group, o.component)])
    return [o.scale * f / (1e3 if o.unit == "kN" else 1.0)]
