"""Rigid analytic tools that translate along a prescribed path.  Lengths in mm.

2-D tools (x = r, y = z in axisymmetry, where every tool is implicitly revolved about the axis) and
3-D tools (x, y, z).  A tool has a ``name``, a dimension ``dim`` (2 or 3), a translation
``path(t, use_ufl) -> (dx, dy)`` or ``(dx, dy, dz)`` [mm] (UFL expressions of the UFL scalar t when
``use_ufl``, floats otherwise; None = fixed; a 3-D tool reads a missing dz as 0) and

* ``gap(x, t) -> (g, N)`` in UFL: x a UFL ``dim``-vector of current positions, t a UFL scalar (e.g.
  the solver's load ``fem.Constant``); g the signed gap [mm] (> 0 separated, < 0 penetrating) and N
  the unit normal pointing from the tool into the body;
* ``gap_np(x, t) -> (g (n,), N (n, dim))``: the same values in numpy (x (n, dim), or (n, 3) for a
  2-D tool, whose third column is ignored; t a float);
* ``translation(t, use_ufl)``: (dx, dy[, dz]), a tuple of UFL scalars or a numpy (dim,) array.

2-D shapes: :class:`Plane` (half-space), :class:`Circle` (the body outside a disc: a sphere on the
axis or a torus in axisymmetry) and :class:`Profile` (a chain of line segments and circular arcs,
the body on one side), which covers flat dies, punches, die shoulders and rings.

3-D shapes: :class:`Plane` (given 3-vectors), :class:`Sphere`, :class:`Cylinder` (infinite),
:class:`Torus` (the body outside each) and :class:`RevolvedProfile` (a :class:`Profile` drawn in the
(rho, a) half-plane of an axis and revolved about it: g and the (rho, a) normal are the profile's,
the normal turned back to 3-D).  Where the normal is not defined (the centre of a sphere, the axis of
a cylinder, torus or revolved profile) it is guarded with TINY as in the 2-D profile: a finite
vector, not 0/0.

Penalty helpers: :func:`default_penalty` (eps = factor E / h) and :func:`contact_length_scale`
(h: the mean depth of the cells along a facet group).
"""
from __future__ import annotations

import math

import numpy as np
import ufl

from fenics_plast.schema import PENALTY_FACTOR, default  # default normal penalty = PENALTY_FACTOR * E / h

TINY = 1e-300          # sqrt(d.d + TINY): a point exactly on a corner gives N = 0, not 0/0


def default_penalty(E, h, factor=PENALTY_FACTOR):
    """Normal penalty eps = factor * E / h [N/mm^3] (E [MPa], h [mm])."""
    return factor * E / h


def contact_length_scale(mesh, facet_tags, tag):
    """Mean depth [mm] of the cells next to the facets tagged ``tag``: cell area / facet length in
    2-D (affine cells), cell volume / facet area in 3-D (hexahedra: 2x2x2 and 2x2 Gauss on the
    trilinear map; tetrahedra exact).  Owned facets of all ranks; collective.  ValueError if no
    facet has the tag."""
    import basix
    from mpi4py import MPI

    from fenics_plast import dolfinx_compat as dc
    tdim, fdim = mesh.topology.dim, mesh.topology.dim - 1
    for a, b in ((fdim, tdim), (tdim, fdim)):
        mesh.topology.create_connectivity(a, b)
    f2c, c2f = mesh.topology.connectivity(fdim, tdim), mesh.topology.connectivity(tdim, fdim)
    cell_name = mesh.topology.cell_type.name
    ref_facets = basix.topology(getattr(basix.CellType, cell_name))[fdim]
    order = [0, 1, 3, 2] if cell_name == "quadrilateral" else [0, 1, 2]
    facets = facet_tags.find(tag)
    total, count = 0.0, 0
    for f in facets[facets < mesh.topology.index_map(fdim).size_local]:
        for c in f2c.links(f):
            v = ref_facets[int(np.flatnonzero(c2f.links(c) == f)[0])]
            if tdim == 3:
                xyz = mesh.geometry.x[dc.geometry_dofs(mesh)[c], :3]
                total += _cell_volume(xyz) / _facet_area(xyz[v])
            else:
                xy = mesh.geometry.x[dc.geometry_dofs(mesh)[c], :2]
                p, q = xy[order], np.roll(xy[order], -1, axis=0)
                area = 0.5 * abs(float(np.sum(p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1])))
                total += area / float(np.linalg.norm(xy[v[1]] - xy[v[0]]))
            count += 1
    total, count = mesh.comm.allreduce(total, op=MPI.SUM), mesh.comm.allreduce(count, op=MPI.SUM)
    if count == 0:
        raise ValueError(f"no facet is tagged {tag}")
    return total / count


