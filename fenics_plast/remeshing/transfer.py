r"""State transfer from an old (deformed) 2-D quadrilateral mesh onto a new one (issue 35).

>>> t = StateTransfer(old_mesh, degree=2, axisymmetric=True)        # collective: gathers the old mesh
>>> state, report = t.quadrature_state(qmap.state(), new_mesh)       # {name: (n_new,) + shape}
>>> rho_new = t.cell_values(rho_old, new_mesh)                        # P0: (new owned cells,)
>>> J_ref = t.point_values(J_old, new_mesh)                            # a scalar per point: (n_new,)
>>> t.nodal_function(v_old, v_new)                                    # CG1 (velocities), in place

The old mesh's CURRENT geometry (the deformed configuration, which becomes the new reference:
``mesh.geometry.x``, or the node coordinates ``x`` given, e.g. X + u, as the other remeshing modules
take them) is the domain of every old field; the new mesh covers (nearly) the same region. Units
are those of the fields (mm for coordinates; eqps dimensionless, temperature K, b_e^-1
dimensionless, ...): the transfer is linear interpolation and changes none.

Method (quadrature state, one pass for all variables):

1. Per old cell, the bilinear (Q1) field through its nq Gauss values: corner values
   ``c = pinv(N(X_q)) v_q`` (N: the Q1 shape functions at the reference points X_q of
   ``dc.quadrature_rule(cell, degree)``); with 2x2 Gauss (nq = 4) this is the extrapolation of Abaqus
   and "SPR-lite" and is exact for bilinear fields in the reference coordinates, hence for every field
   that is linear in x, y (the coordinate map of a Q1 cell is bilinear); nq = 1 gives a constant.
2. At each old node, the volume-weighted mean of its cells' corner values (weight: the cell's area,
   times r in axisymmetric bodies): a continuous Q1 nodal field.
3. Each new quadrature point (its physical position under the new mesh's geometry) is located in the
   old cell that contains it (a bucket grid of the old cells' bounding boxes, then Newton on the
   bilinear map for the reference coordinates; the first cell in original order wins on shared
   edges). A point in no old cell (outside the old body: a slightly different outline) takes the
   value at the nearest point of the old boundary edges, or of the edges of the cells whose box
   holds it when nearer (a point in a non-convex cell where the bilinear map folds). The nodal
   field is evaluated there.
4. Per variable, by its shape (:data:`RULES`; a new variable of these shapes is carried without
   new code, one of another shape raises NotImplementedError until it has a rule):

   * scalars (``eqps``, ``temperature``): the interpolated value, clipped to [min, max] of the old
     values, so no new extrema are created (eqps >= 0 and never above the old maximum). Steps 2-3
     are convex combinations; only the extrapolation of step 1 can overshoot, and the clip removes it.
     The price: new points nearer the boundary than the old ones cannot exceed the old points'
     range, so a linear field is exact only within it (``clip=False``: exact everywhere) and the
     max error where an extremum lies on the boundary is first order.
   * symmetric positive definite 3x3 tensors (``binv`` = b_e^-1): steps 1-3 on ``log b_e^-1`` (6
     components, eigendecomposition), then ``exp``: the result is symmetric positive definite by
     construction, whatever the overshoot. det b_e^-1 = exp(tr log b_e^-1), so ln det b_e^-1 is
     transferred as a scalar field and stays within the old range of det (exp of a convex combination
     of ln det up to the step-1 overshoot). Consistency with the material model: in the isochoric
     model the Kirchhoff stress is LINEAR in log b_e^-1 (``tau = lmbda tr(eps) I + 2 mu eps``,
     ``eps = -1/2 log b_e^-1``), so this transfer interpolates the stress itself (exact for stress
     fields linear in x); plastic flow there is isochoric, det b_e^-1 = J_e^-2 = J^-2 (theta^-2
     with q1p0: F-bar), and the
     transferred value IS the elastic volume ratio carried into the new reference: the model keeps
     no other record of J (the solver's dilatation theta is relative to the reference and restarts
     at 1, see below), so det b_e^-1 after the transfer stays tied to the volume change from the
     stress-free state (J_old at the point times the new meshes' J). The seed model keeps no
     constraint on det b_e^-1 (its plastic update is not isochoric); SPD is all it needs.

Other fields:

* P0 cell fields (:meth:`StateTransfer.cell_values`): the old cell values as constants per cell,
  steps 2-3, and the weighted (|J| w, times r) mean over the new cell's quadrature points; clipped to
  the old range; ``conserve=True`` rescales the result so that its integral equals the old one (a
  density, for mass). First order (a constant per old cell). What the solvers' P0 data are: the
  static solver's mixed space W (element q1p0) holds the displacement and the DG0 dilatation theta,
  the L2 projection of J = det F relative to the REFERENCE; the explicit solver holds theta and a
  DG0 density of the reference. Once the deformed shape becomes the new reference, u := 0 and
  theta := 1 (nothing to transfer: Fbar(0, 1) = I and Fu = Fbar(u, theta) in the next increment),
  while the pressure lives on in b_e^-1 (above). A reference density becomes the current one,
  rho0 / theta per old cell, transferred with ``conserve=True``.
* CG1 nodal fields (:meth:`StateTransfer.nodal_function`, explicit velocities): already continuous
  Q1 fields, evaluated at the new nodes (steps 3, no averaging); linear fields exactly.

MPI: the old mesh's owned cells (corner coordinates, input node indices) and the fields' rows are
gathered to every rank, ordered by original cell index, so every rank holds the same old data in the
same order whatever the partition; each rank evaluates the quadrature points / cells / dofs it owns on
the new mesh. Serial and parallel results agree to round-off (bit for bit in the tests).

Measured (tests/test_remesh_transfer.py: smooth fields from a distorted structured mesh onto Gmsh's
unstructured quadrilaterals of the same rectangle, h halved twice): L2 error of order 1.8-2.1
(eqps, log b_e^-1, T); max error of order about 2 where the extremum is inside, 1 where it is on the
boundary (the clip); P0 fields 1.5-1.7 in L2; linear fields and constants exact to 1e-12. Cost
(benchmarks/bench_remesh_transfer.py, one rank of a shared 2-core machine): 1e3 / 1e4 / 4e4 old
cells onto about as many new ones, the quadrature state (b_e^-1, eqps, T), a P0 and a CG1 vector
field, set-up (gathering the old mesh) included: 0.04 / 0.25 / 1.0 s; locating the points and the
eigendecompositions of b_e^-1 take about a third each.

Shapes: quadrature arrays are laid out as :class:`fenics_plast.quadrature.QuadratureMap` lays them
out, point p = c nq + q of owned cell c, ``(n_owned_cells * nq,) + shape``. Coordinates: the first
two of ``mesh.geometry.x`` (x = r, y = z in axisymmetric bodies). First-order quadrilaterals only
(node order (0,0), (1,0), (0,1), (1,1) of the reference square, dolfinx's).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fenics_plast import dolfinx_compat as dc
from fenics_plast.state_variables import STATE

__all__ = ["StateTransfer", "OldBody", "RULES", "TransferReport", "Located", "gauss_to_corners", "nodal_average",
           "locate", "bilinear", "shape_functions", "cell_corners", "quadrature_points", "quadrature_volumes", "point_volumes",
           "spd_log", "spd_exp", "scattered_values"]

#: transfer rule of a state variable, by its shape per point
RULES = {(): "bounded", (3, 3): "spd-log"}

_SYM = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))   # the 6 components of a symmetric 3x3 tensor
INSIDE_TOL = 1e-10        # reference-coordinate tolerance of "inside a cell"
NEWTON_ITERATIONS = 20    # at most, on the bilinear map (quadratic from the centre of a valid cell)


# -- reference quadrilateral ------------------------------------------------------------------------
def shape_functions(xi: np.ndarray) -> np.ndarray:
    """Q1 shape functions (..., 4) at reference points xi (..., 2) of [0, 1]^2, node order (0,0),
    (1,0), (0,1), (1,1)."""
    s, t = xi[..., 0], xi[..., 1]
    return np.stack([(1 - s) * (1 - t), s * (1 - t), (1 - s) * t, s * t], axis=-1)


def _jacobian(corners: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """d x / d xi (m, 2, 2) of the bilinear maps of cells ``corners`` (m, 4, 2) at xi (m, 2)."""
    s, t = xi[:, 0, None], xi[:, 1, None]
    x0, x1, x2, x3 = (corners[:, k] for k in range(4))
    d = x0 - x1 - x2 + x3
    return np.stack([x1 - x0 + d * t, x2 - x0 + d * s], axis=-1)


def bilinear(corner_values: np.ndarray, cells: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """Values (m, k) at reference points xi (m, 2) of the given cells (m,) of a per-cell Q1 field,
    corner_values (cells, 4, k)."""
    return np.einsum("mc,mck->mk", shape_functions(xi), corner_values[cells])


# -- step 1: Gauss values -> corners --------------------------------------------------------------------
def gauss_to_corners(values: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Corner values (cells, 4, k) of the bilinear field through (least squares for nq > 4; the
    constant for nq = 1) the values (cells, nq, k) at the reference points (nq, 2)."""
    extrapolation = np.linalg.pinv(shape_functions(np.asarray(points, dtype=float)))   # (4, nq)
    return np.einsum("cq,nqk->nck", extrapolation, values)


