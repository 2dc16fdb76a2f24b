"""Quality of a deformed 2-D quadrilateral mesh, and the decision to remesh (issue 35).

The measures are those of the Verdict library (Knupp 2000, "Achieving finite element mesh quality
via optimization of the Jacobian matrix norm and associated quantities"), computed per cell from
the four corners of the deformed cell (geometry x = reference + displacement, mm), in the cell's
counter-clockwise order (dolfinx's tensor-product corners 0, 1, 3, 2):

* **scaled Jacobian**: at corner i with edges e1 = p(i+1) - p(i), e2 = p(i-1) - p(i), the corner
  Jacobian det[e1, e2] / (|e1| |e2|) = sin(corner angle), signed so that it is positive in a cell
  that keeps the orientation of its reference cell; the cell's value is the minimum over its
  corners: 1 for a rectangle, sin(theta) for a rhombus of angle theta, <= 0 for a degenerate or
  inverted cell (a corner of 180 deg or more: non-convex, folded). It is dimensionless and does not
  depend on the cell size, so one threshold serves a graded mesh.
* **max corner angle** [deg], 0..360: the largest interior angle (90 for a rectangle; > 180: the cell
  is non-convex, the bilinear map is no longer one-to-one near that corner).
* **aspect ratio**: longest edge / shortest edge (1 for a square). Graded and boundary-layer meshes
  are elongated on purpose, so it does not trigger remeshing by default.

:func:`should_remesh` decides with :class:`Thresholds` (default: min scaled Jacobian < 0.2, i.e.
a corner angle outside 11.5..168.5 deg, or a corner angle > 160 deg), collectively under MPI (the
worst cell over all ranks decides, so every rank takes the same decision). A fresh mesh of
:mod:`fenics_plast.remeshing.new_mesh` passes them with a margin (min scaled Jacobian 0.54..0.72,
max angle <= 137 deg measured), so a remesh does not call for the next one at once.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from mpi4py import MPI

from ..dolfinx_compat import cell_dofs, geometry_dofs

#: dolfinx's corners of a quadrilateral (tensor-product order 0:(0,0), 1:(1,0), 2:(0,1), 3:(1,1)) in
#: counter-clockwise order around the reference cell
CCW = (0, 1, 3, 2)


@dataclass(frozen=True)
class Thresholds:
    """When a mesh needs remeshing: any cell with a scaled Jacobian below ``min_scaled_jacobian`` or
    a corner angle above ``max_angle_deg`` [deg], or (when not None) an aspect ratio above
    ``max_aspect_ratio``."""
    min_scaled_jacobian: float = 0.2
    max_angle_deg: float = 160.0
    max_aspect_ratio: float | None = None


@dataclass(frozen=True)
class Quality:
    """The worst values over the whole mesh (all ranks) and the decision.

    ``min_scaled_jacobian`` (-1..1), ``max_angle_deg`` (0..360), ``max_aspect_ratio`` (>= 1);
    ``worst_cell_point`` (x, y) [mm]: the centroid of the cell of the smallest scaled Jacobian;
    ``remesh``: True when a threshold is passed; ``reason``: which, in words ("" when none)."""
    min_scaled_jacobian: float
    max_angle_deg: float
    max_aspect_ratio: float
    worst_cell_point: tuple[float, float]
    cells: int
    remesh: bool
    reason: str


def deformed_nodes(u) -> np.ndarray:
    """(local geometry nodes, 2) deformed coordinates x = X + u [mm] of the mesh of the continuous
    degree-1 displacement ``u`` (a Function with 2 components, owned and ghost values current),
    indexed like ``mesh.geometry.x``: what :func:`mesh_quality` and
    :func:`fenics_plast.remeshing.outline.outline` take. The displacement's dofs are matched to the
    geometry nodes cell by cell (both in the reference cell's corner order), not assumed to share
    their numbering."""
    V = u.function_space
    mesh = V.mesh
    x = np.array(mesh.geometry.x[:, :2], dtype=float)
    geo = geometry_dofs(mesh)
    dofs = cell_dofs(V)[: len(geo)]
    bs = V.dofmap.index_map_bs
    values = np.asarray(u.x.array).reshape(-1, bs)
    x[geo.reshape(-1)] = mesh.geometry.x[geo.reshape(-1), :2] + values[dofs.reshape(-1), :2]
    return x


def cell_corners(mesh, x=None, cells=None) -> np.ndarray:
    """(cells, 4, 2) corner coordinates [mm] of the local ``cells`` (default: the owned cells) in
    counter-clockwise reference order (:data:`CCW`), taken from ``x`` ((local geometry nodes, 2 or 3)
    deformed coordinates, indexed like ``mesh.geometry.x``; default ``mesh.geometry.x``)."""
    x = mesh.geometry.x if x is None else np.asarray(x)
    dofs = geometry_dofs(mesh)
    if cells is None:
        cells = np.arange(mesh.topology.index_map(mesh.topology.dim).size_local)
    return x[dofs[np.asarray(cells)][:, CCW]][:, :, :2]


def signed_areas(corners) -> np.ndarray:
    """(cells,) signed areas [mm^2] of the quadrilaterals ``corners`` (cells, 4, 2) (shoelace; > 0
    when counter-clockwise). Exact for the bilinear cell: its edges are straight."""
    c = np.asarray(corners, dtype=float)
    n = np.roll(c, -1, axis=1)
    return 0.5 * np.sum(c[..., 0] * n[..., 1] - n[..., 0] * c[..., 1], axis=1)


def corner_measures(corners, orientation=None):
    """Per-cell measures of quadrilaterals ``corners`` (cells, 4, 2) [mm], listed around each cell:
    returns (scaled Jacobian (cells,) = min over corners, max corner angle (cells,) [deg], aspect ratio
    (cells,)). ``orientation`` (cells,) of +-1: the sense of each reference cell (+1 counter-
    clockwise; default +1 for all): a corner turning against it counts as inverted (negative)."""
    c = np.asarray(corners, dtype=float)
    s = np.ones(len(c)) if orientation is None else np.sign(np.asarray(orientation, dtype=float))
    e1 = np.roll(c, -1, axis=1) - c                 # to the next corner
    e2 = np.roll(c, 1, axis=1) - c                  # to the previous corner
    cross = s[:, None] * (e1[..., 0] * e2[..., 1] - e1[..., 1] * e2[..., 0])
    dot = np.sum(e1 * e2, axis=-1)
    l1 = np.linalg.norm(e1, axis=-1)
    l2 = np.linalg.norm(e2, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        sj = np.where(l1 * l2 > 0, cross / (l1 * l2), -1.0)
    angle = np.degrees(np.arctan2(cross, dot)) % 360.0          # interior angle, 0..360
    angle = np.where(l1 * l2 > 0, angle, 360.0)
    with np.errstate(divide="ignore"):
        aspect = np.where(l1.min(axis=1) > 0, l1.max(axis=1) / l1.min(axis=1), np.inf)
    return sj.min(axis=1), angle.max(axis=1), aspect


def reference_orientation(mesh) -> np.ndarray:
    """(owned cells,) +1 / -1: the sense of each owned cell in ``mesh.geometry.x`` (the reference
    configuration as meshed; Gmsh's and dolfinx's cells are counter-clockwise, +1)."""
    a = signed_areas(cell_corners(mesh))
    return np.where(a < 0, -1.0, 1.0)


def mesh_quality(mesh, x=None, thresholds: Thresholds = Thresholds(), orientation=None) -> Quality:
    """The worst cell measures of ``mesh`` deformed to ``x`` ((local geometry nodes, 2 or 3) [mm],
    indexed like ``mesh.geometry.x``; default: the mesh as it stands) over all ranks, and whether
    ``thresholds`` ask for a new mesh. ``orientation``: (owned cells,) +-1, the sense of each reference
    cell (default: from ``mesh.geometry.x``, :func:`reference_orientation`). Collective."""
    comm = mesh.comm
    corners = cell_corners(mesh, x)
    if orientation is None:
        orientation = reference_orientation(mesh)
    sj, ang, asp = corner_measures(corners, orientation)
    if len(sj):
        i = int(np.argmin(sj))
        local = (float(sj[i]), float(ang.max()), float(asp.max()), tuple(map(float, corners[i].mean(axis=0))))
    else:
        local = (np.inf, -np.inf, -np.inf, (np.nan, np.nan))
    everyone = comm.allgather(local)
    sj_min = min(e[0] for e in everyone)
    point = next(e[3] for e in everyone if e[0] == sj_min)
    ang_max = max(e[1] for e in everyone)
    asp_max = max(e[2] for e in everyone)
    cells = comm.allreduce(len(sj), op=MPI.SUM)
    return judge(sj_min, ang_max, asp_max, point, cells, thresholds)


def judge(sj_min, ang_max, asp_max, point=(np.nan, np.nan), cells=0, thresholds: Thresholds = Thresholds()) -> Quality:
    """The :class:`Quality` of worst values already reduced over the mesh."""
    reasons = []
    if sj_min < thresholds.min_scaled_jacobian:
        reasons.append(f"scaled Jacobian {sj_min:.3g} < {thresholds.min_scaled_jacobian:g}")
    if ang_max > thresholds.max_angle_deg:
        reasons.append(f"corner angle {ang_max:.1f} deg > {thresholds.max_angle_deg:g} deg")
    if thresholds.max_aspect_ratio is not None and asp_max > thresholds.max_aspect_ratio:
        reasons.append(f"aspect ratio {asp_max:.3g} > {thresholds.max_aspect_ratio:g}")
    return Quality(float(sj_min), float(ang_max), float(asp_max), tuple(point), int(cells), bool(reasons),
                   "; ".join(reasons))


def should_remesh(mesh, x=None, thresholds: Thresholds = Thresholds(), orientation=None) -> bool:
    """True on every rank when any cell of ``mesh`` deformed to ``x`` passes a threshold
    (:func:`mesh_quality`). Collective."""
    return mesh_quality(mesh, x, thresholds, orientation).remesh
