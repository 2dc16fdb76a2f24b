"""Circle (2-D): the body outside a disc (in axisymmetry a sphere on the axis or a torus);
g = |x - c| - R, N = (x - c) / |x - c|.

prm = [c_0, c_1, R]: the centre at t = 0 [mm] and the radius [mm].
"""
from fenics_plast.scene_key import OPTIONAL, REQUIRED, Key
from fenics_plast.tool_shapes import ToolShape, vector
from fenics_plast.tool_shapes.ops import sqrt


def gap(prm, x, d):
    """(g [mm], N) of the positions x translated by d (see the package docstring)."""
    r0 = x[0] - (prm[0] + d[0])
    r1 = x[1] - (prm[1] + d[1])
    dist = sqrt(r0 * r0 + r1 * r1)
    return dist - prm[2], (r0 / dist, r1 / dist)


def pack(v, dim):
    if not v["radius"] > 0:
        raise ValueError(f"circle radius must be > 0, got {v['radius']}")
    return vector(v, "center", dim, "circle") + [float(v["radius"])]


SHAPE = ToolShape(
    "circle", 1, (2,), "circle (2-D): the body outside a disc (a sphere or torus in axisymmetry)",
    {"center": Key("vector", OPTIONAL, "Centre at t = 0.", "mm"),
     "radius": Key("float", REQUIRED, "Radius.", "mm", lo=0.0)},
    gap, pack, required={2: ("center",)})
