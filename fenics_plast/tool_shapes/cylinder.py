"""Cylinder (3-D, infinite): the body outside a circular cylinder about an axis; g = rho - R, N = e_rho
(:mod:`~fenics_plast.tool_shapes.axis`).

prm = [c_0, c_1, c_2, e_0, e_1, e_2, R]: a point of the axis at t = 0 [mm], the unit axis, the radius [mm].
"""
from fenics_plast.scene_key import OPTIONAL, REQUIRED, Key
from fenics_plast.tool_shapes import ToolShape
from fenics_plast.tool_shapes.axis import axial, frame


def gap(prm, x, d):
    """(g [mm], N) of the positions x translated by d (see the package docstring)."""
    _, r, rho = axial(prm, x, d)
    return rho - prm[6], (r[0] / rho, r[1] / rho, r[2] / rho)


def pack(v, dim):
    if not v["radius"] > 0:
        raise ValueError(f"cylinder radius must be > 0, got {v['radius']}")
    return frame(v, "cylinder") + [float(v["radius"])]


SHAPE = ToolShape(
    "cylinder", 3, (3,), "cylinder (3-D): the body outside an infinite cylinder about `axis` through `center`",
    {"center": Key("vector", OPTIONAL, "A point of the axis.", "mm"),
     "axis": Key("vector", OPTIONAL, "Direction of the axis.", ""),
     "radius": Key("float", REQUIRED, "Radius.", "mm", lo=0.0)},
    gap, pack, required={3: ("center", "axis")})
