"""A new quadrilateral mesh of a deformed body's outline, with its groups and regions (issue 35).

:func:`mesh_outline` meshes an :class:`~fenics_plast.remeshing.outline.Outline` in Gmsh (rank 0)
and distributes it with ``dolfinx.io.gmshio.model_to_mesh``; :func:`remesh` does both steps from a
deformed dolfinx mesh. The result unpacks like :func:`fenics_plast.meshing.mesh_from_file`:
``mesh, cell_tags, facet_tags, groups = remesh(...)``, groups = {name: (dim, tag)} with the OLD
tags (a scene's groups and regions keep their numbers), so the rest of the package uses it
unchanged.

Decisions, measured in tests/test_remesh_mesh.py:

* **Straight lines** (default, ``curves="lines"``): every old boundary facet is a Gmsh line (old
  facets in a straight row, to 1e-12 of their length squared, merged into one line, which Gmsh may
  then divide at its own size): the new outline is the old deformed polygon itself, so the area, the
  axisymmetric volume 2 pi int r dA, every group's length and every region's area are kept to
  round-off (measured on a bent and a folded round bar: 1e-16 and 3e-14 area, 2e-16 and 6e-14
  volume, 3e-16 lengths, relative). The price: on curved parts the boundary is never coarser than
  the old facets. ``curves="splines"`` puts one Gmsh spline (through the old vertices) on each curve
  between kept vertices: a smoother boundary, meshed at the new size, which moves the body (bent
  bar, 10 x 40 old cells: area 4.0e-5, volume 8.2e-5, group lengths 6.4e-6 relative): a
  spline outline changes the volume at each remesh, so it is not the default.
* **Groups**: each curve of the outline is in exactly one Gmsh physical group (its own), so every
  new facet has one value in ``facet_tags``: the tag of its group, or where a curve is in several
  groups the smallest of their tags. All facets of every group, those shared too, are in
  :attr:`Remeshed.group_facets` ({name: local facet indices}); with no facet in two groups (what
  :func:`fenics_plast.meshing.mesh_from_file` requires of the groups a scene uses),
  ``group_facets[name]`` equals ``facet_tags.find(groups[name][1])``.
* **Regions**: each region is meshed as its own plane surface(s), bounded by the outline and the
  interfaces with the other regions (shared curves, conforming nodes): a new cell lies in one old
  region by construction and each region's area is kept.
* **All quadrilaterals**: Frontal-Delaunay triangles (Mesh.Algorithm 6) recombined by Gmsh's
  Blossom full-quad algorithm (Mesh.RecombinationAlgorithm 3), which leaves no triangle. Measured on
  the folded-corner case of tests/test_remesh_mesh.py: min scaled Jacobian 0.65..0.71 with it, against
  0.17..0.42 for plain Blossom (1), which left 2 triangles even on boundaries of an even number of
  edges (then made even, :func:`_even_boundaries`) and needed subdivision. Should a triangle remain,
  the surface is meshed again at twice the size with Mesh.SubdivisionAlgorithm 1 (every cell split
  into quadrilaterals); anything but linear quadrilaterals then is a :class:`RemeshError`.
  Frontal-Delaunay for quads (Mesh.Algorithm 8) is an option (``algorithm=8``), not the default:
  Debian 12's Gmsh 4.8.4 dies of a segmentation fault in it on any surface (measured on a plain
  rectangle), taking the MPI job with it.
* **Cost** (benchmarks/bench_remesh_mesh.py, one rank, 2-core machine): old 1e3 cells -> 1.7e3 new
  in 0.2 s (outline 0.01 s, Gmsh 0.15 s, model_to_mesh 0.04 s); 1e4 -> 1.3e4 in 1.9 s, Gmsh 1.7 s of
  it (splines: 1.2 s). Gmsh runs on rank 0 only, the other ranks wait.
* **Sizes**: ``h`` [mm] everywhere (Mesh.MeshSizeMax), ``h_min`` within ``radius`` of each of the
  ``refine_points`` (tool edges, contact), growing linearly to ``h`` over a further ``2 radius``
  (Gmsh Threshold field on a MathEval distance to the nearest point, as the background field;
  measured: cells within 0.5 mm of the point 0.090 mm for h_min 0.1, 0.40 mm beyond 2 mm for h 0.5).
  No Distance field: its geometric points leave lone mesh nodes, on which dolfinx 0.5.2's
  model_to_mesh dies (segmentation fault); the mesh is also copied into a model of the used nodes
  only before it is distributed (:func:`_compact_model`, for the splines' control points).
"""
from __future__ import annotations

