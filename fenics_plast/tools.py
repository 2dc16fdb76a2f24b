"""Rigid analytic tools that translate along a prescribed path (2-D: x = r, y = z in axisymmetry,
where every tool is implicitly revolved about the axis).  Lengths in mm.

A tool has a ``name``, a translation ``path(t, use_ufl) -> (dx, dy)`` [mm] (UFL expressions of the
UFL scalar t when ``use_ufl``, floats otherwise; None = fixed) and

* ``gap(x, t) -> (g, N)`` in UFL: x a UFL 2-vector of current positions, t a UFL scalar (e.g. the
  solver's load ``fem.Constant``); g the signed gap [mm] (> 0 separated, < 0 penetrating) and N the
  unit normal pointing from the tool into the body;
* ``gap_np(x, t) -> (g (n,), N (n, 2))``: the same values in numpy (x (n, 2) or (n, 3), t a float);
* ``translation(t, use_ufl)``: (dx, dy), a tuple of UFL scalars or a numpy (2,) array.

Shapes: :class:`Plane` (half-space), :class:`Circle` (the body outside a disc: a sphere on the
axis or a torus in axisymmetry) and :class:`Profile` (a chain of line segments and circular arcs,
the body on one side), which covers flat dies, punches, die shoulders and rings.

Penalty helpers: :func:`default_penalty` (eps = factor E / h) and :func:`contact_length_scale`
(h: the mean depth of the cells along a facet group).
"""
from __future__ import annotations

import math

import numpy as np
import ufl

#: default normal penalty = PENALTY_FACTOR * E / h (chosen by measurement, see tests/test_contact.py:
#: penetration < 1 % of the thickness, force change < 1 % for x10)
PENALTY_FACTOR = 0.3
_TINY = 1e-300          # sqrt(d.d + _TINY): a point exactly on a corner gives N = 0, not 0/0


def default_penalty(E, h, factor=PENALTY_FACTOR):
    """Normal penalty eps = factor * E / h [N/mm^3] (E [MPa], h [mm])."""
    return factor * E / h


def contact_length_scale(mesh, facet_tags, tag):
    """Mean depth [mm] (cell area / facet length) of the cells next to the facets tagged ``tag``
    (2-D affine cells; owned facets of all ranks; collective).  ValueError if no facet has the tag."""
    import basix
    from mpi4py import MPI
    tdim, fdim = mesh.topology.dim, mesh.topology.dim - 1
    for a, b in ((fdim, tdim), (tdim, fdim)):
        mesh.topology.create_connectivity(a, b)
    f2c, c2f = mesh.topology.connectivity(fdim, tdim), mesh.topology.connectivity(tdim, fdim)
    ref_facets = basix.topology(getattr(basix.CellType, mesh.topology.cell_type.name))[fdim]
    order = [0, 1, 3, 2] if mesh.topology.cell_type.name == "quadrilateral" else [0, 1, 2]
    facets = facet_tags.find(tag)
    total, count = 0.0, 0
    for f in facets[facets < mesh.topology.index_map(fdim).size_local]:
        for c in f2c.links(f):
            xy = mesh.geometry.x[mesh.geometry.dofmap.links(c), :2]
            v = ref_facets[int(np.flatnonzero(c2f.links(c) == f)[0])]
            p, q = xy[order], np.roll(xy[order], -1, axis=0)
            area = 0.5 * abs(float(np.sum(p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1])))
            total += area / float(np.linalg.norm(xy[v[1]] - xy[v[0]]))
            count += 1
    total, count = mesh.comm.allreduce(total, op=MPI.SUM), mesh.comm.allreduce(count, op=MPI.SUM)
    if count == 0:
        raise ValueError(f"no facet is tagged {tag}")
    return total / count


def piecewise_path(knots, dx=None, dy=None):
    """A piecewise-linear ``path(t, use_ufl)`` through (knots [t], dx [mm], dy [mm]) (None = 0),
    constant outside the knots."""
    from fenics_plast.expressions import piecewise_linear
    comps = [[0.0] * len(knots) if v is None else list(v) for v in (dx, dy)]
    if any(len(v) != len(knots) for v in comps):
        raise ValueError("a path needs as many values as knots")

    def path(t, use_ufl=True):
        return tuple(piecewise_linear(t, knots, v, use_ufl) for v in comps)
    return path