# -- step 2: nodal average ----------------------------------------------------------------------------
def nodal_average(corner_values: np.ndarray, nodes: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Continuous per-cell corner values (cells, 4, k): at each node the ``weights``-weighted (cells,)
    mean of the corner values of its cells; ``nodes`` (cells, 4): node numbers 0..n_nodes-1."""
    n_nodes = int(nodes.max()) + 1
    flat = nodes.reshape(-1)
    weighted = (corner_values * weights[:, None, None]).reshape(len(flat), -1)
    weight = np.bincount(flat, np.repeat(weights, 4), minlength=n_nodes)
    total = np.stack([np.bincount(flat, column, minlength=n_nodes) for column in weighted.T], axis=1)
    return (total / weight[:, None])[nodes]


# -- step 3: locating points -------------------------------------------------------------------------
def _inverse_map(corners: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Reference coordinates (m, 2) of points (m, 2) in the cells corners (m, 4, 2) (Newton from the
    centre, each point until its step is below 1e-13; meaningful where the point is inside or near a
    valid cell), and the final residual |x(xi) - point| relative to the cell's size (m,)."""
    a, b, c = corners[:, 0], corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    d = corners[:, 0] - corners[:, 1] - corners[:, 2] + corners[:, 3]   # x = a + b s + c t + d s t
    xi = np.full((len(points), 2), 0.5)
    active = np.arange(len(points))
    for _ in range(NEWTON_ITERATIONS):
        s, t = xi[active, 0, None], xi[active, 1, None]
        r = points[active] - (a[active] + b[active] * s + c[active] * t + d[active] * s * t)
        js, jt = b[active] + d[active] * t, c[active] + d[active] * s        # columns of d x / d xi
        det = js[:, 0] * jt[:, 1] - jt[:, 0] * js[:, 1]
        det = np.where(np.abs(det) > 1e-300, det, 1e-300)
        step = np.stack([jt[:, 1] * r[:, 0] - jt[:, 0] * r[:, 1],
                         js[:, 0] * r[:, 1] - js[:, 1] * r[:, 0]], axis=-1) / det[:, None]
        xi[active] = np.clip(xi[active] + step, -2.0, 3.0)     # keeps points far outside from running away
        active = active[np.abs(step).max(axis=1) > 1e-13]
        if not len(active):
            break
    s, t = xi[:, 0, None], xi[:, 1, None]
    r = points - (a + b * s + c * t + d * s * t)
    size = np.linalg.norm(corners[:, 3] - corners[:, 0], axis=1) + np.linalg.norm(corners[:, 2] - corners[:, 1], axis=1)
    return xi, np.linalg.norm(r, axis=1) / np.maximum(size, 1e-300)


class _BucketGrid:
    """Uniform grid of buckets over the cells' bounding boxes: the candidate cells of a point are
    those whose box overlaps the point's bucket (about one bucket per cell)."""

    def __init__(self, corners: np.ndarray):
        lo, hi = corners.min(axis=1), corners.max(axis=1)
        self.origin = lo.min(axis=0)
        extent = np.maximum(hi.max(axis=0) - self.origin, 1e-300)
        self.n = np.maximum(1, np.round(extent / np.sqrt(extent.prod() / len(corners)))).astype(np.int64)
        self.size = extent / self.n
        i0, i1 = self._index(lo), self._index(hi)
        span = i1 - i0 + 1
        count = span[:, 0] * span[:, 1]
        cell = np.repeat(np.arange(len(corners)), count)
        local = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
        ix = i0[cell, 0] + local % span[cell, 0]
        iy = i0[cell, 1] + local // span[cell, 0]
        bucket = iy * self.n[0] + ix
        order = np.argsort(bucket, kind="stable")
        self.cells = cell[order]
        pad = 1e-9 * (hi - lo).max(axis=1, keepdims=True)
        self.lo, self.hi = lo - pad, hi + pad
        self.start = np.searchsorted(bucket[order], np.arange(self.n.prod() + 1))

    def _index(self, x: np.ndarray) -> np.ndarray:
        return np.clip(np.floor((x - self.origin) / self.size).astype(np.int64), 0, self.n - 1)

    def candidates(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(point, cell) pairs: the cells of each point's bucket whose box holds the point."""
        idx = self._index(points)
        b = idx[:, 1] * self.n[0] + idx[:, 0]
        count = self.start[b + 1] - self.start[b]
        point = np.repeat(np.arange(len(points)), count)
        local = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
        cell = self.cells[self.start[b][point] + local]
        p = points[point]
        inside = ((p >= self.lo[cell]) & (p <= self.hi[cell])).all(axis=1)
        return point[inside], cell[inside]


def _outside(xi: np.ndarray) -> np.ndarray:
    """How far reference points are outside [0, 1]^2 (0 inside)."""
    return np.maximum(np.maximum(-xi, xi - 1.0), 0.0).max(axis=1)


def _project(p, a, b):
    """Closest points of the segments a-b to the points p (all (m, 2)): parameter t (m,) in [0, 1] and
    distance (m,)."""
    ab = b - a
    t = np.clip(np.einsum("md,md->m", p - a, ab) / np.maximum(np.einsum("md,md->m", ab, ab), 1e-300), 0.0, 1.0)
    return t, np.linalg.norm(p - a - t[:, None] * ab, axis=1)


def _nearest_on_edges(points, a, b, chunk=2048):
    """For each point (m, 2): the index of the nearest of the segments a-b (e, 2) and the parameter
    t in [0, 1] of the closest point on it."""
    ab = b - a
    ab2 = np.maximum(np.einsum("ed,ed->e", ab, ab), 1e-300)
    best = np.empty(len(points), dtype=np.int64)
    tbest = np.empty(len(points))
    for s in range(0, len(points), chunk):
        p = points[s:s + chunk]
        ap = p[:, None, :] - a[None]
        t = np.clip(np.einsum("med,ed->me", ap, ab) / ab2, 0.0, 1.0)
        d = ap - t[..., None] * ab[None]
        j = np.argmin(np.einsum("med,med->me", d, d), axis=1)
        best[s:s + chunk], tbest[s:s + chunk] = j, t[np.arange(len(p)), j]
    return best, tbest


#: the 4 edges of the reference square as (corner, corner) and the reference points of the corners
_EDGES = ((0, 1), (1, 3), (3, 2), (2, 0))
_CORNER_XI = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])