import contextlib
import ctypes
import os
import sys
import time

import gmsh
import numpy as np
from dolfinx.io import gmshio
from dolfinx.mesh import meshtags

from ..gmsh_session import gmsh_session
from .outline import Outline, crossings, outline

_QUAD = 3                       # Gmsh's 4-node quadrilateral
_COLLINEAR = 1e-12              # |cross| / |chord|^2 below which an old vertex is on the line of its neighbours


class RemeshError(RuntimeError):
    """Gmsh cannot mesh the outline, or meshes it with cells other than quadrilaterals."""


class Remeshed(tuple):
    """``(mesh, cell_tags, facet_tags, groups)`` (like :func:`fenics_plast.meshing.mesh_from_file`)
    with two attributes: ``group_facets`` = {facet group name: (k,) int32 local facet indices, every
    facet of the group (owned and ghost), also those in several groups}; ``info`` = {"cells": number
    of cells (all ranks), "curves": Gmsh curves, "subdivided": whether subdivision was needed,
    "gmsh_s": time in Gmsh [s], "distribute_s": time in model_to_mesh [s], "area_outline" [mm^2]}; after
    :func:`mesh_outline` or :func:`mesh_from_record`, ``record`` (rank 0; None elsewhere): the mesh as plain
    lists (nodes, element blocks, the curves' groups, the groups' and regions' tags), what
    :func:`mesh_from_record` makes it again from (a checkpoint of a remeshed run)."""

    def __new__(cls, mesh, cell_tags, facet_tags, groups, group_facets, info):
        self = super().__new__(cls, (mesh, cell_tags, facet_tags, groups))
        self.group_facets = group_facets
        self.info = info
        return self


def _drop_collinear(pts, chain):
    """The nodes of ``chain`` without those on the straight line between their kept neighbours."""
    keep = [chain[0]]
    for i in range(1, len(chain) - 1):
        a, b, c = pts[keep[-1]], pts[chain[i]], pts[chain[i + 1]]
        d = c - a
        cross = d[0] * (b[1] - a[1]) - d[1] * (b[0] - a[0])
        ahead = np.dot(b - a, d) > 0 and np.dot(c - b, d) > 0
        if not (ahead and abs(cross) <= _COLLINEAR * np.dot(d, d)):
            keep.append(chain[i])
    keep.append(chain[-1])
    return keep


def _drop_short(pts, chain, min_edge):
    """The nodes of ``chain`` without those nearer than ``min_edge`` [mm] to the last kept node or to the
    chain's end (which are kept): no boundary edge of the new mesh shorter than ``min_edge`` but where a
    whole curve is."""
    if not min_edge or len(chain) <= 2:
        return chain
    end = pts[chain[-1]]
    keep = [chain[0]]
    for i in chain[1:-1]:
        if np.linalg.norm(pts[i] - pts[keep[-1]]) >= min_edge and np.linalg.norm(end - pts[i]) >= min_edge:
            keep.append(i)
    keep.append(chain[-1])
    return keep


#: a segment is refitted to its tool where it cuts in deeper than this times its length below its ends
FIT_TOLERANCE = 0.02


