"""Torus (3-D): the body outside a tube of radius r about a ring of radius R centred on an axis, in the
plane a = 0 (:mod:`~fenics_plast.tool_shapes.axis`). The distance to the ring is
dist = sqrt((rho - R)^2 + a^2): g = dist - r, N = ((rho - R) e_rho + a e) / dist (the guarded e_rho is 0
on the axis, where g is still exact and N is a e / dist; on the ring N is guarded with TINY).

prm = [c_0, c_1, c_2, e_0, e_1, e_2, R, r]: the centre at t = 0 [mm], the unit axis, the ring and the
tube radius [mm].
"""
from fenics_plast.scene_key import OPTIONAL, REQUIRED, Key
from fenics_plast.tool_shapes import ToolShape
from fenics_plast.tool_shapes.axis import axial, frame
from fenics_plast.tool_shapes.ops import TINY, sqrt


def gap(prm, x, d):
    """(g [mm], N) of the positions x translated by d (see the package docstring)."""
    a, r, rho = axial(prm, x, d)
    dist = sqrt((rho - prm[6]) ** 2 + a * a + TINY)
    radial, axial_part = (rho - prm[6]) / dist, a / dist
    return dist - prm[7], (radial * (r[0] / rho) + axial_part * prm[3],
                           radial * (r[1] / rho) + axial_part * prm[4],
                           radial * (r[2] / rho) + axial_part * prm[5])


def pack(v, dim):
    if not (v["ring_radius"] > 0 and v["radius"] > 0):
        raise ValueError(f"torus ring_radius and radius must be > 0, got {v['ring_radius']}, {v['radius']}")
    return frame(v, "torus") + [float(v["ring_radius"]), float(v["radius"])]


SHAPE = ToolShape(
    "torus", 4, (3,), "torus (3-D): the body outside a tube of `radius` around a ring of `ring_radius` about `axis`",
    {"center": Key("vector", OPTIONAL, "Centre at t = 0.", "mm"),
     "axis": Key("vector", OPTIONAL, "Direction of the axis.", ""),
     "radius": Key("float", REQUIRED, "The tube radius.", "mm", lo=0.0),
     "ring_radius": Key("float", REQUIRED, "Distance from the axis to the centre of the tube.", "mm", lo=0.0)},
    gap, pack, required={3: ("center", "axis")})