def _edge_xi(k0, k1, t):
    """Reference coordinates (m, 2) of the points at parameter t (m,) along the cell edges k0-k1 (m,)."""
    return (1 - t)[:, None] * _CORNER_XI[k0] + t[:, None] * _CORNER_XI[k1]


@dataclass
class Located:
    """Where points lie in the old body: cell (m,) and reference coordinates xi (m, 2) of each; the
    points found in no old cell (``outside``, bool (m,): outside the old body, or in a cell whose map
    could not be inverted) take the nearest point of the old boundary or of the cells around them,
    at ``distance`` (m,) [mm] (0 for the others)."""
    cells: np.ndarray
    xi: np.ndarray
    outside: np.ndarray
    distance: np.ndarray


def _holders(points, point, cell, corners):
    """Per point (m, 2): the index into the candidate pairs (point, cell) of the first cell (in cell
    order) that holds it, -1 where none does, and the pairs' reference coordinates."""
    xi, residual = _inverse_map(corners[cell], points[point])
    inside = np.flatnonzero((_outside(xi) <= INSIDE_TOL) & (residual <= 1e-10))
    holders, first = np.unique(point[inside], return_index=True)
    found = np.full(len(points), -1, dtype=np.int64)
    found[holders] = inside[first]
    return found, xi