_GAUSS2 = (0.5 - 0.5 / math.sqrt(3.0), 0.5 + 0.5 / math.sqrt(3.0))   # 2-point Gauss on [0, 1]


def _cell_volume(xyz):
    """Volume [mm^3] of a first-order tetrahedron (4, 3) or hexahedron (8, 3; basix vertex order
    v = i + 2 j + 4 k at reference (i, j, k)): exact, 2x2x2 Gauss of det J."""
    if len(xyz) == 4:
        return abs(float(np.linalg.det(xyz[1:] - xyz[0]))) / 6.0
    c = xyz.reshape(2, 2, 2, 3)                  # [k, j, i, :]
    vol = 0.0
    for r in _GAUSS2:
        for s in _GAUSS2:
            for t in _GAUSS2:
                w = [(1 - r, r), (1 - s, s), (1 - t, t)]
                d_r = sum(w[1][j] * w[2][k] * (c[k, j, 1] - c[k, j, 0]) for j in (0, 1) for k in (0, 1))
                d_s = sum(w[0][i] * w[2][k] * (c[k, 1, i] - c[k, 0, i]) for i in (0, 1) for k in (0, 1))
                d_t = sum(w[0][i] * w[1][j] * (c[1, j, i] - c[0, j, i]) for i in (0, 1) for j in (0, 1))
                vol += 0.125 * abs(float(np.linalg.det(np.array([d_r, d_s, d_t]))))
    return vol


def _facet_area(xyz):
    """Area [mm^2] of a triangle (3, 3) or a bilinear quadrilateral (4, 3; basix order v = i + 2 j):
    exact, 2x2 Gauss of |dx/dr x dx/ds|."""
    if len(xyz) == 3:
        return 0.5 * float(np.linalg.norm(np.cross(xyz[1] - xyz[0], xyz[2] - xyz[0])))
    area = 0.0
    for r in _GAUSS2:
        for s in _GAUSS2:
            d_r = (1 - s) * (xyz[1] - xyz[0]) + s * (xyz[3] - xyz[2])
            d_s = (1 - r) * (xyz[2] - xyz[0]) + r * (xyz[3] - xyz[1])
            area += 0.25 * float(np.linalg.norm(np.cross(d_r, d_s)))
    return area


def piecewise_path(knots, dx=None, dy=None, dz=None):
    """A piecewise-linear ``path(t, use_ufl)`` through (knots [t], dx, dy[, dz] [mm]) (None = 0),
    constant outside the knots: (dx, dy) without ``dz`` (2-D tools), (dx, dy, dz) with it."""
    from fenics_plast.expressions import piecewise_linear
    given = (dx, dy) if dz is None else (dx, dy, dz)
    comps = [[0.0] * len(knots) if v is None else list(v) for v in given]
    if any(len(v) != len(knots) for v in comps):
        raise ValueError("a path needs as many values as knots")

    def path(t, use_ufl=True):
        return tuple(piecewise_linear(t, knots, v, use_ufl) for v in comps)
    return path


def _vector(value, what, dims=(2, 3)):
    """``value`` as a float array of one of the lengths ``dims`` (ValueError otherwise)."""
    a = np.asarray(value, dtype=float)
    if a.ndim != 1 or a.shape[0] not in dims or not np.all(np.isfinite(a)):
        raise ValueError(f"{what} must be a finite {' or '.join(map(str, dims))}-vector, got {value}")
    return a


def _unit(value, what, dims=(2, 3)):
    """``value`` normalised to unit length (ValueError for a zero vector)."""
    a = _vector(value, what, dims)
    n = float(np.linalg.norm(a))
    if not n > 0:
        raise ValueError(f"{what} must be non-zero, got {value}")
    return a / n


class Tool:
    """A rigid tool translating along ``path`` (see the module docstring); ``dim`` 2 or 3."""

    name = "tool"
    dim = 2

    def __init__(self, name=None, path=None):
        if name:
            self.name = name
        self.path = path

    def translation(self, t, use_ufl=True):
        """(dx, dy) [mm] at t (3-D tools: (dx, dy, dz)): a tuple of UFL scalars, or a numpy (dim,)
        array."""
        if self.dim == 3:
            return self._translation_3d(t, use_ufl)
        if self.path is None:
            z = ufl.as_ufl(0.0) if use_ufl else 0.0
            return (z, z) if use_ufl else np.zeros(2)
        d = self.path(t, use_ufl)
        return (ufl.as_ufl(d[0]), ufl.as_ufl(d[1])) if use_ufl else np.array([float(d[0]), float(d[1])])

    def _translation_3d(self, t, use_ufl):
        d = (0.0, 0.0, 0.0) if self.path is None else tuple(self.path(t, use_ufl))
        d = d + (0.0,) * (3 - len(d))
        if use_ufl:
            return tuple(ufl.as_ufl(c) for c in d[:3])
        return np.array([float(c) for c in d[:3]])

    def _moved(self, point, t):
        """UFL vector: the reference ``point`` (dim,) [mm] translated to time t."""
        d = self.translation(t)
        return ufl.as_vector([float(point[i]) + d[i] for i in range(len(point))])

    def gap(self, x, t):
        raise NotImplementedError

    def gap_np(self, x, t):
        raise NotImplementedError