def fitted_chain(xy, gap, depth: int = 6, samples: int = 9):
    """The polyline ``xy`` (k, 2) [mm] with points added where a segment cuts into a rigid tool deeper
    than its ends (a chord across a rounded tool edge, whose new nodes would start far inside the tool):
    at a segment's deepest sample the point moved along the tool's normal to the level of its shallower
    end (or onto the surface when both ends are apart), then the two halves the same way, ``depth``
    times at most. ``gap(x (n, 2)) -> (g (n,), N (n, 2))``: the tool's signed gap [mm] (negative inside)
    and unit normal (the direction g grows)."""
    out = [np.asarray(xy[0], dtype=float)]

    def split(a, b, ga, gb, level):
        s = np.linspace(0.0, 1.0, samples)[1:-1, None]
        pts = a + s * (b - a)
        g, N = gap(pts)
        target = min(min(ga, gb), 0.0)
        k = int(np.argmin(g))
        if level == 0 or g[k] >= target - FIT_TOLERANCE * np.linalg.norm(b - a):
            out.append(b)
            return
        q = pts[k] + (target - g[k]) * N[k]
        gq = float(gap(q[None, :])[0][0])
        split(a, q, ga, gq, level - 1)
        split(q, b, gq, gb, level - 1)

    g_all = gap(np.asarray(xy, dtype=float))[0]
    for i in range(len(xy) - 1):
        split(np.asarray(xy[i], dtype=float), np.asarray(xy[i + 1], dtype=float), float(g_all[i]),
              float(g_all[i + 1]), depth)
    return np.array(out)


def _set_field_number(field, names, value):
    """Set the first of ``names`` the Gmsh version knows (e.g. SizeMin, LcMin) on ``field``."""
    for n in names:
        try:
            gmsh.model.mesh.field.setNumber(field, n, value)
            return
        except Exception:      # noqa: BLE001 - gmsh raises plain Exception on an unknown option
            continue
    raise RemeshError(f"Gmsh knows none of the field options {names}")


def _size_fields(h, h_min, radius, refine_points):
    """The background size: ``h`` [mm], ``h_min`` within ``radius`` of each point, rising linearly to
    ``h`` at 3 ``radius``."""
    gmsh.option.setNumber("Mesh.MeshSizeMax", h)
    gmsh.option.setNumber("Mesh.MeshSizeMin", 0.0)
    for opt in ("Mesh.MeshSizeFromPoints", "Mesh.MeshSizeFromCurvature", "Mesh.MeshSizeExtendFromBoundary"):
        gmsh.option.setNumber(opt, 0)
    points = np.asarray(refine_points, dtype=float).reshape(-1, 2)
    if not len(points) or h_min is None or h_min >= h:
        return
    # the distance to the nearest point, as a MathEval field (a Distance field needs geometric points,
    # whose lone mesh nodes dolfinx 0.5.2's model_to_mesh dies on: segmentation fault, measured)
    dist = gmsh.model.mesh.field.add("MathEval")
    terms = [f"Sqrt((x-({x!r}))^2+(y-({y!r}))^2)" for x, y in points.tolist()]
    formula = terms[0]
    for t in terms[1:]:
        formula = f"Min({formula},{t})"
    gmsh.model.mesh.field.setString(dist, "F", formula)
    thr = gmsh.model.mesh.field.add("Threshold")
    gmsh.model.mesh.field.setNumber(thr, "InField", dist)   # (IField in Gmsh < 4.9: InField is also known)
    _set_field_number(thr, ("SizeMin", "LcMin"), h_min)
    _set_field_number(thr, ("SizeMax", "LcMax"), h)
    gmsh.model.mesh.field.setNumber(thr, "DistMin", radius)
    gmsh.model.mesh.field.setNumber(thr, "DistMax", 3 * radius)
    gmsh.model.mesh.field.setAsBackgroundMesh(thr)