def _nearest_boundary(body, points):
    """(cells, xi, distance) of the nearest points of the old boundary to points (m, 2)."""
    e, t = _nearest_on_edges(points, body.edge_a, body.edge_b)
    near = body.edge_a[e] + t[:, None] * (body.edge_b[e] - body.edge_a[e])
    return body.edge_cell[e], _edge_xi(body.edge_k0[e], body.edge_k1[e], t), np.linalg.norm(points - near, axis=1)


def _nearest_cell_edges(body, points, point, cell):
    """(cells, xi, distance) of the nearest points on the edges of each point's candidate cells (pairs
    point, cell); distance inf for a point without candidates."""
    m, n_pairs = len(points), len(point)
    k0 = np.repeat(np.array([e[0] for e in _EDGES])[None], n_pairs, axis=0).reshape(-1)
    k1 = np.repeat(np.array([e[1] for e in _EDGES])[None], n_pairs, axis=0).reshape(-1)
    pp, cc = np.repeat(point, 4), np.repeat(cell, 4)
    t, d = _project(points[pp], body.corners[cc, k0], body.corners[cc, k1])
    order = np.lexsort((np.arange(len(d)), d, pp))          # per point, nearest first (ties: first pair)
    first = order[np.unique(pp[order], return_index=True)[1]]
    cells, xi, distance = np.zeros(m, dtype=np.int64), np.zeros((m, 2)), np.full(m, np.inf)
    cells[pp[first]], xi[pp[first]], distance[pp[first]] = cc[first], _edge_xi(k0[first], k1[first], t[first]), d[first]
    return cells, xi, distance