class Tool:
    """A rigid tool translating along ``path`` (see the module docstring)."""

    name = "tool"

    def __init__(self, name=None, path=None):
        if name:
            self.name = name
        self.path = path

    def translation(self, t, use_ufl=True):
        """(dx, dy) [mm] at t: a tuple of UFL scalars, or a numpy (2,) array."""
        if self.path is None:
            z = ufl.as_ufl(0.0) if use_ufl else 0.0
            return (z, z) if use_ufl else np.zeros(2)
        d = self.path(t, use_ufl)
        return (ufl.as_ufl(d[0]), ufl.as_ufl(d[1])) if use_ufl else np.array([float(d[0]), float(d[1])])

    def gap(self, x, t):
        raise NotImplementedError

    def gap_np(self, x, t):
        raise NotImplementedError


class Plane(Tool):
    """Half-space: the plane through ``point`` [mm] (+ translation) with ``normal`` (any length,
    normalised) pointing into the body; g = (x - p) . N."""

    name = "plane"

    def __init__(self, point=(0.0, 0.0), normal=(0.0, 1.0), path=None, name=None):
        super().__init__(name, path)
        self.point = np.asarray(point, dtype=float)
        n = np.asarray(normal, dtype=float)
        if n.shape != (2,) or not np.linalg.norm(n) > 0:
            raise ValueError(f"plane normal must be a non-zero 2-vector, got {normal}")
        self.normal = n / np.linalg.norm(n)

    def gap(self, x, t):
        d = self.translation(t)
        p = ufl.as_vector([self.point[0] + d[0], self.point[1] + d[1]])
        N = ufl.as_vector([float(self.normal[0]), float(self.normal[1])])
        return ufl.dot(x - p, N), N

    def gap_np(self, x, t):
        p = self.point + self.translation(t, use_ufl=False)
        g = (np.asarray(x)[:, :2] - p) @ self.normal
        return g, np.tile(self.normal, (len(g), 1))


class Circle(Tool):
    """Disc of ``radius`` [mm] centred at ``center`` [mm] (+ translation); the body lies outside:
    g = |x - c| - R, N = (x - c) / |x - c|."""

    name = "circle"

    def __init__(self, center, radius, path=None, name=None):
        super().__init__(name, path)
        self.radius = float(radius)
        if not self.radius > 0:
            raise ValueError(f"circle radius must be > 0, got {radius}")
        self.center0 = np.asarray(center, dtype=float)

    def center(self, t, use_ufl=True):
        d = self.translation(t, use_ufl)
        if use_ufl:
            return ufl.as_vector([self.center0[0] + d[0], self.center0[1] + d[1]])
        return self.center0 + d

    def gap(self, x, t):
        dx = x - self.center(t)
        dist = ufl.sqrt(ufl.dot(dx, dx))
        return dist - self.radius, dx / dist

    def gap_np(self, x, t):
        dx = np.asarray(x)[:, :2] - self.center(t, use_ufl=False)
        dist = np.linalg.norm(dx, axis=1)
        return dist - self.radius, dx / dist[:, None]


# ----------------------------------------------------------------------------------------------
# profiles: per piece, the branch "interior" (the projection falls inside the piece) or "end point"


class _Ops:
    """The few operations the profile formulas need, in numpy (vectorised) or UFL."""

    def __init__(self, use_ufl):
        self.u = use_ufl

    def dot(self, a, b):
        return a[0] * b[0] + a[1] * b[1]

    def sqrt(self, a):
        return ufl.sqrt(a) if self.u else np.sqrt(a)

    def where(self, c, a, b):       # c a UFL condition / numpy bool array; a, b (g, N0, N1)
        if self.u:
            return ufl.conditional(c, ufl.as_vector(a), ufl.as_vector(b))
        return np.where(c, np.asarray(a), np.asarray(b))

    def lt(self, a, b):
        return ufl.lt(a, b) if self.u else a < b

    def ge(self, a, b):
        return ufl.ge(a, b) if self.u else a >= b

    def sign(self, a):              # +1 for a >= 0, -1 otherwise
        return ufl.conditional(ufl.ge(a, 0.0), 1.0, -1.0) if self.u else np.where(a >= 0, 1.0, -1.0)


