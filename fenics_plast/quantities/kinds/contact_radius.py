"""contact_radius: how far the contact zone of a pair reaches from the axis now [mm]: the distance from the
axis (r in axisymmetry; sqrt(x^2 + y^2) in 3-D; |x| in plane strain, the half-width of a zone centred on
x = 0) of the zone's edge.

The edge lies between the outermost node pressed in (gap < 0, at r_1, pressure p_1) and the next node out;
a node's spacing there is the resolution of any nodal estimate (r_1 alone: -3.7 % on the Hertz sphere at
20 cells per mm, a ~ 10 cells). Near the edge of a smooth (non-conforming) contact the pressure falls as the
square root of the distance to the edge, so p^2 is linear there: the edge is where p^2, through the two
outermost pressed nodes (r_2 < r_1, p_2 > p_1), reaches zero, r_1 + p_1^2 (r_1 - r_2) / (p_2^2 - p_1^2),
kept short of the next node out. Where the pressure does not fall toward the edge (a flat punch's
singular edge) the edge is r_1. 0 when no node is pressed. Measured on demos/hertz_sphere.toml against
Hertz's a for the force transmitted: -0.08 % / -1.05 % / -0.61 % at 10 / 20 / 40 cells per mm
(tests/test_static_body_contact.py)."""
from __future__ import annotations

import numpy as np

from .contact_force import check  # noqa: F401  (the pair must exist)

NAME, ORDER = "contact_radius", 24
DOC = "contact_radius: distance from the axis of the edge of a pair's contact zone"
TAKES = ("contact",)


def columns(name, o):
    return [f"{name}_mm"]


def radius(x, g, p, three_d):
    """The edge of the contact zone (module docstring) of nodes at x (n, dim) [mm] with gaps g (n,) [mm] and
    pressures p (n,) [MPa]."""
    r = np.hypot(x[:, 0], x[:, 1]) if three_d else np.abs(x[:, 0])
    on = np.flatnonzero(g < 0.0)
    if not len(on):
        return 0.0
    on = on[np.argsort(r[on])]
    i = on[-1]
    beyond = r[np.isfinite(g) & (g >= 0.0) & (r > r[i])]
    if len(on) < 2 or not p[on[-2]] > p[i]:
        return float(r[i])
    j = on[-2]
    edge = r[i] + p[i] ** 2 * (r[i] - r[j]) / (p[j] ** 2 - p[i] ** 2)
    return float(min(edge, beyond.min()) if len(beyond) else edge)


def value(name, o, q, time, row):
    b = q.body
    c = b.contact_nodes(o.contact)
    gather = [np.concatenate(b.comm.allgather(np.asarray(v, dtype=float))) for v in (c.x, c.g, c.p)]
    return [radius(*gather, gather[0].shape[1] == 3)]
