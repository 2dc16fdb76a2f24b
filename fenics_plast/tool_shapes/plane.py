"""Plane: the half-space on the side of ``normal``; g = (x - p) . N, N the unit normal (2-D or 3-D).

prm = [p_0, p_1, (p_2,) N_0, N_1, (N_2)]: the point p at t = 0 [mm] and the unit normal, ``dim`` each.
"""
import numpy as np

from fenics_plast.scene_key import REQUIRED, Key
from fenics_plast.tool_shapes import ToolShape, vector


def gap(prm, x, d):
    """(g [mm], N) of the positions x translated by d (see the package docstring)."""
    if len(x) == 2:
        n = (prm[2], prm[3])
        return (x[0] - (prm[0] + d[0])) * n[0] + (x[1] - (prm[1] + d[1])) * n[1], n
    n = (prm[3], prm[4], prm[5])
    return ((x[0] - (prm[0] + d[0])) * n[0] + (x[1] - (prm[1] + d[1])) * n[1]
            + (x[2] - (prm[2] + d[2])) * n[2]), n


def pack(v, dim):
    if len(v["point"]) != len(v["normal"]):
        raise ValueError(f"plane point {v['point']} and normal {v['normal']} must have the same dimension")
    point, n = vector(v, "point", dim, "plane"), np.asarray(vector(v, "normal", dim, "plane"))
    if not np.linalg.norm(n) > 0:
        raise ValueError(f"plane normal must be a non-zero {dim}-vector, got {v['normal']}")
    return point + (n / np.linalg.norm(n)).tolist()


SHAPE = ToolShape(
    "plane", 0, (2, 3), "plane: half-space, the body on the side `normal` points to",
    {"point": Key("vector", REQUIRED, "A point of the plane.", "mm"),
     "normal": Key("vector", REQUIRED, "Normal of the plane, pointing into the body.", "")},
    gap, pack)