def _build(out: Outline, curves: str, min_edge: float | None = None, fits=None):
    """The outline as Gmsh geo entities (rank 0): returns ({curve index: Gmsh curve tags}, {region tag:
    [surface tags]}); ``min_edge`` [mm]: lines drop the old vertices nearer than that to the last kept
    one (:func:`_drop_short`); ``fits``: {facet group: gap function}, the lines of a curve in that group
    fitted to the tool (:func:`fitted_chain`)."""
    g = gmsh.model.geo
    pts = out.points
    point_tag = {}

    def point(i):
        if i not in point_tag:
            point_tag[i] = g.addPoint(float(pts[i, 0]), float(pts[i, 1]), 0.0)
        return point_tag[i]
    entities = {}
    for ci, c in enumerate(out.curves):
        nodes = list(c.nodes)
        if curves == "splines" and len(nodes) > 2:
            entities[ci] = [g.addSpline([point(i) for i in nodes])]
        else:
            nodes = _drop_short(pts, _drop_collinear(pts, nodes), min_edge)
            gap = next((fits[n] for n in sorted(c.names) if fits and n in fits), None)
            tags = [point(i) for i in nodes]
            if gap is not None:
                xy = fitted_chain(pts[nodes], gap)
                xy = xy[_drop_short(xy, list(range(len(xy))), min_edge)]
                inner = [g.addPoint(float(p[0]), float(p[1]), 0.0) for p in xy[1:-1]]
                tags = [tags[0]] + inner + [tags[-1]] if len(xy) != len(nodes) else tags
            entities[ci] = [g.addLine(p, q) for p, q in zip(tags[:-1], tags[1:])]
    surfaces = {}
    for region, loops in out.surfaces:
        loop_tags = []
        for loop in loops:
            tags = []
            for ci, sign in loop:
                tags += entities[ci] if sign > 0 else [-t for t in reversed(entities[ci])]
            loop_tags.append(g.addCurveLoop(tags))
        surfaces.setdefault(region, []).append(g.addPlaneSurface(loop_tags))
    g.synchronize()
    return entities, surfaces


@contextlib.contextmanager
def _quiet_stdout():
    """File descriptor 1 sent to /dev/null meanwhile: Gmsh's Blossom code prints "WARNING:
    shrinks.length==shrinks_max=..." with printf on large surfaces, past General.Terminal = 0."""
    libc = ctypes.CDLL(None)
    try:
        saved = os.dup(1)
    except OSError:                     # no stdout to silence
        yield
        return
    try:
        sys.stdout.flush()
        libc.fflush(None)
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
        yield
    finally:
        libc.fflush(None)
        os.dup2(saved, 1)
        os.close(saved)


def _even_boundaries(algorithm_passes: int = 4):
    """Give every surface an even number of boundary edges (rank 0, after ``generate(1)``): a
    recombination can make all-quadrilateral only a surface whose boundary has an even number of
    edges. Where a surface's count is odd, its longest line with more room (on the outline before an
    interface, which two surfaces share) gets one more edge (transfinite), and the lines are meshed again."""
    for _ in range(algorithm_passes):
        odd = []
        edges = {}
        for _, s in gmsh.model.getEntities(2):
            count = 0
            for _, c in gmsh.model.getBoundary([(2, s)], oriented=False, combined=False):
                c = abs(c)
                if c not in edges:
                    edges[c] = sum(len(e) for e in gmsh.model.mesh.getElements(1, c)[1])
                count += edges[c]
            if count % 2:
                odd.append(s)
        if not odd:
            return True
        shared = {}
        for _, s in gmsh.model.getEntities(2):
            for _, c in gmsh.model.getBoundary([(2, s)], oriented=False, combined=False):
                shared[abs(c)] = shared.get(abs(c), 0) + 1
        for s in odd:
            curves = [abs(c) for _, c in gmsh.model.getBoundary([(2, s)], oriented=False, combined=False)]

            def length(c):
                b = gmsh.model.getBoundary([(1, c)], oriented=False)
                p = [np.array(gmsh.model.getValue(0, abs(t), [])) for _, t in b]
                return np.linalg.norm(p[1] - p[0]) / (edges[c] + 1) if len(p) == 2 else 0.0
            c = max(curves, key=lambda c: (shared[c] == 1, length(c)))
            gmsh.model.mesh.setTransfiniteCurve(c, edges[c] + 2)
        gmsh.model.mesh.clear()
        gmsh.model.mesh.generate(1)
    return False