class Plane(Tool):
    """Half-space: the plane through ``point`` [mm] (+ translation) with ``normal`` (any length,
    normalised) pointing into the body; g = (x - p) . N.  2-D with 2-vectors, 3-D with 3-vectors."""

    name = "plane"

    def __init__(self, point=(0.0, 0.0), normal=(0.0, 1.0), path=None, name=None):
        super().__init__(name, path)
        self.point = np.asarray(point, dtype=float)
        n = np.asarray(normal, dtype=float)
        if n.shape not in ((2,), (3,)) or not np.linalg.norm(n) > 0:
            raise ValueError(f"plane normal must be a non-zero 2- or 3-vector, got {normal}")
        if self.point.shape != n.shape:
            raise ValueError(f"plane point {point} and normal {normal} must have the same dimension")
        self.dim = n.shape[0]
        self.normal = n / np.linalg.norm(n)

    def gap(self, x, t):
        if self.dim == 3:
            N = ufl.as_vector([float(c) for c in self.normal])
            return ufl.dot(x - self._moved(self.point, t), N), N
        d = self.translation(t)
        p = ufl.as_vector([self.point[0] + d[0], self.point[1] + d[1]])
        N = ufl.as_vector([float(self.normal[0]), float(self.normal[1])])
        return ufl.dot(x - p, N), N

    def gap_np(self, x, t):
        p = self.point + self.translation(t, use_ufl=False)
        g = (np.asarray(x)[:, :self.dim] - p) @ self.normal
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

    def __init__(self, segments, body_side=default("tools.*.body_side"), path=None, name=None):
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
        dist = op.sqrt(op.dot(d, d) + TINY)
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
        rho = op.sqrt(op.dot(d, d) + TINY)
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


# ----------------------------------------------------------------------------------------------
# 3-D tools


class Sphere(Tool):
    """Ball of ``radius`` [mm] centred at ``center`` [mm] (a 3-vector, + translation); the body lies
    outside: g = |x - c| - R, N = (x - c) / |x - c| (guarded: N = 0 at the centre itself)."""

    name = "sphere"
    dim = 3

    def __init__(self, center, radius, path=None, name=None):
        super().__init__(name, path)
        self.center0 = _vector(center, "sphere center", (3,))
        self.radius = float(radius)
        if not self.radius > 0:
            raise ValueError(f"sphere radius must be > 0, got {radius}")

    def gap(self, x, t):
        d = x - self._moved(self.center0, t)
        dist = ufl.sqrt(ufl.dot(d, d) + TINY)
        return dist - self.radius, d / dist

    def gap_np(self, x, t):
        d = np.asarray(x, dtype=float)[:, :3] - (self.center0 + self.translation(t, use_ufl=False))
        dist = np.sqrt(np.einsum("ij,ij->i", d, d) + TINY)
        return dist - self.radius, d / dist[:, None]


class _AxisTool(Tool):
    """A tool symmetric about the axis through ``center`` [mm] with direction ``axis`` (normalised):
    the axial coordinate a = (x - c) . e_a and the radial vector r = (x - c) - a e_a of a point,
    rho = |r| (guarded: sqrt(r . r + TINY), so e_rho = r / rho = 0 on the axis)."""

    dim = 3

    def __init__(self, center, axis, path=None, name=None):
        super().__init__(name, path)
        self.center0 = _vector(center, f"{self.name} center", (3,))
        self.axis = _unit(axis, f"{self.name} axis", (3,))

    def _axial_ufl(self, x, t):
        """UFL (a, r vector, rho) of the positions x at time t."""
        y = x - self._moved(self.center0, t)
        e = ufl.as_vector([float(c) for c in self.axis])
        a = ufl.dot(y, e)
        r = y - a * e
        return a, r, ufl.sqrt(ufl.dot(r, r) + TINY)

    def _axial_np(self, x, t):
        """numpy (a (n,), r (n, 3), rho (n,)) of the positions x (n, 3) at time t."""
        y = np.asarray(x, dtype=float)[:, :3] - (self.center0 + self.translation(t, use_ufl=False))
        a = y @ self.axis
        r = y - a[:, None] * self.axis
        return a, r, np.sqrt(np.einsum("ij,ij->i", r, r) + TINY)


