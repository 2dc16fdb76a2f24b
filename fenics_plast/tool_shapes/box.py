"""Box: the body outside a box with rounded edges and corners (a rounded rectangle in 2-D), its sides along
the axes: a rectangular or square punch or die with its edge radius (the square cup's punch).

With y = x - (c + d) the position from the centre c (translated by d), b the half sizes of the core (the
flat faces' extent) and r the edge radius (the box's outer half sizes are b + r), q_i = |y_i| - b_i:

* outside the core (some q_i > 0): g = |<q>| - r (<.> the positive part), N_i = sign(y_i) <q_i> / |<q>|:
  the distance to the rounded surface and its gradient, exact;
* inside the core (every q_i <= 0): g = max_i q_i - r, N = sign(y_k) e_k, k the nearest face: the depth
  below that face (exact on the faces' normals; in the rounded rim, where a pressed body hardly goes, a
  bound of the depth).

prm = [c (dim), b (dim), r]: the centre at t = 0 [mm], the half sizes of the core [mm], the edge radius [mm].
"""
from fenics_plast.scene_key import OPTIONAL, REQUIRED, Key
from fenics_plast.tool_shapes import ToolShape, vector
from fenics_plast.tool_shapes.ops import TINY, ge, lt, maximum, sqrt, where


def _sign(y):
    """y / |y| (guarded: 0 at y = 0), a smooth expression rather than a conditional (see :func:`gap`)."""
    return y / sqrt(y * y + TINY)


def _flag(c):
    """1.0 where the condition c holds, else 0.0."""
    return where(c, (1.0,), (0.0,))[0]


def gap(prm, x, d):
    """(g [mm], N) of the positions x translated by d (see the package docstring).

    Written for FFCx as much as for the reader: FFCx cannot factor the Jacobian of a conditional whose one
    branch is a constant and the other depends on the unknowns, so the face picked inside the core is
    weighted by 0/1 flags (they do not depend on the unknowns in the Jacobian) and the signs are smooth
    (``tests/test_tool_shapes.py`` compiles every shape's Jacobian)."""
    if len(x) == 2:
        y0, y1 = x[0] - (prm[0] + d[0]), x[1] - (prm[1] + d[1])
        q0, q1, r = abs(y0) - prm[2], abs(y1) - prm[3], prm[4]
        o0, o1 = maximum(q0, 0.0), maximum(q1, 0.0)
        out = sqrt(o0 * o0 + o1 * o1 + TINY)
        deepest = maximum(q0, q1)
        k0 = _flag(ge(q0, q1))                          # inside: the face of axis 0 is the nearest
        v = where(lt(0.0, deepest), (out - r, _sign(y0) * o0 / out, _sign(y1) * o1 / out),
                  (deepest - r, k0 * _sign(y0), (1.0 - k0) * _sign(y1)))
        return v[0], (v[1], v[2])
    y0, y1, y2 = x[0] - (prm[0] + d[0]), x[1] - (prm[1] + d[1]), x[2] - (prm[2] + d[2])
    q0, q1, q2, r = abs(y0) - prm[3], abs(y1) - prm[4], abs(y2) - prm[5], prm[6]
    o0, o1, o2 = maximum(q0, 0.0), maximum(q1, 0.0), maximum(q2, 0.0)
    out = sqrt(o0 * o0 + o1 * o1 + o2 * o2 + TINY)
    deepest = maximum(q0, maximum(q1, q2))
    k0 = _flag(ge(q0, maximum(q1, q2)))                 # inside: the nearest face's axis, 0, 1 or 2
    k1 = (1.0 - k0) * _flag(ge(q1, q2))
    k2 = 1.0 - k0 - k1
    v = where(lt(0.0, deepest), (out - r, _sign(y0) * o0 / out, _sign(y1) * o1 / out, _sign(y2) * o2 / out),
              (deepest - r, k0 * _sign(y0), k1 * _sign(y1), k2 * _sign(y2)))
    return v[0], (v[1], v[2], v[3])


def pack(v, dim):
    half = vector(v, "half_sizes", dim, "box")
    if not all(h >= 0 for h in half) or not v["edge_radius"] >= 0 or not max(half) + v["edge_radius"] > 0:
        raise ValueError(f"box half_sizes {v['half_sizes']} and edge_radius {v['edge_radius']} must be >= 0, "
                         f"and not all 0")
    return vector(v, "center", dim, "box") + half + [float(v["edge_radius"])]


SHAPE = ToolShape(
    "box", 6, (2, 3), "box: the body outside a box with rounded edges, its sides along the axes (a rounded "
    "rectangle in 2-D)",
    {"center": Key("vector", OPTIONAL, "Centre at t = 0.", "mm"),
     "half_sizes": Key("vector", REQUIRED, "Half sizes of the box's core along x, y (, z): the box's outer half "
                       "sizes are half_sizes + edge_radius.", "mm"),
     "edge_radius": Key("float", 0.0, "Radius of the rounded edges and corners.", "mm", lo=0.0, lo_open=False)},
    gap, pack, required={2: ("center",), 3: ("center",)})
