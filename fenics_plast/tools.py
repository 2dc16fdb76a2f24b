"""Rigid tools that translate along a prescribed path: a shape of :mod:`fenics_plast.tool_shapes` with its
parameters, a name and a path.  Lengths in mm.

2-D tools (x = r, y = z in axisymmetry, where every tool is implicitly revolved about the axis) and
3-D tools (x, y, z).  A :class:`Tool` has a ``name``, a dimension ``dim`` (2 or 3), its ``shape`` (a
:class:`~fenics_plast.tool_shapes.ToolShape`) and parameter vector ``params``, a translation
``path(t, use_ufl) -> (dx, dy)`` or ``(dx, dy, dz)`` [mm] (UFL expressions of the UFL scalar t when
``use_ufl``, floats otherwise; None = fixed; a 3-D tool reads a missing dz as 0) and

* ``gap(x, t) -> (g, N)`` in UFL: x a UFL ``dim``-vector of current positions, t a UFL scalar (e.g.
  the solver's load ``fem.Constant``); g the signed gap [mm] (> 0 separated, < 0 penetrating) and N
  the unit normal pointing from the tool into the body;
* ``gap_np(x, t) -> (g (n,), N (n, dim))``: the same values in numpy (x (n, dim), or (n, 3) for a
  2-D tool, whose third column is ignored; t a float);
* ``translation(t, use_ufl)``: (dx, dy[, dz]), a tuple of UFL scalars or a numpy (dim,) array.

Both come from the shape's one gap formula (the explicit solver compiles the same formula:
:mod:`fenics_plast.solvers.tool_gaps`).  ``Tool("sphere", center=(0, 0, 0), radius=5.0)`` makes any
registered shape from its scene keys; :class:`Plane`, :class:`Circle`, :class:`Profile`, :class:`Sphere`,
:class:`Cylinder`, :class:`Torus` and :class:`RevolvedProfile` (a 3-D profile) are shorthands for the
shipped ones.

Penalty helpers: :func:`default_penalty` (eps = factor E / h) and :func:`contact_length_scale`
(h: the mean depth of the cells along a facet group).
"""
from __future__ import annotations

import math

import numpy as np
import ufl

from fenics_plast.schema import PENALTY_FACTOR, default  # default normal penalty = PENALTY_FACTOR * E / h
from fenics_plast.scene_key import OPTIONAL, REQUIRED
from fenics_plast.tool_shapes import shapes
from fenics_plast.tool_shapes.ops import TINY


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
    pairs = [(f, c) for f in facets[facets < mesh.topology.index_map(fdim).size_local] for c in f2c.links(f)]
    cells = np.array([c for _, c in pairs], dtype=np.int64)
    local = np.array([int(np.flatnonzero(c2f.links(c) == f)[0]) for f, c in pairs], dtype=np.int64)
    total, count = 0.0, len(pairs)
    if count:
        verts = np.asarray(ref_facets)[local]                       # (n, vertices per facet)
        x = mesh.geometry.x[dc.geometry_dofs(mesh)[cells], :tdim]   # (n, vertices per cell, tdim)
        if tdim == 3:
            total = float(np.sum(_cell_volume(x) / _facet_area(np.take_along_axis(x, verts[:, :, None], 1))))
        else:
            p = x[:, order]
            q = np.roll(p, -1, axis=1)
            area = 0.5 * np.abs(np.sum(p[..., 0] * q[..., 1] - q[..., 0] * p[..., 1], axis=1))
            n = np.arange(count)
            total = float(np.sum(area / np.linalg.norm(x[n, verts[:, 1]] - x[n, verts[:, 0]], axis=1)))
    total, count = mesh.comm.allreduce(total, op=MPI.SUM), mesh.comm.allreduce(count, op=MPI.SUM)
    if count == 0:
        raise ValueError(f"no facet is tagged {tag}")
    return total / count


_GAUSS2 = (0.5 - 0.5 / math.sqrt(3.0), 0.5 + 0.5 / math.sqrt(3.0))   # 2-point Gauss on [0, 1]