def _generate(subdivide: bool, algorithm: int, recombination: int, smoothing: int):
    """Mesh the surfaces (rank 0): returns the number of 2-D cells that are not quadrilaterals."""
    gmsh.option.setNumber("Mesh.Algorithm", algorithm)
    gmsh.option.setNumber("Mesh.RecombineAll", 1)
    gmsh.option.setNumber("Mesh.RecombinationAlgorithm", recombination)
    gmsh.option.setNumber("Mesh.Smoothing", smoothing)
    gmsh.option.setNumber("Mesh.SubdivisionAlgorithm", 1 if subdivide else 0)
    gmsh.option.setNumber("Mesh.MeshSizeFactor", 2.0 if subdivide else 1.0)
    gmsh.model.mesh.clear()
    gmsh.model.mesh.generate(1)
    if not subdivide and recombination in (0, 1):
        _even_boundaries()
    with _quiet_stdout():
        gmsh.model.mesh.generate(2)
    others = 0
    for _, e in gmsh.model.getEntities(2):
        for t, els in zip(*gmsh.model.mesh.getElements(2, e)[:2]):
            if t != _QUAD:
                others += len(els)
    return others


def _compact_model(name, curve_groups, surface_groups):
    """Copy the mesh of the physical groups into a new discrete Gmsh model holding only the nodes their
    elements use, and make it current (rank 0). dolfinx 0.5.2's ``model_to_mesh`` dies (segmentation
    fault, measured) on a node that no cell uses, such as those Gmsh puts on the control points of a
    spline. ``curve_groups`` / ``surface_groups``: {physical tag: [entity tags]}."""
    node_tags, coords, _ = gmsh.model.mesh.getNodes()
    xyz = np.asarray(coords).reshape(-1, 3)
    index = {int(t): i for i, t in enumerate(node_tags)}
    blocks = []
    for dim, group in ((2, surface_groups), (1, curve_groups)):
        for tag, ents in group.items():
            for e in ents:
                types, _, nodes = gmsh.model.mesh.getElements(dim, e)
                for t, nd in zip(types, nodes):
                    blocks.append((dim, tag, int(t), np.asarray(nd, dtype=np.int64)))
    used = np.unique(np.concatenate([b[3] for b in blocks]))
    rows = np.array([index[int(u)] for u in used])
    record = dict(nodes=xyz[rows, :2].tolist(),
                  blocks=[(dim, tag, t, (np.searchsorted(used, nd) + 1).tolist()) for dim, tag, t, nd in blocks])
    _add_model(name + "-compact", record)
    return record


def _add_model(name, record):
    """A discrete Gmsh model ``name`` (made current, rank 0) of a mesh ``record``: ``nodes`` (n, 2) [mm]
    numbered 1..n as model_to_mesh requires, ``blocks`` [(dim, physical tag, Gmsh element type, node
    numbers)], each block one discrete entity in its physical group."""
    gmsh.model.add(name)
    xyz = np.zeros((len(record["nodes"]), 3))
    xyz[:, :2] = np.asarray(record["nodes"], dtype=float).reshape(-1, 2)
    members: dict = {}
    for new_tag, (dim, tag, t, nd) in enumerate(record["blocks"], start=1):
        gmsh.model.addDiscreteEntity(int(dim), new_tag)
        if new_tag == 1:
            gmsh.model.mesh.addNodes(int(dim), 1, list(range(1, len(xyz) + 1)), xyz.reshape(-1).tolist())
        gmsh.model.mesh.addElementsByType(new_tag, int(t), [], [int(v) for v in nd])
        members.setdefault((int(dim), int(tag)), []).append(new_tag)
    for (dim, tag), ents in members.items():
        gmsh.model.addPhysicalGroup(dim, ents, tag)


