"""The outline of a deformed 2-D body, as the geometry of its new mesh (issue 35).

:func:`outline` gathers a deformed quadrilateral dolfinx mesh onto rank 0 and returns its
:class:`Outline`: the boundary of the body (an outer loop and holes for each connected part) and,
when the body has several cell regions, the interfaces between them, as polylines whose segments
are the old facets (their end points exactly the deformed old vertices, mm). Every segment carries
the names of the physical groups (Physical Curve) its old facet belonged to, a facet in several
groups carrying all of them.

The polylines are cut into **curves** at the vertices that must stay points of the new geometry:
where the set of group names (or, on an interface, the pair of regions) changes, where three or
more curves meet (a region boundary reaching the outline), and at corners, where the boundary
turns by more than ``corner_deg`` (default 30 deg). Each curve therefore belongs to whole groups:
a group is a union of whole curves, in the new mesh as in the old. A closed loop without such a
vertex (a hole of one group, smooth) is cut at two of its vertices.

Each cell region (Physical Surface) is described by the loops of curves around it
(:attr:`Outline.surfaces`): the new mesh meshes each region on its own, its interfaces shared, so
every region keeps its old area exactly (with straight segments) and its cells keep the region's
tag: no cell is assigned to a region by where its midpoint falls.

Orientation: loops are counter-clockwise around their region (outer loops of positive signed area,
holes negative), as long as the deformed outline does not cross itself; the cells' senses are taken
from the reference configuration (``mesh.geometry.x``), so a loop is traced consistently even where
a deformed cell has inverted.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..dolfinx_compat import entity_nodes, geometry_dofs
from .quality import CCW, reference_orientation


@dataclass
class Curve:
    """One curve of the new geometry: ``nodes`` (k,) indices into :attr:`Outline.points`, in order
    from one kept vertex to the next (first == last for a closed curve, which :func:`outline` never
    makes); ``names``: the facet groups of all its segments (frozenset, empty on an interface
    that no group names); ``regions``: the region tags on its two sides (one of them -1 on the
    outline)."""
    nodes: np.ndarray
    names: frozenset
    regions: tuple[int, int]


@dataclass
class Outline:
    """The deformed body's boundary and region interfaces (rank 0; an empty one on other ranks).

    ``points`` (n, 2) [mm]: the deformed old vertices on the outline and interfaces; ``segments``
    (m, 2) point indices of the old facets on them; ``segment_names`` (m,) frozensets of their group
    names; ``kept`` (n,) bool: vertices kept as points of the new geometry; ``curves``: the
    :class:`Curve` s; ``surfaces``: one entry per connected part of each region, ``(region tag,
    [loop, ...])`` with the outer loop first and each loop a list of (curve index, +1 / -1: along or
    against the curve's node order); ``facet_groups`` / ``regions``: {name: tag} of the old mesh's
    facet groups and cell regions; ``lost_groups``: facet groups with facets inside a region (not on
    the outline nor an interface) that the new geometry does not carry; ``area`` [mm^2] and
    ``r_moment`` [mm^3] (= integral of x dA, so 2 pi r_moment is the axisymmetric volume) of the old
    deformed cells, for checks; ``cells``: the number of old cells."""
    points: np.ndarray
    segments: np.ndarray
    segment_names: list
    kept: np.ndarray
    curves: list
    surfaces: list
    facet_groups: dict
    regions: dict
    lost_groups: list = field(default_factory=list)
    area: float = 0.0
    r_moment: float = 0.0
    cells: int = 0


def _shoelace(p):
    """Signed area [mm^2] and integral of x dA [mm^3] of the closed polygon(s) p (..., k, 2)."""
    n = np.roll(p, -1, axis=-2)
    cross = p[..., 0] * n[..., 1] - n[..., 0] * p[..., 1]
    area = 0.5 * cross.sum(axis=-1)
    moment = (cross * (p[..., 0] + n[..., 0])).sum(axis=-1) / 6.0
    return area, moment


def gather_mesh(mesh, cell_tags, facet_tags, x=None, group_facets=None, facet_groups=None):
    """The owned part of every rank's mesh, on rank 0 (None elsewhere): a dict with ``cells``
    (N, 4) global node numbers (counter-clockwise in the reference cell), ``orientation`` (N,) +-1,
    ``region`` (N,) cell tags (-1: untagged), ``nodes`` (n,) global node numbers with ``x`` (n, 2)
    their deformed coordinates [mm], ``facets`` (F, 2) global node numbers of the tagged facets with
    ``facet_tag`` (F,). ``x``: (local geometry nodes, 2 or 3) deformed coordinates indexed like
    ``mesh.geometry.x`` (default: ``mesh.geometry.x``). ``group_facets`` ({name: local facet
    indices}, with ``facet_groups`` = {name: tag}) replaces ``facet_tags``: a facet may be in several
    groups (dolfinx's MeshTags hold one value per facet). Collective."""
    comm = mesh.comm
    x = mesh.geometry.x if x is None else np.asarray(x)
    tdim = mesh.topology.dim
    gmap = mesh.geometry.index_map()
    n_nodes = gmap.size_local
    n_cells = mesh.topology.index_map(tdim).size_local
    to_global = gmap.local_to_global
    dofs = geometry_dofs(mesh)[:n_cells][:, CCW]
    cells = to_global(dofs.reshape(-1).astype(np.int32)).reshape(-1, 4) if n_cells else np.zeros((0, 4), np.int64)
    region = np.full(n_cells, -1, dtype=np.int64)
    if cell_tags is not None:
        keep = cell_tags.indices < n_cells
        region[cell_tags.indices[keep]] = cell_tags.values[keep]
    orientation = reference_orientation(mesh)
    nodes = to_global(np.arange(n_nodes, dtype=np.int32)) if n_nodes else np.zeros(0, np.int64)
    mesh.topology.create_connectivity(tdim - 1, tdim)
    n_facets = mesh.topology.index_map(tdim - 1).size_local
    if group_facets is not None:
        f = [np.asarray(v, dtype=np.int32) for v in group_facets.values()]
        tag = [np.full(len(v), facet_groups[n], dtype=np.int64) for n, v in group_facets.items()]
        f = np.concatenate(f) if f else np.zeros(0, np.int32)
        tag = np.concatenate(tag) if tag else np.zeros(0, np.int64)
        keep = f < n_facets
        f, tag = f[keep], tag[keep]
    elif facet_tags is not None and len(facet_tags.indices):
        keep = facet_tags.indices < n_facets
        f, tag = facet_tags.indices[keep], facet_tags.values[keep]
    else:
        f = np.zeros(0, np.int32)
    if len(f):
        fn = entity_nodes(mesh, tdim - 1, f)
        facets = to_global(fn.reshape(-1).astype(np.int32)).reshape(-1, 2)
    else:
        facets, tag = np.zeros((0, 2), np.int64), np.zeros(0, np.int64)
    mine = dict(cells=cells, orientation=orientation, region=region, nodes=nodes,
                x=np.asarray(x[:n_nodes, :2], dtype=float), facets=facets, facet_tag=np.asarray(tag))
    everyone = comm.gather(mine, root=0)
    if comm.rank != 0:
        return None
    return {k: np.concatenate([e[k] for e in everyone]) for k in mine}


def outline(mesh, cell_tags, facet_tags, groups, x=None, corner_deg: float = 30.0, group_facets=None) -> Outline:
    """The :class:`Outline` of ``mesh`` deformed to ``x`` ((local geometry nodes, 2 or 3) [mm],
    indexed like ``mesh.geometry.x``; default: the mesh as it stands), with the physical groups
    ``groups`` = {name: (dim, tag)} (as :func:`fenics_plast.meshing.mesh_from_file` returns them:
    dim 2 regions in ``cell_tags``, dim 1 facet groups in ``facet_tags``). ``corner_deg``: a vertex
    where the boundary turns by more than this [deg] is kept as a point of the new geometry.
    ``group_facets``: {facet group name: local facet indices} in place of ``facet_tags``, for facets in
    several groups (:attr:`fenics_plast.remeshing.new_mesh.Remeshed.group_facets` of a mesh remeshed
    before). Collective; the outline is on rank 0 (other ranks get an empty one)."""
    facet_groups = {n: t for n, (d, t) in groups.items() if d == 1}
    data = gather_mesh(mesh, cell_tags, facet_tags, x, group_facets, facet_groups)
    regions = {n: t for n, (d, t) in groups.items() if d == 2}
    if data is None:
        return Outline(np.zeros((0, 2)), np.zeros((0, 2), int), [], np.zeros(0, bool), [], [], facet_groups, regions)
    return outline_of(data, facet_groups, regions, corner_deg)


def outline_of(data: dict, facet_groups: dict, regions: dict, corner_deg: float = 30.0) -> Outline:
    """:func:`outline` of the gathered mesh ``data`` (:func:`gather_mesh`), on one process."""
    ids, inverse = np.unique(np.concatenate([data["cells"].reshape(-1), data["facets"].reshape(-1)]),
                             return_inverse=True)
    n_c = data["cells"].size
    cells = inverse[:n_c].reshape(-1, 4)
    facets = inverse[n_c:].reshape(-1, 2)
    xyz = np.full((len(ids), 2), np.nan)
    where = np.searchsorted(ids, data["nodes"])
    ok = (where < len(ids)) & (ids[np.minimum(where, len(ids) - 1)] == data["nodes"])
    xyz[where[ok]] = data["x"][ok]
    # number the vertices by their coordinates, not by the partition's global numbers: the same
    # outline (curve order, loop starts, hence the same Gmsh mesh) on any number of ranks
    order = np.lexsort((xyz[:, 1], xyz[:, 0]))
    rank = np.empty(len(order), dtype=np.int64)
    rank[order] = np.arange(len(order))
    cells, facets, xyz = rank[cells], rank[facets], xyz[order]
    flip = data["orientation"] < 0
    cells[flip] = cells[flip][:, ::-1]
    region = data["region"]
    corners = xyz[cells]
    area, moment = _shoelace(corners)

    # directed edges of every cell, counter-clockwise in the reference
    a = cells.reshape(-1)
    b = np.roll(cells, -1, axis=1).reshape(-1)
    er = np.repeat(region, 4)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    key = lo * len(ids) + hi
    order = np.lexsort((er, key))
    key_s, er_s = key[order], er[order]
    # an edge is on a region's boundary when no other cell of the same region has it
    same_prev = np.r_[False, (key_s[1:] == key_s[:-1]) & (er_s[1:] == er_s[:-1])]
    same_next = np.r_[(key_s[1:] == key_s[:-1]) & (er_s[1:] == er_s[:-1]), False]
    boundary = order[~(same_prev | same_next)]          # directed edges bounding their region
    # the skeleton: undirected edges on a region boundary, with the regions on either side
    bkey = key[boundary]
    ukey, first, counts = np.unique(bkey, return_index=True, return_counts=True)
    seg = np.column_stack([lo[boundary][first], hi[boundary][first]])
    side = np.full((len(ukey), 2), -1, dtype=np.int64)
    pos = np.searchsorted(ukey, bkey)
    fill = np.zeros(len(ukey), dtype=int)
    for e, p in zip(boundary, pos):
        if fill[p] < 2:
            side[p, fill[p]] = er[e]
            fill[p] += 1
    side.sort(axis=1)

    # facet group names of each skeleton segment
    tag_name = {t: n for n, t in facet_groups.items()}
    names = [set() for _ in range(len(ukey))]
    lost = set()
    if len(facets):
        fkey = facets.min(axis=1) * len(ids) + facets.max(axis=1)
        fp = np.searchsorted(ukey, fkey)
        on = (fp < len(ukey)) & (ukey[np.minimum(fp, len(ukey) - 1)] == fkey)
        for p, t, o in zip(fp, data["facet_tag"], on):
            name = tag_name.get(int(t))
            if name is None:
                continue
            if o:
                names[p].add(name)
            else:
                lost.add(name)
    seg_names = [frozenset(s) for s in names]
    label = [(n, tuple(s)) for n, s in zip(seg_names, side)]

    # compact the points to those on the skeleton
    used, seg = np.unique(seg, return_inverse=True)
    seg = seg.reshape(-1, 2)
    pts = xyz[used]
    remap = np.full(len(ids), -1)
    remap[used] = np.arange(len(used))
    n = len(pts)

    # vertex -> incident segments
    inc = [[] for _ in range(n)]
    for s, (p, q) in enumerate(seg):
        inc[p].append(s)
        inc[q].append(s)
    kept = np.zeros(n, dtype=bool)
    cos_corner = math.cos(math.radians(corner_deg))
    for v in range(n):
        if len(inc[v]) != 2:
            kept[v] = True
            continue
        s0, s1 = inc[v]
        if label[s0] != label[s1]:
            kept[v] = True
            continue
        u = pts[seg[s0][seg[s0] != v][0]] - pts[v]
        w = pts[seg[s1][seg[s1] != v][0]] - pts[v]
        # turning angle = 180 deg - angle(u, w); turning > corner_deg <=> cos(angle(-u, w)) < cos(corner)
        c = -np.dot(u, w) / (np.linalg.norm(u) * np.linalg.norm(w))
        if c < cos_corner:
            kept[v] = True

    def other(s, v):
        p, q = seg[s]
        return q if p == v else p

    # chains between kept vertices
    curve_of = np.full(len(seg), -1)
    curves = []
    def walk(v, s):
        chain, segs = [v], []
        while True:
            segs.append(s)
            v = other(s, v)
            chain.append(v)
            if kept[v]:
                return chain, segs
            s = inc[v][0] if inc[v][1] == s else inc[v][1]
    for v in np.flatnonzero(kept):
        for s in inc[v]:
            if curve_of[s] < 0:
                chain, segs = walk(v, s)
                curve_of[segs] = len(curves)
                curves.append(Curve(np.array(chain), seg_names[s], tuple(int(r) for r in side[s])))
    for s in range(len(seg)):          # closed loops with no kept vertex: cut at two vertices
        if curve_of[s] >= 0:
            continue
        loop_v, loop_s, v, t = [seg[s][0]], [], seg[s][0], s
        while True:
            loop_s.append(t)
            v = other(t, v)
            if v == loop_v[0]:
                break
            loop_v.append(v)
            t = inc[v][0] if inc[v][1] == t else inc[v][1]
        kept[loop_v[0]] = kept[loop_v[len(loop_v) // 2]] = True
        for start in (loop_v[0], loop_v[len(loop_v) // 2]):
            for t in inc[start]:
                if curve_of[t] < 0:
                    chain, segs = walk(start, t)
                    curve_of[segs] = len(curves)
                    curves.append(Curve(np.array(chain), seg_names[t], tuple(int(r) for r in side[t])))

    # directed edge (p, q) -> (curve, sign); the curve is entered at its first or last node
    start_of = {}
    for ci, c in enumerate(curves):
        start_of[(c.nodes[0], c.nodes[1])] = (ci, 1)
        start_of[(c.nodes[-1], c.nodes[-2])] = (ci, -1)
    # loops around each region, from its directed boundary edges
    surfaces = []
    for r in np.unique(region):
        mine = boundary[er[boundary] == r]
        out = {}
        for e in mine:
            out.setdefault(remap[a[e]], []).append(remap[b[e]])
        for v in out:
            out[v].sort(reverse=True)
        loops = []
        while out:
            v0 = min(v for v in out if kept[v])
            loop, v = [], v0
            while True:
                nxt = out[v].pop()
                if not out[v]:
                    del out[v]
                ci, sign = start_of[(v, nxt)]
                loop.append((ci, sign))
                c = curves[ci].nodes
                v = c[-1] if sign > 0 else c[0]
                # walk the rest of the curve's directed edges off the table
                path = c if sign > 0 else c[::-1]
                for p, q in zip(path[1:-1], path[2:]):
                    out[p].remove(q)
                    if not out[p]:
                        del out[p]
                if v == v0:
                    break
            loops.append(loop)
        polys = [_loop_points(curves, lp) for lp in loops]
        signed = [float(_shoelace(pts[p])[0]) for p in polys]
        outer = [i for i, s in enumerate(signed) if s > 0]
        holes = [i for i, s in enumerate(signed) if s <= 0]
        parts = {i: [loops[i]] for i in outer}
        for h in holes:
            probe = pts[polys[h][0]] * 0.5 + pts[polys[h][1]] * 0.5
            inside = [i for i in outer if _inside(pts[polys[i]], probe)]
            host = min(inside, key=lambda i: signed[i]) if inside else max(outer, key=lambda i: signed[i])
            parts[host].append(loops[h])
        for i in sorted(parts, key=lambda i: -signed[i]):
            surfaces.append((int(r), parts[i]))
    return Outline(points=pts, segments=seg, segment_names=seg_names, kept=kept, curves=curves, surfaces=surfaces,
                   facet_groups=dict(facet_groups), regions=dict(regions), lost_groups=sorted(lost),
                   area=float(area.sum()), r_moment=float(moment.sum()), cells=len(cells))


def _loop_points(curves, loop):
    """Point indices around a loop of (curve, sign), each point once."""
    out = []
    for ci, sign in loop:
        c = curves[ci].nodes if sign > 0 else curves[ci].nodes[::-1]
        out.extend(c[:-1])
    return np.array(out)


def _inside(poly, p) -> bool:
    """Whether point p (2,) lies inside the closed polygon ``poly`` (k, 2) (even-odd rule)."""
    x, y = poly[:, 0], poly[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    crosses = ((y > p[1]) != (yn > p[1]))
    with np.errstate(divide="ignore", invalid="ignore"):
        xs = x + (p[1] - y) * (xn - x) / (yn - y)
    return bool(np.count_nonzero(crosses & (p[0] < xs)) % 2)


def group_lengths(out: Outline) -> dict:
    """{facet group name: total length [mm] of its segments in the outline} (rank 0)."""
    lengths = {}
    d = np.linalg.norm(out.points[out.segments[:, 1]] - out.points[out.segments[:, 0]], axis=1) if len(out.segments) else []
    for length, names in zip(d, out.segment_names):
        for name in names:
            lengths[name] = lengths.get(name, 0.0) + float(length)
    return lengths


def crossings(out: Outline, block: int = 512) -> np.ndarray:
    """(k, 2) pairs of segments of ``out`` that cross or touch without sharing an end point: a fold
    that has closed onto the body, a side pushed through another; such an outline cannot be meshed.
    O(m^2) in blocks of ``block`` rows (m segments; 0.2 s for m = 4000, measured)."""
    p = out.points[out.segments[:, 0]]
    q = out.points[out.segments[:, 1]]
    lo, hi = np.minimum(p, q), np.maximum(p, q)
    m = len(p)
    found = []

    def orient(a, b, c):
        return np.sign((b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1]) - (b[..., 1] - a[..., 1]) * (c[..., 0] - a[..., 0]))
    for start in range(0, m, block):
        rows = np.arange(start, min(start + block, m))
        overlap = ((lo[rows, None, 0] <= hi[None, :, 0]) & (lo[None, :, 0] <= hi[rows, None, 0])
                   & (lo[rows, None, 1] <= hi[None, :, 1]) & (lo[None, :, 1] <= hi[rows, None, 1]))
        overlap &= rows[:, None] < np.arange(m)[None, :]
        i, j = np.nonzero(overlap)
        i = rows[i]
        si, sj = out.segments[i], out.segments[j]
        shared = (si[:, :1] == sj).any(axis=1) | (si[:, 1:] == sj).any(axis=1)
        i, j = i[~shared], j[~shared]
        o1, o2 = orient(p[i], q[i], p[j]), orient(p[i], q[i], q[j])
        o3, o4 = orient(p[j], q[j], p[i]), orient(p[j], q[j], q[i])
        hit = (o1 * o2 <= 0) & (o3 * o4 <= 0)
        found.append(np.column_stack([i[hit], j[hit]]))
    return np.concatenate(found) if found else np.zeros((0, 2), dtype=int)
