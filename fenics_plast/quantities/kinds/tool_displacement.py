"""tool_displacement: a rigid tool's translation, one component [mm]."""
from __future__ import annotations

from .tool_force import check  # noqa: F401  (the same rule: the tool must exist)

NAME, ORDER = "tool_displacement", 30
DOC = "tool_displacement: the tool's translation"
TAKES = ("tool", "component", "scale")


def columns(name, o):
    return [f"{name}_mm"]


def value(name, o, q, time, row):
    b = q.body
    return [o.scale * float(b.tool_translation(o.tool, time)[b.component(o.component)])]
