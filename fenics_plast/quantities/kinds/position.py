"""position: the current coordinate of the node nearest a reference point, one component [mm]."""
from __future__ import annotations

from .displacement import check_mesh, node_value, setup  # noqa: F401  (the same node, rule and set-up)

NAME, ORDER = "position", 50
DOC = "position: the current coordinate of the node nearest `point` (of `group` or `regions` if given)"
TAKES = ("component", "point", "group", "regions")


def columns(name, o):
    return [f"{name}_mm"]


def value(name, o, q, time, row):
    return node_value(name, o, q, displacement=False)