def mesh_outline(comm, out: Outline, h: float, h_min: float | None = None, refine_points=(),
                 radius: float | None = None, curves: str = "lines", recombination: int = 3,
                 smoothing: int = 5, algorithm: int = 6, name: str = "remeshed", min_edge: float | None = None,
                 fits=None) -> Remeshed:
    """A quadrilateral mesh of the outline ``out`` (built on rank 0; other ranks pass an empty one):
    size ``h`` [mm], ``h_min`` [mm] within ``radius`` [mm] (default 2 ``h``) of each of
    ``refine_points`` ((k, 2) [mm], e.g. tool edges), lines or splines (``curves``, see the module),
    Gmsh's Mesh.Algorithm ``algorithm`` (6: Frontal-Delaunay) recombined by Mesh.RecombinationAlgorithm
    ``recombination`` (3: Blossom full-quad), ``smoothing`` Laplacian passes; ``min_edge`` [mm]: old
    boundary vertices nearer than that to their kept neighbour are dropped (lines only; None: every old
    vertex is kept, and the area with it, to round-off); ``fits`` {facet group: gap function}: the lines
    of those groups refitted to their tool (:func:`fitted_chain`). An outline that crosses
    or touches itself (:func:`~fenics_plast.remeshing.outline.crossings`) is refused. Returns
    :class:`Remeshed` (unpacks as ``mesh, cell_tags, facet_tags, groups``), distributed from rank 0.
    Collective; RemeshError on every rank when the outline is refused or Gmsh fails."""
    if curves not in ("lines", "splines"):
        raise ValueError(f"curves must be 'lines' or 'splines', got {curves!r}")
    radius = 2.0 * h if radius is None else radius
    error, chain_names, info, record = None, {}, {}, None
    t0 = time.perf_counter()
    with gmsh_session(log=True):
        gmsh.model.add(name)
        if comm.rank == 0:
            try:
                bad = crossings(out)
                if len(bad):
                    where = out.points[out.segments[bad[0]]].mean(axis=(0, 1))
                    raise RemeshError(f"the deformed outline crosses or touches itself ({len(bad)} pair(s) of "
                                      f"boundary facets, the first near x = {where[0]:.4g}, y = {where[1]:.4g} mm): "
                                      f"a fold has closed onto the body; remesh earlier")
                entities, surfaces = _build(out, curves, min_edge, fits)
                _size_fields(h, h_min, radius, refine_points)
                subdivided = False
                if _generate(False, algorithm, recombination, smoothing):
                    subdivided = True
                    if _generate(True, algorithm, recombination, smoothing):
                        raise RemeshError("Gmsh left cells other than quadrilaterals after subdivision")
                curve_groups = {}
                for ci, c in enumerate(out.curves):
                    if c.names:
                        curve_groups[ci + 1] = entities[ci]
                        chain_names[ci + 1] = sorted(c.names)
                record = _compact_model(name, curve_groups, {int(r): t for r, t in surfaces.items()})
                info = dict(curves=sum(len(v) for v in entities.values()), subdivided=subdivided)
                record.update(chain_names={int(k): v for k, v in chain_names.items()}, facet_groups=out.facet_groups,
                              regions=out.regions)
            except RemeshError as e:
                error = str(e)
            except Exception as e:      # noqa: BLE001 - gmsh raises plain Exception
                log = [m for m in gmsh.logger.get() if "rror" in m]
                error = f"Gmsh cannot mesh the outline: {(log[-1] if log else str(e)).strip()}"
        error, chain_names, info = comm.bcast((error, chain_names, info), root=0)
        if error is not None:
            raise RemeshError(error)
        remeshed = _distributed(comm, name, out.facet_groups, out.regions, chain_names, info, t0)
    remeshed.info.update(area_outline=comm.bcast(out.area, root=0))
    remeshed.record = record if comm.rank == 0 else None
    return remeshed