def locate(body: "OldBody", points: np.ndarray) -> Located:
    """The old cell containing each point (m, 2) and its reference coordinates there; a point in
    none takes the nearest point of the old boundary, or of the edges of the cells whose box holds
    it if nearer (a point inside a cell whose bilinear map Newton could not invert)."""
    points = np.asarray(points, dtype=float)[:, :2]
    m = len(points)
    point, cell = body.grid.candidates(points)
    found, xi = _holders(points, point, cell, body.corners)
    ok = found >= 0
    cells, ref, distance = np.zeros(m, dtype=np.int64), np.zeros((m, 2)), np.zeros(m)
    cells[ok], ref[ok] = cell[found[ok]], np.clip(xi[found[ok]], 0.0, 1.0)
    lost = np.flatnonzero(~ok)
    if len(lost):
        cells_b, xi_b, d_b = _nearest_boundary(body, points[lost])
        pairs = np.isin(point, lost)
        local = np.searchsorted(lost, point[pairs])
        cells_c, xi_c, d_c = _nearest_cell_edges(body, points[lost], local, cell[pairs])
        inner = d_c < d_b
        cells[lost] = np.where(inner, cells_c, cells_b)
        ref[lost] = np.where(inner[:, None], xi_c, xi_b)
        distance[lost] = np.minimum(d_c, d_b)
    return Located(cells, ref, ~ok, distance)


# -- the old body, gathered -------------------------------------------------------------------------
def _owned_cells(mesh) -> int:
    return mesh.topology.index_map(mesh.topology.dim).size_local


def cell_corners(mesh, x=None) -> np.ndarray:
    """(owned cells, 4, 2) corner coordinates [mm] of the owned cells, in dolfinx's node order, from
    ``x`` ((local geometry nodes, 2 or 3), indexed like ``mesh.geometry.x``; default: the mesh as
    it stands)."""
    x = mesh.geometry.x if x is None else x
    return np.asarray(x)[dc.geometry_dofs(mesh)[:_owned_cells(mesh)], :2]


def quadrature_points(mesh, degree: int, x=None) -> np.ndarray:
    """Physical coordinates (owned cells * nq, 2) [mm] of the owned quadrature points, point p = c nq + q
    (``x``: as for :func:`cell_corners`)."""
    X, _ = dc.quadrature_rule(mesh.ufl_cell().cellname(), degree)
    return np.einsum("qk,ckd->cqd", shape_functions(X), cell_corners(mesh, x)).reshape(-1, 2)


def quadrature_volumes(mesh, degree: int, axisymmetric: bool = False, x=None) -> np.ndarray:
    """(owned cells, nq) weights |det J| w_q (times r when ``axisymmetric``) of the owned quadrature
    points: their share of the cell's area (volume per radian) [mm^2 or mm^3] (``x``: as for
    :func:`cell_corners`)."""
    X, w = dc.quadrature_rule(mesh.ufl_cell().cellname(), degree)
    corners = cell_corners(mesh, x)
    n, nq = len(corners), len(w)
    J = _jacobian(np.repeat(corners, nq, axis=0), np.tile(X, (n, 1)))
    vol = np.abs(J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]).reshape(n, nq) * w[None, :]
    if axisymmetric:
        vol = vol * quadrature_points(mesh, degree, x)[:, 0].reshape(n, nq)
    return vol


def point_volumes(mesh, degree: int, axisymmetric: bool, binv, x=None) -> tuple[np.ndarray, np.ndarray]:
    """(dv, dV0) (owned points,) [mm^3; plane strain mm^2, per mm]: each owned quadrature point's volume
    of ``mesh`` deformed to ``x`` (axisymmetric: revolved, 2 pi r dA; :func:`quadrature_volumes`) and the
    same with its elastic dilatation taken out, dv / J_e with J_e = det(b_e^-1)^(-1/2) (``binv``: the points'
    b_e^-1, (points, 3, 3)): the stress-free volume the energies and the remeshing's volume check count in."""
    dv = quadrature_volumes(mesh, degree, axisymmetric, x).reshape(-1)
    if axisymmetric:
        dv = 2.0 * np.pi * dv
    return dv, dv * np.sqrt(np.linalg.det(np.asarray(binv).reshape(-1, 3, 3)))


