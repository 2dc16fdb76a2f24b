"""Signed gaps of points to a faceted surface: line segments in 2-D, triangles in 3-D, compiled.

The master surface of node-to-surface contact when it is a mesh (a meshed rigid tool today; the boundary of
a deformable body is the same data at its current positions). :func:`build_surface` takes the vertices
(nv, dim) [mm] and the facets (nf, dim) (vertex indices, 2 per segment, 3 per triangle), orients the
facets coherently across shared edges (vertices in 2-D) and returns a :class:`FacetSurface`: unit facet
normals, the pseudo-normals of its edges and vertices, and a bounding-volume hierarchy over the facets.
:func:`surface_gaps` gives, for points x (n, dim) and a translation of the surface d (dim,) [mm], the
signed distance g to the nearest point q of the surface and the unit normal N pointing to the point's
side; the body's side is where the normals point (``flip=True`` turns them).

Sign (Baerentzen and Aanaes, "Signed distance computation using the angle weighted pseudonormal", 2005):
the sign of (x - q) . n_q, n_q the normal of the feature that holds q: the facet's own normal inside a
facet, the sum of the adjacent facets' normals on an edge (3-D), and at a vertex the facets' normals
weighted by the facet's angle there (3-D) or summed (2-D). The sign is then right on either side of
convex and concave edges and corners alike. N = sign (x - q) / |x - q| (the facet's normal inside a facet,
continuous where q moves onto an edge or corner); n_q where x lies on the surface.

Search: a bounding-volume hierarchy (axis-aligned boxes; each node split at the median of its facets'
centres along its longest side, leaves of at most :data:`LEAF_SIZE` facets). A point walks it depth
first, the nearer child first, and skips a box farther than the nearest facet found so far: about log2(nf)
boxes and a few leaves per point, near the surface or far from it. Beyond ``reach`` [mm] the search stops
and reports g = reach, N = 0 (no contact). ``tests/test_surface_gaps.py`` holds it to a search over all
facets.

Units mm. The gaps of the analytic tool shapes are :mod:`fenics_plast.solvers.tool_gaps`.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

from fenics_plast.solvers.tool_gaps import FLAGS

_njit = numba.njit(cache=True, **FLAGS)

#: most facets in a leaf of the bounding-volume hierarchy
LEAF_SIZE = 4


class FacetSurface(NamedTuple):
    """A faceted surface ready for :func:`surface_gaps` (``dim`` = 2: segments, 3: triangles)."""
    vertices: np.ndarray        # (nv, dim) [mm], reference positions
    facets: np.ndarray          # (nf, dim) vertex indices, coherently oriented
    normals: np.ndarray         # (nf, dim) unit facet normals (the body's side)
    facet_edges: np.ndarray     # (nf, 3) edge index of edge k (vertices k, k+1 mod 3) of a triangle; (nf, 0) in 2-D
    edge_normals: np.ndarray    # (ne, dim) edge pseudo-normals (3-D; (0, 2) in 2-D)
    vertex_normals: np.ndarray  # (nv, dim) vertex pseudo-normals
    box_lo: np.ndarray          # (nb, dim) lower corners of the hierarchy's boxes [mm] (box 0: the root)
    box_hi: np.ndarray          # (nb, dim) upper corners [mm]
    children: np.ndarray        # (nb, 2) the two child boxes of an inner box; -1 for a leaf
    leaf: np.ndarray            # (nb, 2) a leaf's facets: order[leaf[b, 0]:leaf[b, 1]]
    order: np.ndarray           # (nf,) facet indices, each leaf's contiguous
    open_vertices: np.ndarray   # (nv,) 1 at a vertex on the surface's open boundary (2-D: of one segment)
    open_edges: np.ndarray      # (nf, 3) 1 at an edge of one triangle (3-D; (nf, 0) in 2-D)


def _orient(facets: np.ndarray, dim: int) -> np.ndarray:
    """The facets with their vertex order turned where needed so that neighbours agree: a shared vertex (2-D)
    is the end of one segment and the start of the other; a shared edge (3-D) is walked in opposite senses.
    The first facet of each connected piece keeps its order. ValueError where no orientation exists
    (a vertex of three segments, an edge of three triangles, a Moebius-like strip)."""
    facets = facets.copy()
    nf = len(facets)
    sides = [(k, (k + 1) % dim) for k in range(dim)] if dim == 3 else [(0, 1)]
    owners: dict = {}
    for f in range(nf):
        keys = [int(facets[f, 0]), int(facets[f, 1])] if dim == 2 else \
            [tuple(sorted((int(facets[f, a]), int(facets[f, b])))) for a, b in sides]
        for key in keys:
            owners.setdefault(key, []).append(f)
    if any(len(v) > 2 for v in owners.values()):
        raise ValueError("the surface branches: a " + ("vertex is shared by three segments or more" if dim == 2
                         else "an edge is shared by three triangles or more"))
    neighbours = [[] for _ in range(nf)]
    for v in owners.values():
        if len(v) == 2:
            neighbours[v[0]].append(v[1])
            neighbours[v[1]].append(v[0])

    def agree(f, g):            # f's orientation taken as right: is g's consistent with it?
        if dim == 2:
            return facets[f, 1] == facets[g, 0] or facets[f, 0] == facets[g, 1]
        ef = {(int(facets[f, a]), int(facets[f, b])) for a, b in sides}
        eg = {(int(facets[g, a]), int(facets[g, b])) for a, b in sides}
        return not (ef & eg)    # a shared edge walked in the same sense: disagree

    done = np.zeros(nf, dtype=bool)
    for seed in range(nf):
        if done[seed]:
            continue
        done[seed] = True
        stack = [seed]
        while stack:
            f = stack.pop()
            for g in neighbours[f]:
                if done[g]:
                    if not agree(f, g):
                        raise ValueError("the surface cannot be oriented (a one-sided strip)")
                    continue
                if not agree(f, g):
                    facets[g] = facets[g, ::-1]
                done[g] = True
                stack.append(g)
    return facets


def build_surface(vertices, facets, flip: bool) -> FacetSurface:
    """The :class:`FacetSurface` of ``vertices`` (nv, dim) [mm] and ``facets`` (nf, dim) (segments in 2-D,
    triangles in 3-D), coherently oriented (:func:`_orient`); the normals turned over when ``flip``.
    ValueError for an empty or degenerate surface or one that cannot be oriented."""
    V = np.ascontiguousarray(vertices, dtype=float)
    F = np.ascontiguousarray(facets, dtype=np.int64)
    if V.ndim != 2 or V.shape[1] not in (2, 3) or F.ndim != 2 or F.shape[1] != V.shape[1] or len(F) == 0:
        raise ValueError(f"a surface needs vertices (nv, 2 or 3) and facets (nf, dim) of as many vertices as "
                         f"dimensions, got {V.shape} and {F.shape}")
    if F.min() < 0 or F.max() >= len(V):
        raise ValueError("a facet names a vertex that does not exist")
    F = _orient(F, V.shape[1])
    if flip:
        F = np.ascontiguousarray(F[:, ::-1])
    return oriented_surface(V, F)


def oriented_surface(vertices, facets, mirrored=None) -> FacetSurface:
    """The :class:`FacetSurface` of facets (nf, dim) already oriented as wanted (their normals point to the
    side a point's gap is positive on: left of a segment's direction, right-handed about a triangle's
    vertex order), e.g. a body's boundary facets turned to point out of its cells. ``mirrored`` (nv,) bool:
    the vertices on a plane (or axis) of symmetry of the model, across which the surface continues as its
    mirror image: a boundary vertex (2-D) or an edge of two such vertices (3-D) there is not open (see
    :func:`nearest_points`). ValueError for a degenerate facet."""
    V = np.array(vertices, dtype=float)
    F = np.ascontiguousarray(facets, dtype=np.int64)
    dim = V.shape[1]
    P = V[F]                                                   # (nf, dim, dim)
    size = np.linalg.norm(P[:, 1] - P[:, 0], axis=1) if dim == 2 else \
        np.linalg.norm(np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]), axis=1)
    if not np.all(size > 0):
        raise ValueError(f"facet {int(np.argmin(size))} of the surface is degenerate (zero length or area)")
    mirrored = np.zeros(len(V), dtype=bool) if mirrored is None else np.asarray(mirrored, dtype=bool)
    open_vertices = np.zeros(len(V), dtype=np.int8)
    if dim == 2:
        facet_edges, n_edges = np.zeros((len(F), 0), dtype=np.int64), 0
        open_edges = np.zeros((len(F), 0), dtype=np.int8)
        open_vertices[(np.bincount(F.ravel(), minlength=len(V)) == 1) & ~mirrored] = 1
    else:
        keys = np.sort(np.stack([F, np.roll(F, -1, axis=1)], axis=2).reshape(-1, 2), axis=1)
        unique, facet_edges = np.unique(keys, axis=0, return_inverse=True)
        facet_edges, n_edges = facet_edges.reshape(-1, 3).astype(np.int64), len(unique)
        once = (np.bincount(facet_edges.ravel(), minlength=n_edges) == 1) & ~mirrored[unique].all(axis=1)
        open_edges = once[facet_edges].astype(np.int8)
        open_vertices[unique[once].ravel()] = 1
    _, _, children, leaf, order = _hierarchy(P.min(axis=1), P.max(axis=1))
    nb = len(children)
    s = FacetSurface(V, F, np.zeros((len(F), dim)), facet_edges, np.zeros((n_edges, dim)), np.zeros_like(V),
                     np.zeros((nb, dim)), np.zeros((nb, dim)), children, leaf, order, open_vertices, open_edges)
    refresh(s, V)
    return s


def refresh(surface: FacetSurface, vertices) -> None:
    """Move ``surface``'s vertices to ``vertices`` (nv, dim) [mm] (a deformable body's boundary at its
    current positions) and recompute, in place, what depends on them: facet normals, pseudo-normals and the
    hierarchy's boxes (refitted bottom up; the tree's facets stay where they are). A facet squeezed to zero
    length or area gets a zero normal (its neighbours' pseudo-normals decide the sign there)."""
    s = surface
    s.vertices[:] = vertices
    _refresh(s.vertices, s.facets, s.normals, s.facet_edges, s.edge_normals, s.vertex_normals, s.box_lo, s.box_hi,
             s.children, s.leaf, s.order)


def _hierarchy(lo, hi):
    """(box_lo, box_hi, children, leaf, order) of the bounding-volume hierarchy over the facet boxes
    [lo, hi] (nf, dim): see the module docstring."""
    centre = 0.5 * (lo + hi)
    order = np.arange(len(lo))
    box_lo, box_hi, children, leaf = [], [], [], []
    stack = [(0, len(lo), -1, 0)]               # (start, end in order, parent box, which child)
    while stack:
        start, end, parent, side = stack.pop()
        b = len(box_lo)
        idx = order[start:end]
        box_lo.append(lo[idx].min(axis=0))
        box_hi.append(hi[idx].max(axis=0))
        children.append([-1, -1])
        leaf.append([start, end])
        if parent >= 0:
            children[parent][side] = b
        if end - start > LEAF_SIZE:
            c = centre[idx]
            axis = int(np.argmax(c.max(axis=0) - c.min(axis=0)))
            mid = (end - start) // 2
            order[start:end] = idx[np.argpartition(c[:, axis], mid)]
            stack.append((start + mid, end, b, 1))
            stack.append((start, start + mid, b, 0))
    return (np.array(box_lo), np.array(box_hi), np.array(children, dtype=np.int64), np.array(leaf, dtype=np.int64),
            order.astype(np.int64))


def surface_gaps(surface: FacetSurface, x, d=None, reach: float = math.inf, derivative: bool = False):
    """(g (n,) [mm], N (n, dim)) of the points x (n, dim) [mm] to ``surface`` translated by d (dim,) [mm]:
    see the module docstring. Points farther than ``reach`` [mm] get g = reach and N = 0. With
    ``derivative``, also dN/dx (n, dim, dim) [1/mm]: 0 where the nearest point lies inside a facet,
    (I - N N^T - t t^T) / g where it lies on an edge of unit tangent t (3-D), (I - N N^T) / g at a vertex
    (where the nearest point stays put while x moves, N turns about it); 0 where g is 0 to round-off."""
    s = surface
    dim = s.vertices.shape[1]
    x = np.ascontiguousarray(x, dtype=float)[:, :dim]
    d = np.zeros(dim) if d is None else np.asarray(d, dtype=float)[:dim]
    g, N, dN = np.empty(len(x)), np.empty((len(x), dim)), np.empty((len(x), dim, dim))
    _gaps(s.vertices + d, s.facets, s.normals, s.facet_edges, s.edge_normals, s.vertex_normals, s.box_lo + d,
          s.box_hi + d, s.children, s.leaf, s.order, x, float(reach), g, N, dN, np.full(len(x), -1, np.int64),
          np.empty(len(x), np.int64), np.empty((len(x), dim)), s.open_vertices, s.open_edges, 0.0, x, 2.0)
    return (g, N, dN) if derivative else (g, N)


#: node-to-surface contact: a point whose nearest point lies on the surface's open boundary is apart when it
#: lies farther than this fraction of the facet's size beyond the boundary, in the facet's plane
OPEN_BOUNDARY_TOLERANCE = 1e-3


#: self-contact: a facet counts for a point only when its normal and the point's own (its vertex normal)
#: face each other, n_f . n_s below this (an angle over 107 degrees): the facets next to a node on its own
#: surface, nearly parallel to it, are never its contact
SELF_CONTACT_FACING = -0.3


def nearest_points(surface: FacetSurface, x, skip, g, N, facet, weights, reach: float = math.inf,
                   facing=None) -> None:
    """Node-to-surface contact's search: for the points x (n, dim) [mm], into g (n,) [mm] and N (n, dim) (as
    :func:`surface_gaps`), facet (n,) the facet that holds the nearest point (-1 beyond ``reach``) and
    weights (n, dim) of that facet's vertices there (sum 1: the point is weights . vertices[facets[facet]]).
    skip (n,): a vertex whose facets point i does not see (-1: none; a node of the surface itself).

    A surface with an open boundary (the face of a body, a group that ends) has no inside beyond its edge:
    a point whose nearest point lies on the open boundary and that is more than
    :data:`OPEN_BOUNDARY_TOLERANCE` of the facet's size beyond it (measured in the facet's plane) is apart
    (g = reach, N = 0, facet -1); within it, it has the facet's own gap and normal (a node at the corner
    of the other body's face). Where the surface ends on a plane of symmetry it is not open
    (:func:`oriented_surface`'s ``mirrored``): a point there pressed into a facet tilted across the plane
    lies beyond the facet's edge by the depth times the tilt, and is in contact with the edge.

    facing (n, dim): the points' own outward normals (self-contact, points of the surface itself): only
    facets whose normal faces the point's (n_f . n_s < :data:`SELF_CONTACT_FACING`) are searched."""
    s = surface
    dim = s.vertices.shape[1]
    x = np.ascontiguousarray(x, dtype=float)[:, :dim]
    _gaps(s.vertices, s.facets, s.normals, s.facet_edges, s.edge_normals, s.vertex_normals, s.box_lo, s.box_hi,
          s.children, s.leaf, s.order, x, float(reach), g, N, np.empty((len(x), dim, dim)), skip, facet, weights,
          s.open_vertices, s.open_edges, OPEN_BOUNDARY_TOLERANCE,
          x if facing is None else np.ascontiguousarray(facing, dtype=float), 2.0 if facing is None else
          SELF_CONTACT_FACING)


# ----------------------------------------------------------------------------------------------
# compiled: the nearest point of one facet, and the search down the hierarchy


@_njit
def segment_nearest(p, V, f0, f1):
    """(squared distance, q0, q1, feature, s) of point p (2,) to the segment of vertices f0, f1 of V;
    feature 0 inside, 1 at the first vertex, 2 at the second; q = (1 - s) V[f0] + s V[f1]."""
    a0, a1 = V[f0, 0], V[f0, 1]
    t0, t1 = V[f1, 0] - a0, V[f1, 1] - a1
    length2 = t0 * t0 + t1 * t1
    s = ((p[0] - a0) * t0 + (p[1] - a1) * t1) / length2 if length2 > 0.0 else 0.0
    feature = 0
    if s <= 0.0:
        s, feature = 0.0, 1
    elif s >= 1.0:
        s, feature = 1.0, 2
    q0, q1 = a0 + s * t0, a1 + s * t1
    return (p[0] - q0) ** 2 + (p[1] - q1) ** 2, q0, q1, feature, s


@_njit
def _dot3(a0, a1, a2, b0, b1, b2):
    return a0 * b0 + a1 * b1 + a2 * b2


@_njit
def triangle_nearest(p, V, fa, fb, fc):
    """(squared distance, q0, q1, q2, feature, v, w) of point p (3,) to the triangle of vertices fa, fb, fc
    of V (Ericson, Real-Time Collision Detection, 5.1.5); feature 0 inside, 1, 2, 3 at vertex a, b, c,
    4, 5, 6 on edge ab, bc, ca; q = a + v (b - a) + w (c - a)."""
    a0, a1, a2 = V[fa, 0], V[fa, 1], V[fa, 2]
    ab0, ab1, ab2 = V[fb, 0] - a0, V[fb, 1] - a1, V[fb, 2] - a2
    ac0, ac1, ac2 = V[fc, 0] - a0, V[fc, 1] - a1, V[fc, 2] - a2
    ap0, ap1, ap2 = p[0] - a0, p[1] - a1, p[2] - a2
    d1, d2 = _dot3(ab0, ab1, ab2, ap0, ap1, ap2), _dot3(ac0, ac1, ac2, ap0, ap1, ap2)
    # q = a + v ab + w ac
    if d1 <= 0.0 and d2 <= 0.0:
        v, w, f = 0.0, 0.0, 1
    else:
        bp0, bp1, bp2 = ap0 - ab0, ap1 - ab1, ap2 - ab2
        d3, d4 = _dot3(ab0, ab1, ab2, bp0, bp1, bp2), _dot3(ac0, ac1, ac2, bp0, bp1, bp2)
        cp0, cp1, cp2 = ap0 - ac0, ap1 - ac1, ap2 - ac2
        d5, d6 = _dot3(ab0, ab1, ab2, cp0, cp1, cp2), _dot3(ac0, ac1, ac2, cp0, cp1, cp2)
        vc, vb, va = d1 * d4 - d3 * d2, d5 * d2 - d1 * d6, d3 * d6 - d5 * d4
        if d3 >= 0.0 and d4 <= d3:
            v, w, f = 1.0, 0.0, 2
        elif d6 >= 0.0 and d5 <= d6:
            v, w, f = 0.0, 1.0, 3
        elif vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
            v, w, f = d1 / (d1 - d3), 0.0, 4
        elif vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
            v, w, f = 0.0, d2 / (d2 - d6), 6
        elif va <= 0.0 and d4 - d3 >= 0.0 and d5 - d6 >= 0.0:
            w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
            v, f = 1.0 - w, 5
        else:
            den = va + vb + vc
            v, w, f = (vb / den, vc / den, 0) if den != 0.0 else (0.0, 0.0, 1)
    q0, q1, q2 = a0 + v * ab0 + w * ac0, a1 + v * ab1 + w * ac1, a2 + v * ab2 + w * ac2
    return (p[0] - q0) ** 2 + (p[1] - q1) ** 2 + (p[2] - q2) ** 2, q0, q1, q2, f, v, w


@_njit
def _box_distance2(p, lo, hi):
    """Squared distance from p to the box [lo, hi]."""
    d2 = 0.0
    for k in range(len(p)):
        if p[k] < lo[k]:
            d2 += (lo[k] - p[k]) ** 2
        elif p[k] > hi[k]:
            d2 += (p[k] - hi[k]) ** 2
    return d2


@_njit
def _refresh(V, F, n, facet_edges, edge_normals, vertex_normals, box_lo, box_hi, children, leaf, order):
    """Facet normals n (nf, dim), pseudo-normals of edges (3-D) and vertices, boxes (nb, dim) of the surface
    of vertices V and oriented facets F: see :func:`refresh`. 2-D: the segment's left normal, vertex
    pseudo-normal the sum of its segments'; 3-D: right-handed about the vertex order, edge pseudo-normal
    the sum of its two triangles' (normalised), vertex pseudo-normal weighted by each triangle's angle there
    (Baerentzen and Aanaes)."""
    dim = V.shape[1]
    nf = F.shape[0]
    vertex_normals[:, :] = 0.0
    edge_normals[:, :] = 0.0
    for f in range(nf):
        if dim == 2:
            t0, t1 = V[F[f, 1], 0] - V[F[f, 0], 0], V[F[f, 1], 1] - V[F[f, 0], 1]
            size = math.sqrt(t0 * t0 + t1 * t1)
            n[f, 0], n[f, 1] = (-t1 / size, t0 / size) if size > 0.0 else (0.0, 0.0)
            for k in range(2):
                vertex_normals[F[f, k], 0] += n[f, 0]
                vertex_normals[F[f, k], 1] += n[f, 1]
            continue
        a0, a1, a2 = V[F[f, 1], 0] - V[F[f, 0], 0], V[F[f, 1], 1] - V[F[f, 0], 1], V[F[f, 1], 2] - V[F[f, 0], 2]
        b0, b1, b2 = V[F[f, 2], 0] - V[F[f, 0], 0], V[F[f, 2], 1] - V[F[f, 0], 1], V[F[f, 2], 2] - V[F[f, 0], 2]
        c0, c1, c2 = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
        size = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
        if size > 0.0:
            n[f, 0], n[f, 1], n[f, 2] = c0 / size, c1 / size, c2 / size
        else:
            n[f, 0], n[f, 1], n[f, 2] = 0.0, 0.0, 0.0
        for k in range(3):
            e = facet_edges[f, k]
            for j in range(3):
                edge_normals[e, j] += n[f, j]
            v, p, q = F[f, k], F[f, (k + 1) % 3], F[f, (k + 2) % 3]
            p0, p1, p2 = V[p, 0] - V[v, 0], V[p, 1] - V[v, 1], V[p, 2] - V[v, 2]
            q0, q1, q2 = V[q, 0] - V[v, 0], V[q, 1] - V[v, 1], V[q, 2] - V[v, 2]
            lp, lq = math.sqrt(p0 * p0 + p1 * p1 + p2 * p2), math.sqrt(q0 * q0 + q1 * q1 + q2 * q2)
            cos = _dot3(p0, p1, p2, q0, q1, q2) / (lp * lq) if lp * lq > 0.0 else 1.0
            angle = math.acos(min(1.0, max(-1.0, cos)))
            for j in range(3):
                vertex_normals[v, j] += angle * n[f, j]
    for e in range(edge_normals.shape[0]):
        size = math.sqrt(_dot3(edge_normals[e, 0], edge_normals[e, 1], edge_normals[e, 2], edge_normals[e, 0],
                               edge_normals[e, 1], edge_normals[e, 2]))
        if size > 0.0:
            for j in range(3):
                edge_normals[e, j] /= size
    for v in range(V.shape[0]):
        size = 0.0
        for j in range(dim):
            size += vertex_normals[v, j] ** 2
        size = max(math.sqrt(size), 1e-300)
        for j in range(dim):
            vertex_normals[v, j] /= size
    for b in range(box_lo.shape[0] - 1, -1, -1):     # children come after their parent: bottom up
        for j in range(dim):
            box_lo[b, j], box_hi[b, j] = math.inf, -math.inf
        if children[b, 0] < 0:
            for m in range(leaf[b, 0], leaf[b, 1]):
                for k in range(dim):
                    for j in range(dim):
                        x = V[F[order[m], k], j]
                        box_lo[b, j] = min(box_lo[b, j], x)
                        box_hi[b, j] = max(box_hi[b, j], x)
        else:
            for c in (children[b, 0], children[b, 1]):
                for j in range(dim):
                    box_lo[b, j] = min(box_lo[b, j], box_lo[c, j])
                    box_hi[b, j] = max(box_hi[b, j], box_hi[c, j])


@_njit
def _gaps(V, F, n, facet_edges, edge_normals, vertex_normals, box_lo, box_hi, children, leaf, order, x, reach, g, N,
          dN, skip, facet_of, weights, open_vertices, open_edges, open_tolerance, facing, facing_cos):
    """g (n,), N (n, dim), dN (n, dim, dim) of the points x (n, dim) to the surface of vertices V and boxes
    (already translated); see :func:`surface_gaps`. Also the nearest facet facet_of (n,) (-1: none within
    reach) and the weights (n, dim) of its vertices at the nearest point; facets with the vertex skip[i]
    (-1: none) are not searched for point i (a body's own node). open_tolerance > 0: a nearest point on the
    open boundary (open_vertices, open_edges) is apart beyond it (:func:`nearest_points`). facing_cos <= 1:
    facets with n_f . facing[i] >= facing_cos are not searched for point i (self-contact)."""
    dim = V.shape[1]
    stack = np.empty(2 * len(box_lo) + 2, dtype=np.int64)
    reach2 = reach * reach if reach < math.inf else math.inf
    for i in range(len(x)):
        p = x[i]
        best, facet, feature = reach2, -1, 0
        q0 = q1 = q2 = 0.0
        wv = ww = 0.0
        top = 0
        stack[0] = 0
        while top >= 0:
            b = stack[top]
            top -= 1
            if _box_distance2(p, box_lo[b], box_hi[b]) >= best:
                continue
            c0, c1 = children[b, 0], children[b, 1]
            if c0 < 0:                                  # a leaf: its facets
                for m in range(leaf[b, 0], leaf[b, 1]):
                    f = order[m]
                    if skip[i] >= 0 and (F[f, 0] == skip[i] or F[f, 1] == skip[i]
                                         or (dim == 3 and F[f, dim - 1] == skip[i])):
                        continue
                    if facing_cos <= 1.0:
                        c = n[f, 0] * facing[i, 0] + n[f, 1] * facing[i, 1]
                        if dim == 3:
                            c += n[f, 2] * facing[i, 2]
                        if c >= facing_cos:
                            continue
                    if dim == 2:
                        dd, a0, a1, ff, sv = segment_nearest(p, V, F[f, 0], F[f, 1])
                        a2 = sw = 0.0
                    else:
                        dd, a0, a1, a2, ff, sv, sw = triangle_nearest(p, V, F[f, 0], F[f, 1], F[f, 2])
                    if dd < best:
                        best, facet, feature, q0, q1, q2, wv, ww = dd, f, ff, a0, a1, a2, sv, sw
                continue
            d0, d1 = _box_distance2(p, box_lo[c0], box_hi[c0]), _box_distance2(p, box_lo[c1], box_hi[c1])
            near, far = (c0, c1) if d0 <= d1 else (c1, c0)
            stack[top + 1] = far                         # the nearer child is walked first
            stack[top + 2] = near
            top += 2
        dist = math.sqrt(best)
        dN[i, :, :] = 0.0
        facet_of[i] = facet
        if facet < 0 or dist > reach:
            g[i] = reach
            N[i, :] = 0.0
            weights[i, :] = 0.0
            facet_of[i] = -1
            continue
        if dim == 2:
            weights[i, 0], weights[i, 1] = 1.0 - wv, wv
        else:
            weights[i, 0], weights[i, 1], weights[i, 2] = 1.0 - wv - ww, wv, ww
        if open_tolerance > 0.0 and feature != 0:
            on_open = (open_vertices[F[facet, feature - 1]] == 1) if feature <= dim else \
                (open_edges[facet, feature - 4] == 1)
            if on_open:
                # the point's offset from q in the facet's plane against the facet's size
                r0_, r1_, r2_ = p[0] - q0, p[1] - q1, (p[2] - q2 if dim == 3 else 0.0)
                nf = n[facet]
                normal_part = r0_ * nf[0] + r1_ * nf[1] + (r2_ * nf[2] if dim == 3 else 0.0)
                in0, in1 = r0_ - normal_part * nf[0], r1_ - normal_part * nf[1]
                in2 = r2_ - normal_part * nf[2] if dim == 3 else 0.0
                size = 0.0
                for a in range(dim):
                    b = (a + 1) % dim
                    e = 0.0
                    for j in range(dim):
                        e += (V[F[facet, a], j] - V[F[facet, b], j]) ** 2
                    size = max(size, e)
                if in0 * in0 + in1 * in1 + in2 * in2 > (open_tolerance * open_tolerance) * size:
                    g[i] = reach
                    N[i, :] = 0.0
                    weights[i, :] = 0.0
                    facet_of[i] = -1
                    continue
                g[i] = normal_part
                for j in range(dim):
                    N[i, j] = nf[j]
                continue
        if feature == 0:
            normal = n[facet]
        elif feature <= dim:
            normal = vertex_normals[F[facet, feature - 1]]
        else:
            normal = edge_normals[facet_edges[facet, feature - 4]]
        r0_, r1_, r2_ = p[0] - q0, p[1] - q1, (p[2] - q2 if dim == 3 else 0.0)
        along = r0_ * normal[0] + r1_ * normal[1] + (r2_ * normal[2] if dim == 3 else 0.0)
        sign = 1.0 if along >= 0.0 else -1.0
        g[i] = sign * dist
        if dist > 1e-12 * (1.0 + abs(q0) + abs(q1) + abs(q2)):
            N[i, 0], N[i, 1] = sign * r0_ / dist, sign * r1_ / dist
            if dim == 3:
                N[i, 2] = sign * r2_ / dist
            if feature != 0:            # on an edge or at a vertex: N turns as x moves (dN/dx)
                t0 = t1 = t2 = 0.0
                if feature > dim:       # an edge (3-D): its unit tangent
                    e = feature - 4
                    a, b = F[facet, e], F[facet, (e + 1) % 3]
                    t0, t1, t2 = V[b, 0] - V[a, 0], V[b, 1] - V[a, 1], V[b, 2] - V[a, 2]
                    tn = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
                    t0, t1, t2 = t0 / tn, t1 / tn, t2 / tn
                t = (t0, t1, t2)
                for a in range(dim):
                    for b in range(dim):
                        dN[i, a, b] = ((1.0 if a == b else 0.0) - N[i, a] * N[i, b] - t[a] * t[b]) / g[i]
        else:
            N[i, :] = normal