def _cell_volume(xyz):
    """Volumes [mm^3] (n,) of first-order tetrahedra (n, 4, 3) or hexahedra (n, 8, 3; basix vertex order
    v = i + 2 j + 4 k at reference (i, j, k)): exact, 2x2x2 Gauss of det J."""
    if xyz.shape[1] == 4:
        return np.abs(np.linalg.det(xyz[:, 1:] - xyz[:, :1])) / 6.0
    c = xyz.reshape(-1, 2, 2, 2, 3)                  # [cell, k, j, i, :]
    vol = np.zeros(len(xyz))
    for r in _GAUSS2:
        for s in _GAUSS2:
            for t in _GAUSS2:
                w = [(1 - r, r), (1 - s, s), (1 - t, t)]
                d_r = sum(w[1][j] * w[2][k] * (c[:, k, j, 1] - c[:, k, j, 0]) for j in (0, 1) for k in (0, 1))
                d_s = sum(w[0][i] * w[2][k] * (c[:, k, 1, i] - c[:, k, 0, i]) for i in (0, 1) for k in (0, 1))
                d_t = sum(w[0][i] * w[1][j] * (c[:, 1, j, i] - c[:, 0, j, i]) for i in (0, 1) for j in (0, 1))
                vol += 0.125 * np.abs(np.linalg.det(np.stack([d_r, d_s, d_t], axis=1)))
    return vol


def _facet_area(xyz):
    """Areas [mm^2] (n,) of triangles (n, 3, 3) or bilinear quadrilaterals (n, 4, 3; basix order v = i + 2 j):
    exact, 2x2 Gauss of |dx/dr x dx/ds|."""
    if xyz.shape[1] == 3:
        return 0.5 * np.linalg.norm(np.cross(xyz[:, 1] - xyz[:, 0], xyz[:, 2] - xyz[:, 0]), axis=1)
    area = np.zeros(len(xyz))
    for r in _GAUSS2:
        for s in _GAUSS2:
            d_r = (1 - s) * (xyz[:, 1] - xyz[:, 0]) + s * (xyz[:, 3] - xyz[:, 2])
            d_s = (1 - r) * (xyz[:, 2] - xyz[:, 0]) + r * (xyz[:, 3] - xyz[:, 1])
            area += 0.25 * np.linalg.norm(np.cross(d_r, d_s), axis=1)
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


class Tool:
    """A rigid tool of the registered shape ``shape`` (:mod:`fenics_plast.tool_shapes`) with the scene key
    values ``values`` (absent keys take their declared default), translating along ``path`` (see the
    module docstring); ``dim`` 2 or 3 (default: :meth:`~fenics_plast.tool_shapes.ToolShape.dim_of`).
    ValueError for an unknown shape, a missing required key or values the shape cannot take."""

    def __init__(self, shape, path=None, name=None, dim=None, **values):
        if shape not in shapes():
            raise ValueError(f"unknown tool shape {shape!r}; allowed: {sorted(shapes())}")
        self.shape = shapes()[shape]
        for key, spec in self.shape.params.items():
            if values.get(key) is None:
                if spec.default is REQUIRED:
                    raise ValueError(f"a {shape} tool needs {key!r}")
                values[key] = None if spec.default is OPTIONAL else spec.default
        self.dim = self.shape.dim_of(values) if dim is None else dim
        if self.dim not in self.shape.dims:
            raise ValueError(f"a {shape} tool exists in {' or '.join(f'{d}-D' for d in self.shape.dims)}, "
                             f"not in {self.dim}-D")
        self.params = np.asarray(self.shape.pack(values, self.dim), dtype=float)     # prm of the shape
        self.name = name or shape
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

    def gap(self, x, t):
        """(g, N) in UFL at the positions x (a UFL ``dim``-vector) and the UFL time t."""
        g, N = self.shape.gap(self.params.tolist(), tuple(x[i] for i in range(self.dim)), self.translation(t))
        return g, ufl.as_vector(N)

    def gap_np(self, x, t):
        """(g (n,), N (n, dim)) in numpy at the positions x (n, dim) (or (n, 3) for a 2-D tool) and t."""
        x = np.asarray(x, dtype=float)
        d = self.translation(t, use_ufl=False)
        g, N = self.shape.gap(self.params.tolist(), tuple(x[:, i] for i in range(self.dim)),
                              tuple(float(c) for c in d))
        return g, np.stack([np.broadcast_to(c, g.shape) for c in N], axis=1)


