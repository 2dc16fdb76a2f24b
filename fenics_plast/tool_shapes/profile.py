"""Profile: a chain of line segments and circular arcs, the body on ``body_side`` (walking along it); in
2-D drawn in (x, y) (in axisymmetry (r, z), implicitly revolved about the axis), in 3-D drawn in the
(rho, a) half-plane of ``axis`` through ``center`` and revolved about it
(:mod:`~fenics_plast.tool_shapes.axis`).

Pieces (coordinates [mm], angles [degrees]): ``("line", (x0, y0), (x1, y1))`` and
``("arc", (cx, cy), radius, start_deg, end_deg)``, counter-clockwise if end > start, clockwise otherwise
(|end - start| <= 360). Consecutive pieces must join (to 1e-9 of the profile's size); the chain is closed
when the last piece ends where the first starts.

g is the signed distance to the nearest point q of the profile: negative when x is on the tool side of
the nearest piece, N = sign (x - q) / |x - q| (the piece's normal when q is inside the piece), continuous
across a smooth joint. When q is a corner, the sign is the corner's (+ where the tool is convex, - where
it is concave); beyond an open end the sign is the side of the end's tangent line and g the distance to
the end. Each piece gives (g, N) from its projection clamped to the piece (inside it, or at its start or
end point) and nested :func:`~fenics_plast.tool_shapes.ops.where` pick the nearest piece
(``ufl.derivative`` goes through them: the Newton Jacobian of the penalty residual). In 3-D g of a point is
the profile's at its (rho, a) and N = N_rho e_rho + N_a e (on the axis, e_rho = 0: N = N_a e).

Example, an axisymmetric die (opening radius 20, shoulder radius 5, top z = 0 out to r = 60; the blank
lies above)::

    [("line", (20, -30), (20, -5)), ("arc", (25, -5), 5, 180, 90), ("line", (25, 0), (60, 0))]

prm = [c (3), e (3), side, n] + n pieces of :data:`WIDTH` values: the axis frame (zeros in 2-D), side
+1 (body on the left) or -1, the number of pieces; per piece the fields at the offsets below.
"""
import math

import numpy as np

from fenics_plast.scene_key import OPTIONAL, REQUIRED, Key
from fenics_plast.tool_shapes import ToolShape
from fenics_plast.tool_shapes.axis import axial, frame
from fenics_plast.tool_shapes.ops import TINY, dot, ge, lt, sign, sqrt, where

SIDE, COUNT, FIRST = 6, 7, 8         # offsets in prm: side, number of pieces, first piece
WIDTH = 18                           # values per piece
LINE, ARC = 0.0, 1.0                 # piece kinds
# offsets in a piece: kind, end points P0, P1, unit tangents T0, T1 at them, corner signs S0, S1 (0: none,
# the side of the end's tangent line); a line's unit direction E, length L, normal N; an arc's centre C,
# radius R, mid-direction M, cosine of its half-sweep COSB, curvature sign KAPPA
KIND, P0, P1, T0, T1, S0, S1 = 0, 1, 3, 5, 7, 9, 10
E, L, N = 11, 13, 14
C, R, M, COSB, KAPPA = 11, 13, 14, 16, 17


def _end(prm, side, i, end, y):
    """(g, N_0, N_1) of piece i (offset) with the nearest point at its end ``end`` (0 start, 1 end)."""
    P, T, S = (P0, T0, S0) if end == 0 else (P1, T1, S1)
    d = (y[0] - prm[i + P], y[1] - prm[i + P + 1])
    dist = sqrt(dot(d, d) + TINY)
    n = (side * -prm[i + T + 1], side * prm[i + T])
    s = prm[i + S] if prm[i + S] != 0.0 else sign(dot(d, n))
    return (s * dist, s * d[0] / dist, s * d[1] / dist)