class OldBody:
    """The old mesh's owned cells of every rank, on every rank, in original-cell order: ``corners``
    (cells, 4, 2) [mm], ``nodes`` (cells, 4) node numbers 0.. (from the input node indices),
    ``volumes`` (cells,) area (times mean r when axisymmetric), the boundary edges (``edge_a``,
    ``edge_b`` their end points, ``edge_cell``, ``edge_k0``, ``edge_k1`` the cell and its corners),
    and the bucket grid of the cells. :meth:`gather` brings any per-owned-cell array in that order.
    ``x``: the deformed node coordinates, as for :func:`cell_corners` (default: the mesh as it stands)."""

    def __init__(self, mesh, degree: int = 2, axisymmetric: bool = False, x=None):
        self.comm = mesh.comm
        n = _owned_cells(mesh)
        original = np.asarray(mesh.topology.original_cell_index, dtype=np.int64)[:n]
        counts = self.comm.allgather(n)
        self._order = np.argsort(np.concatenate(self.comm.allgather(original)), kind="stable")
        self._counts = counts
        self.corners = self.gather(cell_corners(mesh, x))
        node_keys = np.asarray(mesh.geometry.input_global_indices, dtype=np.int64)[dc.geometry_dofs(mesh)[:n]]
        _, self.nodes = np.unique(self.gather(node_keys), return_inverse=True)
        self.nodes = self.nodes.reshape(-1, 4)
        self.volumes = self.gather(quadrature_volumes(mesh, degree, axisymmetric, x).sum(axis=1))
        self._boundary_edges()
        self.grid = _BucketGrid(self.corners)

    def gather(self, rows: np.ndarray) -> np.ndarray:
        """The rows (owned cells, ...) of every rank, in original-cell order (collective)."""
        rows = np.ascontiguousarray(rows)
        return np.concatenate(self.comm.allgather(rows))[self._order]

    def _boundary_edges(self):
        k0 = np.array([e[0] for e in _EDGES])
        k1 = np.array([e[1] for e in _EDGES])
        a, b = self.nodes[:, k0], self.nodes[:, k1]                  # (cells, 4)
        key = np.minimum(a, b) * (self.nodes.max() + 1) + np.maximum(a, b)
        _, inverse, count = np.unique(key.reshape(-1), return_inverse=True, return_counts=True)
        single = np.flatnonzero(count[inverse] == 1)                  # edges of one cell: the boundary
        cell, local = np.divmod(single, 4)
        self.edge_cell, self.edge_k0, self.edge_k1 = cell, k0[local], k1[local]
        self.edge_a = self.corners[cell, self.edge_k0]
        self.edge_b = self.corners[cell, self.edge_k1]


# -- SPD tensors ----------------------------------------------------------------------------------
def spd_log(A: np.ndarray) -> np.ndarray:
    """Matrix logarithm (n, 3, 3) of symmetric positive definite (n, 3, 3) (eigendecomposition);
    raises ValueError on an eigenvalue <= 0."""
    w, V = np.linalg.eigh(0.5 * (A + np.swapaxes(A, 1, 2)))
    if len(w) and not (w > 0).all():
        raise ValueError(f"not positive definite: smallest eigenvalue {w.min():.3e}")
    return np.matmul(V * np.log(w)[:, None, :], np.swapaxes(V, 1, 2))


def spd_exp(L: np.ndarray) -> np.ndarray:
    """Matrix exponential (n, 3, 3) of symmetric (n, 3, 3): symmetric (exactly) positive definite."""
    w, V = np.linalg.eigh(0.5 * (L + np.swapaxes(L, 1, 2)))
    E = np.matmul(V * np.exp(w)[:, None, :], np.swapaxes(V, 1, 2))
    return 0.5 * (E + np.swapaxes(E, 1, 2))


def _to_columns(rule: str, values: np.ndarray) -> np.ndarray:
    """The interpolated columns (n, k) of a variable's values (n,) + shape, by its rule."""
    if rule == "bounded":
        return values.reshape(-1, 1)
    L = spd_log(values)
    return np.stack([L[:, i, j] for i, j in _SYM], axis=1)


def _from_columns(rule: str, columns: np.ndarray, bounds) -> tuple[np.ndarray, int]:
    """A variable's values from its interpolated columns, and how many were clipped (bounded rule)."""
    if rule == "bounded":
        v = columns[:, 0]
        clipped = int(np.count_nonzero((v < bounds[0]) | (v > bounds[1])))
        return np.clip(v, bounds[0], bounds[1]), clipped
    L = np.zeros((len(columns), 3, 3))
    for c, (i, j) in enumerate(_SYM):
        L[:, i, j] = L[:, j, i] = columns[:, c]
    return spd_exp(L), 0


def _measure(rule: str, values: np.ndarray) -> np.ndarray:
    """The scalar a report gives the range of: the values (scalars), det (tensors)."""
    return values if rule == "bounded" else np.linalg.det(values)


