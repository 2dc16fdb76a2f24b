"""Meshed rigid tools: a physical curve (2-D) or surface (3-D) of a Gmsh file, moved rigidly along a path.

A tool no analytic shape makes (a die from CAD, a square punch): ``[tools.<name>] shape = "mesh"``, with
``file`` (a Gmsh ``.geo``, meshed here, or a ``.msh``, either screened like the body's mesh file) and
``group`` (the physical curve or surface that is the tool's working surface; line elements in 2-D,
triangles or quadrangles in 3-D, the quadrangles split in two). The body lies on the side the facets'
normals point to: left of the curve's direction in 2-D, right-handed about the vertex order in 3-D, every
facet oriented like its neighbours (:func:`fenics_plast.solvers.surface_gaps.build_surface`);
``flip = true`` takes the other side.

A :class:`MeshedTool` answers what the solvers ask of a tool: ``gap_np(x, t)`` (the signed gap and normal
of :func:`~fenics_plast.solvers.surface_gaps.surface_gaps`, the surface translated by the path) and
``translation(t)``. The explicit contact takes its gaps as given (a tool with a ``gap_np`` of its own:
:mod:`fenics_plast.solvers.explicit_contact`); the static contact forms, which evaluate gaps at the nodes,
take them, and the normal's derivative, as nodal functions computed at every Newton state and linearised
about it (:meth:`fenics_plast.contact.ContactPair._nodal_gap`, ``has_ufl_gap = False``). Friction and
energy as for an analytic tool. Units mm.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from fenics_plast.errors import SceneError
from fenics_plast.scene_key import REQUIRED, Key

#: the ``shape`` of a meshed tool
SHAPE = "mesh"
#: its scene keys (``tools.<name>.*``; the schema adds ``when = {shape: mesh}``)
KEYS = {
    "file": Key("str", REQUIRED, "Gmsh .geo or .msh file holding the tool's surface, relative to the scene "
                "file, suffix in any case (screened like the body's mesh file, links resolved; a .geo is then "
                "meshed)."),
    "group": Key("str", REQUIRED, "The physical curve (2-D) or physical surface (3-D) of `file` that is the "
                 "tool's surface (line elements; triangles or quadrangles)."),
    "flip": Key("bool", False, "The body lies on the side the surface's normals point to (left of the "
                "curve's direction in 2-D, right-handed about the element's vertex order in 3-D, all facets "
                "oriented like their neighbours); true: on the other side."),
}
DOC = "mesh: a physical curve (2-D) or surface (3-D) of a Gmsh file"

#: Gmsh element types: 2-node line, 3-node triangle, 4-node quadrangle
_LINE, _TRIANGLE, _QUADRANGLE = 1, 2, 3


def read_surface(path, group: str, dim: int, comm, scene_dir=None):
    """(vertices (nv, dim) [mm], facets (nf, dim)) of the physical group ``group`` of dimension dim - 1 in
    the Gmsh file ``path`` (rank 0 reads, every rank gets them). SceneError naming the file and group for
    a missing file, a script the screen refuses, a group that does not exist, has another dimension, is
    empty or holds elements other than linear lines (2-D) or triangles and quadrangles (3-D)."""
    import gmsh

    from fenics_plast.geo_screen import GeoScreenError
    from fenics_plast.gmsh_session import gmsh_session
    path = Path(path)
    error, surface = None, None
    if comm.rank == 0:
        try:
            with gmsh_session():
                surface = _read_group(gmsh, path, group, dim, scene_dir)
        except (SceneError, GeoScreenError) as e:
            error = str(e)
        except Exception as e:  # noqa: BLE001 - gmsh raises plain Exception with its last error
            error = f"Gmsh cannot read {path.name}: {e}"
    error, surface = comm.bcast((error, surface), root=0)
    if error is not None:
        raise SceneError(error)
    return surface


def _read_group(gmsh, path, group, dim, scene_dir):
    """The facets of ``group`` in the Gmsh file ``path`` (screened, a .geo meshed), Gmsh running. Gmsh opens
    the file with its links resolved, the one the screen read, and its kind is that name's suffix in any
    case (issue 34)."""
    from fenics_plast.geo_screen import mesh_file_kind, screen
    if not path.is_file():
        raise SceneError(f"file {path} not found")
    opened, kind = mesh_file_kind(path)
    if not kind:
        raise SceneError(f"file {path}: must end in .geo or .msh"
                         + (f" (it is a symbolic link to {opened})" if opened.name != path.name else ""))
    screen(path, scene_dir)         # a .msh too: Gmsh reads one that is no mesh as a script
    gmsh.open(str(opened))
    if kind == ".geo":
        gmsh.model.geo.synchronize()
        gmsh.model.mesh.generate(dim - 1)
    return _group_facets(gmsh, path, group, dim)


def _group_facets(gmsh, path, group, dim):
    kind = "physical curve" if dim == 2 else "physical surface"
    names = {gmsh.model.getPhysicalName(d, t): (d, t) for d, t in gmsh.model.getPhysicalGroups()}
    if group not in names:
        raise SceneError(f"{path.name} has no physical group {group!r} (its groups: "
                         f"{', '.join(sorted(names)) or 'none'})")
    d, tag = names[group]
    if d != dim - 1:
        raise SceneError(f"{path.name}: {group!r} is a physical group of dimension {d}: a {dim}-D tool needs "
                         f"a {kind}")
    facets = []
    for entity in gmsh.model.getEntitiesForPhysicalGroup(d, tag):
        for etype, _, nodes in zip(*gmsh.model.mesh.getElements(d, entity)):
            nodes = np.asarray(nodes, dtype=np.int64)
            if dim == 2 and etype == _LINE:
                facets.append(nodes.reshape(-1, 2))
            elif dim == 3 and etype == _TRIANGLE:
                facets.append(nodes.reshape(-1, 3))
            elif dim == 3 and etype == _QUADRANGLE:
                q = nodes.reshape(-1, 4)
                facets.append(np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]]))
            else:
                name = gmsh.model.mesh.getElementProperties(etype)[0]
                raise SceneError(f"{path.name}: {kind} {group!r} holds {name} elements: a tool surface takes "
                                 + ("2-node lines" if dim == 2 else "3-node triangles and 4-node quadrangles"))
    if not facets:
        raise SceneError(f"{path.name}: {kind} {group!r} has no elements")
    facets = np.concatenate(facets)
    used = np.unique(facets)
    tags, coords, _ = gmsh.model.mesh.getNodes()
    tags, coords = np.asarray(tags, dtype=np.int64), np.asarray(coords).reshape(-1, 3)
    by_tag = np.argsort(tags)
    rows = by_tag[np.searchsorted(tags, used, sorter=by_tag)]
    return coords[rows, :dim], np.searchsorted(used, facets)


class MeshedTool:
    """A rigid tool whose surface is ``surface`` (:class:`~fenics_plast.solvers.surface_gaps.FacetSurface`),
    translating along ``path`` (as :class:`fenics_plast.tools.Tool`'s: a function of t, None = fixed);
    ``flip`` as in the scene."""

    def __init__(self, surface, flip: bool, path=None, name=SHAPE):
        self.surface = surface
        self.dim = surface.vertices.shape[1]
        self.path = path
        self.name = name
        self.flip = flip            # the scene's flip, which built ``surface`` (for messages)

    #: its gap is computed at the nodes (gap_np), not written in UFL (fenics_plast.contact.ContactPair)
    has_ufl_gap = False

    def translation(self, t, use_ufl=True):
        """Translation [mm] at t: a tuple of ``dim`` UFL scalars of the UFL t, or a numpy (dim,) array."""
        import ufl
        d = (0.0,) * self.dim if self.path is None else tuple(self.path(t, use_ufl))
        d = (d + (0.0,) * self.dim)[:self.dim]
        if use_ufl:
            return tuple(ufl.as_ufl(c) for c in d)
        return np.array([float(c) for c in d])

    def gap_np(self, x, t):
        """(g (n,) [mm], N (n, dim)) of the positions x (n, dim) (or (n, 3) for a 2-D tool) at time t."""
        from fenics_plast.solvers.surface_gaps import surface_gaps
        return surface_gaps(self.surface, np.asarray(x)[:, :self.dim], self.translation(t, use_ufl=False))

    def nodal_gap(self, x, t):
        """(g, N, dN/dx (n, dim, dim) [1/mm]) at the positions x (n, dim) at time t: what the static contact
        forms linearise about (:meth:`fenics_plast.contact.ContactPair._nodal_gap`)."""
        from fenics_plast.solvers.surface_gaps import surface_gaps
        return surface_gaps(self.surface, np.asarray(x)[:, :self.dim], self.translation(t, use_ufl=False),
                            derivative=True)


def check_tool_size(name, tool: MeshedTool, cell: float, where: str = "") -> None:
    """SceneError naming ``tools.<name>`` when the tool's surface spans less than ``cell`` [mm] (the body's
    smallest cell, :func:`fenics_plast.build.smallest_cell`; ``where``: the scene file): a tool shorter
    than a cell touches the body between its nodes (the nodal contact sees no gap, or one node takes the
    tool's whole force)."""
    v = np.asarray(tool.surface.vertices)
    extent = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0))) if len(v) else 0.0
    if not extent >= cell:
        raise SceneError(f"{where + ': ' if where else ''}tools.{name}: the tool's surface spans {extent:.3g} mm, "
                         f"less than the body's smallest cell ({cell:.3g} mm): contact is found at the body's "
                         f"nodes, so a tool must be longer than a cell (refine the body's mesh or enlarge the tool)")


def meshed_tool(name, spec, dim: int, path, comm, scene_dir) -> MeshedTool:
    """The :class:`MeshedTool` of a validated ``[tools.<name>]`` table with ``shape = "mesh"`` in ``dim``
    dimensions (its file resolved against ``scene_dir``); SceneError (the key named) for a surface that
    cannot be read or oriented."""
    from fenics_plast.solvers.surface_gaps import build_surface
    file = Path(spec.file)
    file = file if file.is_absolute() else Path(scene_dir) / file
    try:
        vertices, facets = read_surface(file, spec.group, dim, comm, scene_dir)
        surface = build_surface(vertices, facets, flip=bool(spec.flip))
    except (SceneError, ValueError) as e:
        raise SceneError(f"tools.{name}: {e}") from None
    return MeshedTool(surface, bool(spec.flip), path, name)