def _piece_gap(prm, side, i, y):
    """(g, N_0, N_1) of piece i (offset) at the untranslated profile coordinates y."""
    start, end = _end(prm, side, i, 0, y), _end(prm, side, i, 1, y)
    if prm[i + KIND] == LINE:
        ya = (y[0] - prm[i + P0], y[1] - prm[i + P0 + 1])
        s = dot(ya, (prm[i + E], prm[i + E + 1]))
        inner = (dot(ya, (prm[i + N], prm[i + N + 1])), 0.0 * s + prm[i + N], 0.0 * s + prm[i + N + 1])
        return where(lt(s, 0.0), start, where(lt(prm[i + L], s), end, inner))
    d = (y[0] - prm[i + C], y[1] - prm[i + C + 1])
    rho = sqrt(dot(d, d) + TINY)
    k = prm[i + KAPPA]
    inner = (k * (rho - prm[i + R]), k * d[0] / rho, k * d[1] / rho)
    return where(ge(dot(d, (prm[i + M], prm[i + M + 1])), prm[i + COSB] * rho), inner,
                 where(lt(abs(end[0]), abs(start[0])), end, start))


def profile_gap(prm, y):
    """(g, N_0, N_1) of the profile at the (untranslated) profile coordinates y = (y_0, y_1) [mm]."""
    side = prm[SIDE]
    best = _piece_gap(prm, side, FIRST, y)
    for k in range(1, int(prm[COUNT])):
        v = _piece_gap(prm, side, FIRST + k * WIDTH, y)
        best = where(lt(abs(v[0]), abs(best[0])), v, best)
    return best


def gap(prm, x, d):
    """(g [mm], N) of the positions x translated by d (see the package docstring)."""
    if len(x) == 2:
        v = profile_gap(prm, (x[0] - d[0], x[1] - d[1]))
        return v[0], (v[1], v[2])
    a, r, rho = axial(prm, x, d)
    v = profile_gap(prm, (rho, a))
    return v[0], (v[1] * (r[0] / rho) + v[2] * prm[3], v[1] * (r[1] / rho) + v[2] * prm[4],
                  v[1] * (r[2] / rho) + v[2] * prm[5])


def _piece(k, s, side):
    """The fields (WIDTH,) of piece k, ``s`` as in the module docstring (corner signs still 0)."""
    f = np.zeros(WIDTH)
    kind = s[0] if isinstance(s, (tuple, list)) and s else None
    if kind == "line" and len(s) == 3:
        a, b = np.asarray(s[1], dtype=float), np.asarray(s[2], dtype=float)
        length = float(np.linalg.norm(b - a))
        if a.shape != (2,) or b.shape != (2,) or not length > 0:
            raise ValueError(f"profile piece {k}: a line needs two distinct 2-D points, got {s}")
        e = (b - a) / length
        f[[KIND, L]] = LINE, length
        f[P0:P0 + 2], f[P1:P1 + 2], f[T0:T0 + 2], f[T1:T1 + 2], f[E:E + 2] = a, b, e, e, e
        f[N:N + 2] = side * np.array([-e[1], e[0]])
        return f
    if kind == "arc" and len(s) == 5:
        c, radius, a0, a1 = np.asarray(s[1], dtype=float), float(s[2]), float(s[3]), float(s[4])
        if c.shape != (2,) or not radius > 0:
            raise ValueError(f"profile piece {k}: an arc needs a 2-D centre and a radius > 0, got {s}")
        if not 0 < abs(a1 - a0) <= 360:
            raise ValueError(f"profile piece {k}: an arc must sweep 0 < |end - start| <= 360 degrees")
        ccw = 1.0 if a1 > a0 else -1.0
        u = [np.array([math.cos(a), math.sin(a)]) for a in (math.radians(a) for a in (a0, a1, 0.5 * (a0 + a1)))]
        f[[KIND, R, COSB, KAPPA]] = ARC, radius, math.cos(math.radians(0.5 * abs(a1 - a0))), -side * ccw
        f[C:C + 2], f[P0:P0 + 2], f[P1:P1 + 2], f[M:M + 2] = c, c + radius * u[0], c + radius * u[1], u[2]
        f[T0:T0 + 2], f[T1:T1 + 2] = (ccw * np.array([-v[1], v[0]]) for v in u[:2])
        return f
    raise ValueError(f"profile piece {k}: expected ('line', p0, p1) or "
                     f"('arc', center, radius, start_deg, end_deg), got {s!r}")