# -- the transfer --------------------------------------------------------------------------------------
@dataclass
class TransferReport:
    """Diagnostics of one transfer (identical on every rank): new points (all ranks), those outside
    the old body and their largest distance to it [mm], and per variable the old and new range
    (min, max; of det for b_e^-1 and other tensors) and the number of values clipped to the old range."""
    points: int = 0
    outside: int = 0
    max_distance: float = 0.0
    ranges: dict = field(default_factory=dict)
    clipped: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        return {"points": self.points, "outside": self.outside, "max_distance": self.max_distance,
                "ranges": self.ranges, "clipped": self.clipped}


class StateTransfer:
    """Transfers fields of ``old_mesh`` deformed to ``x`` ((local geometry nodes, 2 or 3) [mm], indexed
    like ``mesh.geometry.x``, e.g. X + u; default: the mesh as it stands) onto new meshes (as they
    stand); quadrature ``degree``; volumes times r when ``axisymmetric``. Collective (every method too)."""

    def __init__(self, old_mesh, degree: int = 2, axisymmetric: bool = False, x=None):
        self.mesh = old_mesh
        self.x = x
        self.degree = degree
        self.axisymmetric = axisymmetric
        self.points, _ = dc.quadrature_rule(old_mesh.ufl_cell().cellname(), degree)
        self.nq = len(self.points)
        self.body = OldBody(old_mesh, degree, axisymmetric, x)
        self._located = (np.zeros((0, 2)), None)      # the last points located, and where they are

    def _continuous(self, values_per_point: np.ndarray) -> np.ndarray:
        """Steps 1-2: continuous corner values (all old cells, 4, k) of owned-point columns (n, k)."""
        k = values_per_point.shape[1]
        corners = gauss_to_corners(values_per_point.reshape(-1, self.nq, k), self.points)
        return nodal_average(self.body.gather(corners), self.body.nodes, self.body.volumes)

    def _locate_points(self, points: np.ndarray) -> Located:
        """:func:`locate`, kept for the next call with the same points (a new mesh's state, then its
        P0 fields)."""
        if not np.array_equal(points, self._located[0]):
            self._located = (points, locate(self.body, points))
        return self._located[1]

    def _locate(self, points: np.ndarray, report: TransferReport) -> Located:
        where = self._locate_points(points)
        comm = self.body.comm
        report.points += comm.allreduce(len(points))
        report.outside += comm.allreduce(int(where.outside.sum()))
        report.max_distance = max(report.max_distance, comm.allreduce(float(where.distance.max(initial=0.0)),
                                                                      op=_max()))
        return where

    def _range(self, values: np.ndarray) -> tuple[float, float]:
        comm = self.body.comm
        return (comm.allreduce(float(values.min(initial=np.inf)), op=_min()),
                comm.allreduce(float(values.max(initial=-np.inf)), op=_max()))

    def quadrature_state(self, old_state: dict, new_mesh, variables=None, clip: bool = True
                         ) -> tuple[dict, TransferReport]:
        """The state at the new mesh's owned quadrature points (same degree), ``{name: (n_new,) + shape}``,
        from ``old_state`` ``{name: (n_old,) + shape}`` (``QuadratureMap.state()``), and the report.
        ``variables``: the :class:`~fenics_plast.state_variables.StateVariable` to carry (default: those
        of STATE in ``old_state``, e.g. ``present(material)``'s). ``clip=False``: scalars not clipped to
        their old range (then linear fields are exact everywhere, also at new points nearer the
        boundary than the old ones, where a linear field exceeds the old points' range)."""
        variables = [v for v in STATE if v.name in old_state] if variables is None else list(variables)
        report = TransferReport()
        rules, columns = {}, []
        for v in variables:
            if v.shape not in RULES:
                raise NotImplementedError(f"no transfer rule for state variable {v.name!r} of shape {v.shape}: "
                                          f"add one to fenics_plast.remeshing.transfer.RULES")
            rules[v.name] = RULES[v.shape]
            columns.append(_to_columns(rules[v.name], np.asarray(old_state[v.name], dtype=float)))
        widths = [c.shape[1] for c in columns]
        nodal = self._continuous(np.concatenate(columns, axis=1))
        where = self._locate(quadrature_points(new_mesh, self.degree), report)
        new_columns = bilinear(nodal, where.cells, where.xi)
        out, start = {}, 0
        for v, width in zip(variables, widths):
            old = np.asarray(old_state[v.name], dtype=float)
            bounds = self._range(old) if clip and rules[v.name] == "bounded" else (-np.inf, np.inf)
            out[v.name], clipped = _from_columns(rules[v.name], new_columns[:, start:start + width], bounds)
            start += width
            report.ranges[v.name] = {"old": self._range(_measure(rules[v.name], old)),
                                     "new": self._range(_measure(rules[v.name], out[v.name]))}
            report.clipped[v.name] = self.body.comm.allreduce(clipped)
        return out, report

    def point_values(self, old_values: np.ndarray, new_mesh) -> np.ndarray:
        """A scalar at the quadrature points, (new owned points,) from (old owned points,), by the scalars'
        rule of :meth:`quadrature_state` (clipped to the old range): e.g. the reference volume ratio."""
        old_values = np.asarray(old_values, dtype=float)
        nodal = self._continuous(old_values.reshape(-1, 1))
        where = self._locate_points(quadrature_points(new_mesh, self.degree))
        lo, hi = self._range(old_values)
        return np.clip(bilinear(nodal, where.cells, where.xi)[:, 0], lo, hi)

    def cell_values(self, old_values: np.ndarray, new_mesh, conserve: bool = False) -> np.ndarray:
        """P0 values (new owned cells,) from P0 values (old owned cells,): constants per old cell
        averaged at the nodes, then the weighted mean over each new cell's quadrature points, clipped
        to the old range; ``conserve``: rescaled so that the volume integrals agree."""
        old_values = np.asarray(old_values, dtype=float)
        nodal = self._continuous(np.repeat(old_values, self.nq).reshape(-1, 1))
        where = self._locate_points(quadrature_points(new_mesh, self.degree))
        vol = quadrature_volumes(new_mesh, self.degree, self.axisymmetric)
        at_points = bilinear(nodal, where.cells, where.xi)[:, 0].reshape(vol.shape)
        lo, hi = self._range(old_values)
        new = np.clip((at_points * vol).sum(axis=1) / vol.sum(axis=1), lo, hi)
        if conserve:
            comm = self.body.comm
            old_volumes = quadrature_volumes(self.mesh, self.degree, self.axisymmetric, self.x).sum(axis=1)
            old_total = comm.allreduce(float(old_values @ old_volumes))
            new_total = comm.allreduce(float(new @ vol.sum(axis=1)))
            new = new * (old_total / new_total if new_total != 0.0 else 1.0)
        return new

    def nodal_function(self, old_function, new_function) -> None:
        """Sets the CG1 ``new_function`` (values at its dof points, owned and ghost) from the CG1
        ``old_function`` (blocked or scalar) of the old mesh: the old Q1 field at the new nodes."""
        bs = old_function.function_space.dofmap.index_map_bs
        n_old = _owned_cells(self.mesh)
        dofs = dc.cell_dofs(old_function.function_space)[:n_old]                   # (cells, 4) blocks
        values = np.asarray(old_function.x.array).reshape(-1, bs)[dofs]            # (cells, 4, bs)
        corner_values = self.body.gather(values)
        V = new_function.function_space
        imap = V.dofmap.index_map
        n_owned = imap.size_local
        x = V.tabulate_dof_coordinates()[:n_owned, :2]
        where = locate(self.body, x)
        new_function.x.array[: n_owned * bs] = bilinear(corner_values, where.cells, where.xi).reshape(-1)
        new_function.x.scatter_forward()


