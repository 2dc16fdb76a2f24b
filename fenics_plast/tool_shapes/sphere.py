"""Sphere (3-D): the body outside a ball; g = |x - c| - R, N = (x - c) / |x - c| (guarded at the centre).

prm = [c_0, c_1, c_2, R]: the centre at t = 0 [mm] and the radius [mm].
"""
from fenics_plast.scene_key import OPTIONAL, REQUIRED, Key
from fenics_plast.tool_shapes import ToolShape, vector
from fenics_plast.tool_shapes.ops import TINY, sqrt


def gap(prm, x, d):
    """(g [mm], N) of the positions x translated by d (see the package docstring)."""
    y0 = x[0] - (prm[0] + d[0])
    y1 = x[1] - (prm[1] + d[1])
    y2 = x[2] - (prm[2] + d[2])
    dist = sqrt(y0 * y0 + y1 * y1 + y2 * y2 + TINY)
    return dist - prm[3], (y0 / dist, y1 / dist, y2 / dist)


def pack(v, dim):
    if not v["radius"] > 0:
        raise ValueError(f"sphere radius must be > 0, got {v['radius']}")
    return vector(v, "center", dim, "sphere") + [float(v["radius"])]


SHAPE = ToolShape(
    "sphere", 2, (3,), "sphere (3-D): the body outside a ball",
    {"center": Key("vector", OPTIONAL, "Centre at t = 0.", "mm"),
     "radius": Key("float", REQUIRED, "Radius.", "mm", lo=0.0)},
    gap, pack, required={3: ("center",)})