class Cylinder(_AxisTool):
    """Infinite circular cylinder of ``radius`` [mm] about the axis through ``center`` [mm] (+
    translation) with direction ``axis``; the body lies outside: g = rho - R, N = e_rho."""

    name = "cylinder"

    def __init__(self, center, axis, radius, path=None, name=None):
        super().__init__(center, axis, path=path, name=name)
        self.radius = float(radius)
        if not self.radius > 0:
            raise ValueError(f"cylinder radius must be > 0, got {radius}")

    def gap(self, x, t):
        _, r, rho = self._axial_ufl(x, t)
        return rho - self.radius, r / rho

    def gap_np(self, x, t):
        _, r, rho = self._axial_np(x, t)
        return rho - self.radius, r / rho[:, None]


class Torus(_AxisTool):
    """Torus about the axis through ``center`` [mm] (+ translation) with direction ``axis``: a tube of
    ``radius`` r [mm] whose centre circle has ``ring_radius`` R [mm] in the plane a = 0; the body lies
    outside the tube.  The distance to the centre circle is d = sqrt((rho - R)^2 + a^2): g = d - r,
    N = ((rho - R) e_rho + a e_a) / d (the guarded e_rho is 0 on the axis, where g is still exact
    and N is a e_a / d; on the centre circle N is guarded with TINY)."""

    name = "torus"

    def __init__(self, center, axis, ring_radius, radius, path=None, name=None):
        super().__init__(center, axis, path=path, name=name)
        self.ring_radius, self.radius = float(ring_radius), float(radius)
        if not (self.ring_radius > 0 and self.radius > 0):
            raise ValueError(f"torus ring_radius and radius must be > 0, got {ring_radius}, {radius}")

    def gap(self, x, t):
        a, r, rho = self._axial_ufl(x, t)
        e = ufl.as_vector([float(c) for c in self.axis])
        dist = ufl.sqrt((rho - self.ring_radius) ** 2 + a * a + TINY)
        return dist - self.radius, ((rho - self.ring_radius) / dist) * (r / rho) + (a / dist) * e

    def gap_np(self, x, t):
        a, r, rho = self._axial_np(x, t)
        dist = np.sqrt((rho - self.ring_radius) ** 2 + a * a + TINY)
        return (dist - self.radius, ((rho - self.ring_radius) / dist / rho)[:, None] * r
                + (a / dist)[:, None] * self.axis)


class RevolvedProfile(_AxisTool):
    """A :class:`Profile` (``segments`` and ``body_side`` as there) drawn in the (rho, a) half-plane
    of the axis through ``center`` [mm] with direction ``axis`` (rho >= 0 the distance from the axis,
    a the coordinate along it from ``center``) and revolved about that axis; it moves with
    ``path`` (3-D).  g of a point is the profile's at its (rho, a) and N = N_rho e_rho + N_a e_a.
    On the axis e_rho is 0 (guarded), so N there is N_a e_a.

    Example, a flat-ended punch of radius 10 with a 2 mm edge radius, its face at a = 0, pressing
    along -axis (the body below)::

        RevolvedProfile([("line", (0, 0), (8, 0)), ("arc", (8, 2), 2, 270, 360),
                         ("line", (10, 2), (10, 30))], center=(0, 0, 0), axis=(0, 0, 1),
                        body_side="right")
    """

    name = "revolved_profile"

    def __init__(self, segments, center, axis, body_side=default("tools.*.body_side"), path=None, name=None):
        super().__init__(center, axis, path=path, name=name)
        self.profile = Profile(segments, body_side=body_side)
        size = max(1.0, *(float(np.abs(q).max()) for p in self.profile.pieces for q in p["P"]))
        for k, p in enumerate(self.profile.pieces):
            if p["kind"] == "line":
                lowest = min(p["P"][0][0], p["P"][1][0])
            else:   # the arc's points: sample its sweep
                a0, a1 = (float(v) for v in segments[k][3:5])
                ang = np.radians(np.linspace(a0, a1, 361))
                lowest = float((p["c"][0] + p["R"] * np.cos(ang)).min())
            if lowest < -1e-9 * size:
                raise ValueError(f"revolved profile piece {k} reaches rho = {lowest:.6g} < 0: draw the "
                                 f"profile in the half-plane rho >= 0")

    def gap(self, x, t):
        a, r, rho = self._axial_ufl(x, t)
        v = self.profile._gap(_Ops(True), [rho, a])
        e = ufl.as_vector([float(c) for c in self.axis])
        return v[0], v[1] * (r / rho) + v[2] * e

    def gap_np(self, x, t):
        a, r, rho = self._axial_np(x, t)
        v = self.profile._gap(_Ops(False), [rho, a])
        return v[0], v[1][:, None] * (r / rho[:, None]) + v[2][:, None] * self.axis


__all__ = ["Tool", "Plane", "Circle", "Profile", "Sphere", "Cylinder", "Torus", "RevolvedProfile",
           "PENALTY_FACTOR", "default_penalty",
           "contact_length_scale", "piecewise_path"]
