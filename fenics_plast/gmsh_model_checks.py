"""Checks of a Gmsh model before dolfinx distributes it (rank 0, the mesh open in Gmsh): every cell of
the body a linear quadrilateral (2-D) or hexahedron (3-D) (:func:`require_linear_cells`), and the
facet groups (:func:`check_facet_groups`): no two groups the scene names sharing a facet (dolfinx's
mesh keeps one tag per facet, the other group would come out without it), and no group off the
body (dolfinx cannot distribute it: a segmentation fault, no message). Each refusal is a
:class:`~fenics_plast.gmsh_child.MeshError` naming the groups (and the scene keys naming them).
"""
from __future__ import annotations

import gmsh
import numpy as np

from .gmsh_child import MeshError

__all__ = ["require_linear_cells", "check_facet_groups"]


_GMSH_HEXAHEDRON = 5
_GMSH_QUADRANGLE = 3


def require_linear_cells(name, groups, gdim=3):
    """MeshError unless every cell of the physical volumes is a linear hexahedron (``gdim`` = 2: every
    cell of the physical surfaces a linear quadrilateral) (rank 0, gmsh open)."""
    counts: dict[str, int] = {}
    wanted = _GMSH_HEXAHEDRON if gdim == 3 else _GMSH_QUADRANGLE
    for dim, tag in groups.values():
        if dim != gdim:
            continue
        for e in gmsh.model.getEntitiesForPhysicalGroup(gdim, tag):
            types, elements, _ = gmsh.model.mesh.getElements(gdim, e)
            for t, els in zip(types, elements):
                if t != wanted and len(els):
                    kind = gmsh.model.mesh.getElementProperties(t)[0]
                    counts[kind] = counts.get(kind, 0) + len(els)
    if counts:
        what = ", ".join(f"{n} {k}" for k, n in counts.items())
        if gdim == 2:
            raise MeshError(f"{name}: the 2-D elements are linear quadrilaterals only; this mesh has {what} "
                            f"(use Transfinite Surface + Recombine Surface, or Recombine Surface on an unstructured "
                            f"surface)")
        raise MeshError(f"{name}: the 3-D elements are linear hexahedra only; this mesh has {what} (use "
                        f"Transfinite Volume + Recombine, or Extrude with Layers and Recombine)")


def _element_rows(dim, entity):
    """{nodes per element: sorted node tags (n, k)} of the elements of one entity."""
    out = {}
    types, _, nodes = gmsh.model.mesh.getElements(dim, entity)
    for t, nd in zip(types, nodes):
        k = gmsh.model.mesh.getElementProperties(t)[3]
        rows = np.sort(np.asarray(nd, dtype=np.int64).reshape(-1, k), axis=1)
        out.setdefault(k, []).append(rows)
    return {k: np.concatenate(v) for k, v in out.items()}


def check_facet_groups(name, groups, gdim, used):
    """MeshError when two facet groups share a facet (an entity, or the same facet element in both) and
    ``used`` (group -> scene key; None: all) names one of them, or a facet group has elements with nodes
    on no cell of the body (rank 0, the mesh open in Gmsh)."""
    fdim = gdim - 1
    kind, entity = ("physical curve", "line") if gdim == 2 else ("physical surface", "surface")
    facet = sorted(((n, t) for n, (d, t) in groups.items() if d == fdim), key=lambda e: e[1])    # (file order)
    if not facet:
        return

    def named(*names):
        return used is None or any(n in used for n in names)

    def keys(*names):
        said = [f"{used[n]} names {n!r}" for n in names if used and n in used]
        return f" ({'; '.join(said)})" if said else ""
    entities = {n: list(gmsh.model.getEntitiesForPhysicalGroup(fdim, t)) for n, t in facet}
    owner: dict[int, str] = {}
    for n, _ in facet:
        for e in entities[n]:
            other = owner.get(e)
            if other is not None and other != n and named(other, n):
                raise MeshError(f"{name}: {kind}s {other!r} and {n!r} share {entity} {e}{keys(other, n)}: a facet "
                                f"belongs to one group in this solver; name the facets once (a group for each "
                                f"part, the parts listed together where a key takes several)")
            owner.setdefault(e, n)
    rows: dict[int, list] = {}
    for i, (n, _) in enumerate(facet):
        for e in entities[n]:
            for k, r in _element_rows(fdim, e).items():
                rows.setdefault(k, []).append((r, i))
    cell_nodes = [np.asarray(nodes, dtype=np.int64)
                  for d, t in groups.values() if d == gdim
                  for e in gmsh.model.getEntitiesForPhysicalGroup(gdim, t)
                  for nodes in gmsh.model.mesh.getElements(gdim, e)[2]]
    cell_nodes = np.unique(np.concatenate(cell_nodes)) if cell_nodes else np.zeros(0, dtype=np.int64)
    for k, parts in rows.items():
        R = np.concatenate([r for r, _ in parts])
        G = np.concatenate([np.full(len(r), i) for r, i in parts])
        off = ~np.isin(R, cell_nodes).all(axis=1)
        if off.any():
            bad = sorted({facet[i][0] for i in G[off]})
            n = bad[0]
            count = int(np.count_nonzero(G[off] == facet.index((n, groups[n][1]))))
            raise MeshError(f"{name}: {kind} {n!r} ({entity} {', '.join(map(str, entities[n]))}) has {count} "
                            f"element(s) with nodes on no cell of the body{keys(n)}: a facet group must lie on the "
                            f"body (on the boundary of its physical {'surfaces' if gdim == 2 else 'volumes'}); "
                            f"remove it from the file or move it onto the body")
        if len(parts) < 2:
            continue
        both = np.unique(np.column_stack([R, G]), axis=0)
        R, G = both[:, :-1], both[:, -1]
        _, inverse, counts = np.unique(R, axis=0, return_inverse=True, return_counts=True)
        inverse = np.asarray(inverse).reshape(-1)
        shared = counts[inverse] > 1
        if not shared.any():
            continue
        order = np.lexsort((G[shared], inverse[shared]))
        inv, grp = inverse[shared][order], G[shared][order]
        for j in range(len(inv) - 1):
            if inv[j] == inv[j + 1]:
                a, b = facet[grp[j]][0], facet[grp[j + 1]][0]
                if named(a, b):
                    nodes = " ".join(map(str, R[shared][order][j]))
                    raise MeshError(f"{name}: {kind}s {a!r} and {b!r} share facet elements (e.g. the one on "
                                    f"nodes {nodes}){keys(a, b)}: a facet belongs to one group in this solver; "
                                    f"name the facets once")
