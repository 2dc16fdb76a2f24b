"""The frame of the shapes symmetric about an axis (cylinder, torus, revolved profile): not a shape.

A point's axial coordinate a = y . e and radial vector r = y - a e, y = x - (c + d) its position from
the axis point c [mm] (translated by d), e the unit axis; rho = |r| guarded: sqrt(r . r + TINY), so
e_rho = r / rho is 0 on the axis.
"""
import numpy as np

from fenics_plast.tool_shapes import vector
from fenics_plast.tool_shapes.ops import TINY, sqrt


def axial(prm, x, d):
    """(a, (r_0, r_1, r_2), rho) [mm] of the positions x, prm starting [c_0, c_1, c_2, e_0, e_1, e_2]."""
    y0 = x[0] - (prm[0] + d[0])
    y1 = x[1] - (prm[1] + d[1])
    y2 = x[2] - (prm[2] + d[2])
    a = y0 * prm[3] + y1 * prm[4] + y2 * prm[5]
    r0 = y0 - a * prm[3]
    r1 = y1 - a * prm[4]
    r2 = y2 - a * prm[5]
    return a, (r0, r1, r2), sqrt(r0 * r0 + r1 * r1 + r2 * r2 + TINY)


def frame(v, what):
    """[c_0, c_1, c_2, e_0, e_1, e_2] of the values' ``center`` and ``axis`` (the axis normalised;
    ValueError for a zero axis)."""
    center, e = vector(v, "center", 3, what), np.asarray(vector(v, "axis", 3, what))
    if not np.linalg.norm(e) > 0:
        raise ValueError(f"{what} axis must be non-zero, got {v['axis']}")
    return center + (e / np.linalg.norm(e)).tolist()