class Profile(Tool):
    """Chain of pieces, traversed in order, the body on ``body_side`` ("left"/"right") of the
    direction of travel (coordinates [mm], angles [degrees]):

    * ``("line", (x0, y0), (x1, y1))``;
    * ``("arc", (cx, cy), radius, start_deg, end_deg)``: counter-clockwise if end > start,
      clockwise otherwise (|end - start| <= 360).

    Consecutive pieces must join (to 1e-9 of the profile's size); the chain is closed when the
    last piece ends where the first starts.  g is the signed distance to the nearest point q of
    the profile: negative when x is on the tool side of the nearest piece, N = sign (x - q)/|x - q|
    (the piece's normal when q is inside the piece), continuous across a smooth joint.  When q is
    a corner, the sign is the corner's (+ where the tool is convex, - where it is concave); beyond
    an open end the sign is the side of the end's tangent line and g the distance to the end.

    In UFL each piece gives (g, N) from its projection parameter clamped to the piece (inside the
    piece, or at its start or end point), and nested ``ufl.conditional`` pick the nearest piece;
    ``ufl.derivative`` goes through it (Newton Jacobian of the penalty residual).

    Example, an axisymmetric die (opening radius 20, shoulder radius 5, top z = 0 out to r = 60)::

        die = Profile([("line", (20, -30), (20, -5)),           # vertical wall, going up
                       ("arc", (25, -5), 5, 180, 90),           # quarter-circle shoulder, clockwise
                       ("line", (25, 0), (60, 0))])             # flat top; the blank lies above
    """

    name = "profile"

    def __init__(self, segments, body_side="left", path=None, name=None):
        super().__init__(name, path)
        if body_side not in ("left", "right"):
            raise ValueError(f"body_side must be 'left' or 'right', got {body_side!r}")
        self.side = 1.0 if body_side == "left" else -1.0
        self.pieces = [self._piece(k, s) for k, s in enumerate(segments)]
        if not self.pieces:
            raise ValueError("a profile needs at least one piece")
        ends = np.array([[p["P"][0], p["P"][1]] for p in self.pieces]).reshape(-1, 2)
        size = max(np.ptp(ends, axis=0).max(), max(p.get("R", 0.0) for p in self.pieces))
        tol = 1e-9 * size
        for k in range(len(self.pieces) - 1):
            a, b = self.pieces[k]["P"][1], self.pieces[k + 1]["P"][0]
            if np.linalg.norm(a - b) > tol:
                raise ValueError(f"profile pieces {k} and {k + 1} do not join: {a.tolist()} != {b.tolist()}")
        self.closed = len(self.pieces) > 1 and np.linalg.norm(self.pieces[-1]["P"][1]
                                                              - self.pieces[0]["P"][0]) <= tol
        for p in self.pieces:
            p["sigma"] = [None, None]
        joints = [(k, k + 1) for k in range(len(self.pieces) - 1)]
        joints += [(len(self.pieces) - 1, 0)] if self.closed else []
        for a, b in joints:
            t1, t2 = self.pieces[a]["T"][1], self.pieces[b]["T"][0]
            cross, dot = t1[0] * t2[1] - t1[1] * t2[0], float(t1 @ t2)
            if abs(cross) <= 1e-9:
                if dot < 0:
                    raise ValueError(f"profile pieces {a} and {b} turn back on themselves (a cusp)")
                continue                                            # smooth joint: own side
            s = -self.side * math.copysign(1.0, cross)               # + at a convex tool corner
            self.pieces[a]["sigma"][1] = self.pieces[b]["sigma"][0] = s

    def _piece(self, k, s):
        kind = s[0] if isinstance(s, (tuple, list)) and s else None
        if kind == "line" and len(s) == 3:
            a, b = np.asarray(s[1], dtype=float), np.asarray(s[2], dtype=float)
            L = float(np.linalg.norm(b - a))
            if a.shape != (2,) or b.shape != (2,) or not L > 0:
                raise ValueError(f"profile piece {k}: a line needs two distinct 2-D points, got {s}")
            e = (b - a) / L
            return dict(kind="line", P=[a, b], T=[e, e], e=e, L=L,
                        n=self.side * np.array([-e[1], e[0]]))
        if kind == "arc" and len(s) == 5:
            c, R, a0, a1 = np.asarray(s[1], dtype=float), float(s[2]), float(s[3]), float(s[4])
            if c.shape != (2,) or not R > 0:
                raise ValueError(f"profile piece {k}: an arc needs a 2-D centre and a radius > 0, got {s}")
            if not 0 < abs(a1 - a0) <= 360:
                raise ValueError(f"profile piece {k}: an arc must sweep 0 < |end - start| <= 360 degrees")
            ccw = 1.0 if a1 > a0 else -1.0
            rad = [math.radians(a) for a in (a0, a1, 0.5 * (a0 + a1))]
            u = [np.array([math.cos(a), math.sin(a)]) for a in rad]
            return dict(kind="arc", c=c, R=R, P=[c + R * u[0], c + R * u[1]], m=u[2],
                        T=[ccw * np.array([-v[1], v[0]]) for v in u[:2]],
                        cosb=math.cos(math.radians(0.5 * abs(a1 - a0))), kappa=-self.side * ccw)
        raise ValueError(f"profile piece {k}: expected ('line', p0, p1) or "
                         f"('arc', center, radius, start_deg, end_deg), got {s!r}")

    def _end(self, op, p, e, y):
        """(g, N0, N1) with the nearest point at the piece's end e (0 start, 1 end)."""
        P, T = p["P"][e], p["T"][e]
        d = [y[0] - P[0], y[1] - P[1]]
        dist = op.sqrt(op.dot(d, d) + _TINY)
        n = self.side * np.array([-T[1], T[0]])
        s = p["sigma"][e] if p["sigma"][e] is not None else op.sign(op.dot(d, n))
        return (s * dist, s * d[0] / dist, s * d[1] / dist)

    def _piece_gap(self, op, p, y):
        """(g, N0, N1) of one piece at the (untranslated) positions y."""
        start, end = self._end(op, p, 0, y), self._end(op, p, 1, y)
        if p["kind"] == "line":
            a, n = p["P"][0], p["n"]
            s = op.dot([y[0] - a[0], y[1] - a[1]], p["e"])
            inner = (op.dot([y[0] - a[0], y[1] - a[1]], n), 0.0 * s + n[0], 0.0 * s + n[1])
            return op.where(op.lt(s, 0.0), start, op.where(op.lt(p["L"], s), end, inner))
        c = p["c"]
        d = [y[0] - c[0], y[1] - c[1]]
        rho = op.sqrt(op.dot(d, d) + _TINY)
        k = p["kappa"]
        inner = (k * (rho - p["R"]), k * d[0] / rho, k * d[1] / rho)
        return op.where(op.ge(op.dot(d, p["m"]), p["cosb"] * rho), inner,
                        op.where(op.lt(abs(end[0]), abs(start[0])), end, start))

    def _gap(self, op, y):
        best = self._piece_gap(op, self.pieces[0], y)
        for p in self.pieces[1:]:
            v = self._piece_gap(op, p, y)
            best = op.where(op.lt(abs(v[0]), abs(best[0])), v, best)
        return best

    def gap(self, x, t):
        d = self.translation(t)
        v = self._gap(_Ops(True), x - ufl.as_vector([d[0], d[1]]))
        return v[0], ufl.as_vector([v[1], v[2]])

    def gap_np(self, x, t):
        y = np.asarray(x, dtype=float)[:, :2] - self.translation(t, use_ufl=False)
        v = self._gap(_Ops(False), y.T)
        return v[0], np.stack([v[1], v[2]], axis=1)


__all__ = ["Tool", "Plane", "Circle", "Profile", "PENALTY_FACTOR", "default_penalty",
           "contact_length_scale", "piecewise_path"]