def scattered_values(old_points: np.ndarray, old_values: np.ndarray, new_points: np.ndarray, comm) -> np.ndarray:
    """Values (m, k) at ``new_points`` (m, 2) [mm] of values (n, k) known at scattered ``old_points``
    (n, 2) [mm] (each rank its own; gathered to every rank): the two nearest old points' values
    weighted by the inverse distance, linear along a row of points such as a boundary group's nodes
    (a contact pair's history). Collective; (m, k) zeros where there are no old points."""
    k = old_values.shape[1] if old_values.ndim == 2 else 1
    pts = np.concatenate(comm.allgather(np.asarray(old_points, dtype=float).reshape(-1, 2)))
    vals = np.concatenate(comm.allgather(np.asarray(old_values, dtype=float).reshape(-1, k)))
    new_points = np.asarray(new_points, dtype=float).reshape(-1, 2)
    if not len(pts) or not len(new_points):
        return np.zeros((len(new_points), k))
    d = np.linalg.norm(new_points[:, None, :] - pts[None, :, :], axis=2)
    if len(pts) == 1:
        return np.repeat(vals, len(new_points), axis=0)
    near = np.argsort(d, axis=1)[:, :2]
    d1, d2 = np.take_along_axis(d, near, axis=1).T
    w1 = np.where(d1 + d2 > 0.0, d2 / np.maximum(d1 + d2, 1e-300), 1.0)
    return w1[:, None] * vals[near[:, 0]] + (1.0 - w1)[:, None] * vals[near[:, 1]]


def _min():
    from mpi4py import MPI
    return MPI.MIN


def _max():
    from mpi4py import MPI
    return MPI.MAX