def _lowest_rho(k, s, f):
    """The smallest first coordinate (rho) piece k reaches [mm] (an arc's: sampled over its sweep)."""
    if f[KIND] == LINE:
        return min(f[P0], f[P1])
    ang = np.radians(np.linspace(float(s[3]), float(s[4]), 361))
    return float((f[C] + f[R] * np.cos(ang)).min())


def pack(v, dim):
    segments = v["segments"]
    if v["body_side"] not in ("left", "right"):
        raise ValueError(f"body_side must be 'left' or 'right', got {v['body_side']!r}")
    side = 1.0 if v["body_side"] == "left" else -1.0
    pieces = [_piece(k, s, side) for k, s in enumerate(segments)]
    if not pieces:
        raise ValueError("a profile needs at least one piece")
    ends = np.array([[f[P0:P0 + 2], f[P1:P1 + 2]] for f in pieces]).reshape(-1, 2)
    tol = 1e-9 * max(np.ptp(ends, axis=0).max(), max(f[R] if f[KIND] == ARC else 0.0 for f in pieces))
    for k in range(len(pieces) - 1):
        a, b = pieces[k][P1:P1 + 2], pieces[k + 1][P0:P0 + 2]
        if np.linalg.norm(a - b) > tol:
            raise ValueError(f"profile pieces {k} and {k + 1} do not join: {a.tolist()} != {b.tolist()}")
    closed = len(pieces) > 1 and np.linalg.norm(pieces[-1][P1:P1 + 2] - pieces[0][P0:P0 + 2]) <= tol
    joints = [(k, k + 1) for k in range(len(pieces) - 1)] + ([(len(pieces) - 1, 0)] if closed else [])
    for a, b in joints:
        t1, t2 = pieces[a][T1:T1 + 2], pieces[b][T0:T0 + 2]
        cross, dot_ = t1[0] * t2[1] - t1[1] * t2[0], float(t1 @ t2)
        if abs(cross) <= 1e-9:
            if dot_ < 0:
                raise ValueError(f"profile pieces {a} and {b} turn back on themselves (a cusp)")
            continue                                            # smooth joint: own side
        pieces[a][S1] = pieces[b][S0] = -side * math.copysign(1.0, cross)   # + at a convex tool corner
    head = [0.0] * 6
    if dim == 3:
        head = frame(v, "profile")
        size = max(1.0, *(float(np.abs(f[q:q + 2]).max()) for f in pieces for q in (P0, P1)))
        for k, (s, f) in enumerate(zip(segments, pieces)):
            lowest = _lowest_rho(k, s, f)
            if lowest < -1e-9 * size:
                raise ValueError(f"revolved profile piece {k} reaches rho = {lowest:.6g} < 0: draw the "
                                 f"profile in the half-plane rho >= 0")
    return head + [side, float(len(pieces))] + np.concatenate(pieces).tolist()


def _check(dotted, values, dim, fail):
    if dim == 2:
        for k in ("center", "axis"):
            if values.get(k) is not None:
                fail(f"{dotted}.{k} is for 3-D profiles only: a 2-D profile is drawn in (x, y) or (r, z)")


SHAPE = ToolShape(
    "profile", 5, (2, 3), "profile: chain of line segments and circular arcs, the body on `body_side` (revolved "
    "about the axis in axisymmetry and about `axis` through `center` in 3-D)",
    {"segments": Key("segments", REQUIRED, "Profile pieces in order: { line = [[x0, y0], [x1, y1]] } or "
                     "{ arc = [cx, cy], radius = R, from = deg, to = deg } (counter-clockwise when to > from). "
                     "In 3-D the coordinates are (rho, a): distance from `axis` and coordinate along it from "
                     "`center`.", "mm"),
     "body_side": Key("str", "left", "Side of the profile (walking along it) where the body lies.",
                      choices=("left", "right")),
     "center": Key("vector", OPTIONAL, "3-D: the origin of the profile's axial coordinate.", "mm"),
     "axis": Key("vector", OPTIONAL, "3-D: direction of the axis.", "")},
    gap, pack, required={3: ("center", "axis")}, check=_check)