def mesh_from_record(comm, record, name: str = "remeshed") -> Remeshed:
    """The mesh a :func:`mesh_outline` made, again, from its ``record`` (:attr:`Remeshed.record`, rank 0's;
    the other ranks may pass None): the same nodes, cells, groups and, on as many ranks, the same
    distribution, so that a checkpoint's values keyed by input node and cell index find their places
    (a resumed run on a remeshed body). Collective."""
    t0 = time.perf_counter()
    record = comm.bcast(record if comm.rank == 0 else None, root=0)
    chain_names = {int(k): v for k, v in record["chain_names"].items()}
    with gmsh_session(log=True):
        gmsh.model.add(name)
        if comm.rank == 0:
            _add_model(name + "-compact", record)
        remeshed = _distributed(comm, name, record["facet_groups"], record["regions"], chain_names, {}, t0)
    remeshed.record = record if comm.rank == 0 else None
    return remeshed


def _distributed(comm, name, facet_groups, regions, chain_names, info, t0) -> Remeshed:
    """The current Gmsh model (rank 0) as a distributed dolfinx mesh with :func:`mesh_outline`'s tags and
    groups (``chain_names``: {physical curve tag: its facet groups}). Collective, inside the Gmsh session."""
    t1 = time.perf_counter()
    mesh, cell_tags, ft = gmshio.model_to_mesh(gmsh.model, comm, 0, gdim=2)
    t2 = time.perf_counter()
    mesh.name = name
    cell_tags.name = "cell_tags"
    groups = {n: (1, int(t)) for n, t in facet_groups.items()}
    groups.update({n: (2, int(t)) for n, t in regions.items()})
    group_facets, primary = {}, {}
    for chain, names in chain_names.items():
        primary[chain] = min(facet_groups[n] for n in names)
    indices = np.asarray(ft.indices, dtype=np.int32)
    values = np.asarray(ft.values)
    for n in facet_groups:
        chains = [c for c, names in chain_names.items() if n in names]
        group_facets[n] = indices[np.isin(values, chains)]
    new_values = np.array([primary[int(v)] for v in values], dtype=np.int32)
    facet_tags = meshtags(mesh, 1, indices, new_values)
    facet_tags.name = "facet_tags"
    cells = comm.allreduce(mesh.topology.index_map(2).size_local)
    info = dict(info, cells=cells, gmsh_s=t1 - t0, distribute_s=t2 - t1)
    return Remeshed(mesh, cell_tags, facet_tags, groups, group_facets, info)


def remesh(mesh, cell_tags, facet_tags, groups, h: float, x=None, corner_deg: float = 30.0, group_facets=None,
           **options) -> Remeshed:
    """A new mesh of ``mesh`` deformed to ``x`` ((local geometry nodes, 2 or 3) deformed coordinates
    [mm] indexed like ``mesh.geometry.x``; default the mesh as it stands) with its ``cell_tags``,
    ``facet_tags`` and ``groups`` ({name: (dim, tag)}): :func:`~fenics_plast.remeshing.outline.outline`
    then :func:`mesh_outline` (``h`` [mm] and ``options`` passed on). ``group_facets``: {name: local
    facet indices} in place of ``facet_tags`` where facets are in several groups (a :class:`Remeshed`'s
    own). Collective."""
    out = outline(mesh, cell_tags, facet_tags, groups, x=x, corner_deg=corner_deg, group_facets=group_facets)
    return mesh_outline(mesh.comm, out, h, **options)