def compiled_shape(tool):
    """(shape code, parameter vector) of a tool whose gap the compiled kernels compute
    (:mod:`fenics_plast.solvers.tool_gaps`): a :class:`Tool` without a gap of its own; None for any other."""
    if isinstance(tool, Tool) and type(tool).gap_np is Tool.gap_np:
        return tool.shape.code, np.asarray(tool.params, dtype=float)
    return None


class Plane(Tool):
    """Half-space through ``point`` [mm] (+ translation) with ``normal`` (any length, normalised) pointing
    into the body (:mod:`~fenics_plast.tool_shapes.plane`); 2-D with 2-vectors, 3-D with 3-vectors."""

    def __init__(self, point=(0.0, 0.0), normal=(0.0, 1.0), path=None, name=None):
        super().__init__("plane", path, name, point=point, normal=normal)


class Circle(Tool):
    """Disc of ``radius`` [mm] centred at ``center`` [mm] (+ translation), the body outside
    (:mod:`~fenics_plast.tool_shapes.circle`)."""

    def __init__(self, center, radius, path=None, name=None):
        super().__init__("circle", path, name, center=center, radius=radius)


class Profile(Tool):
    """2-D chain of ``("line", p0, p1)`` and ``("arc", centre, radius, start_deg, end_deg)`` pieces, the body
    on ``body_side`` (:mod:`~fenics_plast.tool_shapes.profile`, which has an example)."""

    def __init__(self, segments, body_side=default("tools.*.body_side"), path=None, name=None):
        super().__init__("profile", path, name, dim=2, segments=segments, body_side=body_side)


class Sphere(Tool):
    """Ball of ``radius`` [mm] centred at ``center`` [mm] (+ translation), the body outside
    (:mod:`~fenics_plast.tool_shapes.sphere`)."""

    def __init__(self, center, radius, path=None, name=None):
        super().__init__("sphere", path, name, center=center, radius=radius)


class Cylinder(Tool):
    """Infinite cylinder of ``radius`` [mm] about the axis through ``center`` [mm] with direction ``axis``,
    the body outside (:mod:`~fenics_plast.tool_shapes.cylinder`)."""

    def __init__(self, center, axis, radius, path=None, name=None):
        super().__init__("cylinder", path, name, center=center, axis=axis, radius=radius)


class Torus(Tool):
    """Tube of ``radius`` [mm] about a ring of ``ring_radius`` [mm] about the axis through ``center`` with
    direction ``axis``, the body outside (:mod:`~fenics_plast.tool_shapes.torus`)."""

    def __init__(self, center, axis, ring_radius, radius, path=None, name=None):
        super().__init__("torus", path, name, center=center, axis=axis, ring_radius=ring_radius, radius=radius)


class RevolvedProfile(Tool):
    """A :class:`Profile` (``segments``, ``body_side``) drawn in the (rho, a) half-plane of the axis through
    ``center`` [mm] with direction ``axis`` and revolved about it (3-D; see
    :mod:`~fenics_plast.tool_shapes.profile`)."""

    def __init__(self, segments, center, axis, body_side=default("tools.*.body_side"), path=None, name=None):
        super().__init__("profile", path, name, dim=3, segments=segments, center=center, axis=axis,
                         body_side=body_side)


__all__ = ["Tool", "compiled_shape", "Plane", "Circle", "Profile", "Sphere", "Cylinder", "Torus", "RevolvedProfile",
           "TINY", "PENALTY_FACTOR", "default_penalty",
           "contact_length_scale", "piecewise_path"]
