"""contact_force: the force of a contact pair's master surface on the pair's group, one component [N or kN]:
a rigid tool's on the body, or (``master``) the master group's body's on the group's (the master body takes
the opposite force). Two passes: the group's own forces and the reactions of the other pass."""
from __future__ import annotations

NAME, ORDER = "contact_force", 21
DOC = "contact_force: force of a contact pair's master surface on its group"
TAKES = ("contact", "component", "unit", "scale")


def columns(name, o):
    return [f"{name}_{o.unit}"]


def check(d, o, ctx, fail):
    """The pair must exist (shared by every contact_* kind)."""
    if o.contact not in ctx["contacts"]:
        fail(f"{d}.contact = {o.contact!r} is not a contact pair: pairs are {', '.join(ctx['contacts']) or 'none'}")


def value(name, o, q, time, row):
    b = q.body
    f = b.contact_force(o.contact)[b.component(o.component)]
    return [o.scale * f / (1e3 if o.unit == "kN" else 1.0)]
