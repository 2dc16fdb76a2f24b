"""Parametric Gmsh geometries (meshes/*.geo) -> dolfinx meshes and tags.

The .geo files are the single definition of each geometry: their ``DefineConstant``
parameters are set through ONELAB ("Parameters/<name>") before the file is opened, on
rank 0 only; the mesh is distributed with ``dolfinx.io.gmshio.model_to_mesh``.
Every function returns ``(mesh, cell_tags, facet_tags, tag_ids)`` with ``tag_ids`` the
map physical-group name -> integer tag (cells and facets).
"""
from __future__ import annotations

import os
from pathlib import Path

import gmsh
from dolfinx.io import gmshio

MESH_DIR = Path(os.environ.get("FENICS_PLAST_MESHES", Path(__file__).resolve().parent.parent / "meshes"))


def geo_path(name: str) -> Path:
    p = MESH_DIR / f"{name}.geo"
    if not p.exists():
        raise FileNotFoundError(f"geometry file {p} not found")
    return p


def mesh_from_geo(comm, name: str, parameters: dict, gdim: int = 2):
    """Mesh meshes/<name>.geo with the given ONELAB parameters ("Parameters/<key>")."""
    path = geo_path(name)
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        tag_ids = {}
        if comm.rank == 0:
            for key, value in parameters.items():
                gmsh.onelab.setNumber(f"Parameters/{key}", [float(value)])
            gmsh.open(str(path))
            gmsh.model.geo.synchronize()
            gmsh.model.mesh.generate(2)
            for dim, tag in gmsh.model.getPhysicalGroups():
                tag_ids[gmsh.model.getPhysicalName(dim, tag)] = tag
        else:
            gmsh.model.add(name)
        tag_ids = comm.bcast(tag_ids, root=0)
        mesh, cell_tags, facet_tags = gmshio.model_to_mesh(gmsh.model, comm, 0, gdim=gdim)
    finally:
        gmsh.finalize()
    mesh.name = name
    cell_tags.name = "cell_tags"
    facet_tags.name = "facet_tags"
    return mesh, cell_tags, facet_tags, tag_ids


def bar_mesh(comm, radius, length, cells_radial, cells_axial, imperfection=0.0, grading=1.0):
    """Half round bar, axisymmetric (x=r, y=z); groups axis, bottom (z=0), top (z=L), outer."""
    return mesh_from_geo(comm, "round_bar", {
        "radius": radius, "length": length, "cells_radial": int(cells_radial),
        "cells_axial": int(cells_axial), "imperfection": imperfection, "axial_grading": grading})


def blank_mesh(comm, radius, thickness, cells_radial, cells_thickness, grading=1.0):
    """Circular blank, axisymmetric; groups axis, lower (z=0), upper (z=t), rim (r=R)."""
    return mesh_from_geo(comm, "circular_blank", {
        "radius": radius, "thickness": thickness, "cells_radial": int(cells_radial),
        "cells_thickness": int(cells_thickness), "radial_grading": grading})


def ring_mesh(comm, inner_radius, outer_radius, cells_radial, cells_circumferential, grading=1.0):
    """Quarter annulus, plane strain; groups bottom (y=0), left (x=0), inner (r=a), outer (r=b)."""
    return mesh_from_geo(comm, "ring", {
        "inner_radius": inner_radius, "outer_radius": outer_radius,
        "cells_radial": int(cells_radial), "cells_circumferential": int(cells_circumferential),
        "radial_grading": grading})


class MeshError(ValueError):
    """A mesh file cannot be read or meshed, or names a parameter it does not define."""


_GMSH_HEXAHEDRON = 5


def _require_hexahedra(name, groups):
    """MeshError unless every cell of the physical volumes is a linear hexahedron (rank 0, gmsh open)."""
    counts: dict[str, int] = {}
    for dim, tag in groups.values():
        if dim != 3:
            continue
        for e in gmsh.model.getEntitiesForPhysicalGroup(3, tag):
            types, elements, _ = gmsh.model.mesh.getElements(3, e)
            for t, els in zip(types, elements):
                if t != _GMSH_HEXAHEDRON and len(els):
                    kind = gmsh.model.mesh.getElementProperties(t)[0]
                    counts[kind] = counts.get(kind, 0) + len(els)
    if counts:
        what = ", ".join(f"{n} {k}" for k, n in counts.items())
        raise MeshError(f"{name}: the 3-D elements are linear hexahedra only; this mesh has {what} (use "
                        f"Transfinite Volume + Recombine, or Extrude with Layers and Recombine)")


def mesh_from_file(comm, path, parameters=None, refine=1, gdim=2):
    """A dolfinx mesh and its named groups from a Gmsh ``.geo`` (meshed here) or ``.msh`` file.

    ``parameters`` (name -> number) set the .geo's ``DefineConstant`` values "Parameters/<name>";
    ``refine`` multiplies those whose name starts with ``cells`` (rounded to an integer). A name
    the file does not define, a .msh with parameters or refine, and Gmsh's own errors raise
    :class:`MeshError` with Gmsh's message. ``gdim``: 2 (quadrilaterals; physical surfaces are the cell
    regions, physical curves the facet groups) or 3 (hexahedra only, meshed with ``generate(3)``;
    physical volumes are the cell regions, physical surfaces the facet groups). Returns
    ``(mesh, cell_tags, facet_tags, groups)`` with ``groups`` = {physical name: (dim, tag)} (dim = gdim:
    cell regions, dim = gdim - 1: facet groups).
    """
    path = Path(path)
    parameters = dict(parameters or {})
    if not path.exists():
        raise MeshError(f"mesh file {path} not found")
    suffix = path.suffix.lower()
    if suffix not in (".geo", ".msh"):
        raise MeshError(f"mesh file {path}: must end in .geo or .msh")
    if suffix == ".msh" and (parameters or refine != 1):
        raise MeshError(f"mesh file {path}: a .msh file takes no parameters and no refine (use a .geo)")
    values = {k: (v * refine if k.startswith("cells") else v) for k, v in parameters.items()}
    if gdim not in (2, 3):
        raise ValueError(f"gdim must be 2 or 3, got {gdim}")
    region = "surface" if gdim == 2 else "volume"
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.logger.start()
        error, groups = None, {}
        if comm.rank == 0:
            try:
                if values:     # the names the file defines: open it once without ours
                    gmsh.open(str(path))
                    known = {n.split("/", 1)[1] for n in gmsh.onelab.getNames("Parameters/.*")}
                    unknown = sorted(set(values) - known)
                    if unknown:
                        raise MeshError(f"{path.name} defines no parameter {', '.join(unknown)} "
                                        f"(its parameters: {', '.join(sorted(known)) or 'none'})")
                    gmsh.clear()
                    gmsh.onelab.clear()
                for key, value in values.items():
                    gmsh.onelab.setNumber(f"Parameters/{key}", [float(value)])
                gmsh.open(str(path))
                if suffix == ".geo":
                    gmsh.model.geo.synchronize()
                    gmsh.model.mesh.generate(gdim)
                for dim, tag in gmsh.model.getPhysicalGroups():
                    groups[gmsh.model.getPhysicalName(dim, tag)] = (dim, tag)
                if not any(d == gdim for d, _ in groups.values()):
                    raise MeshError(f"{path.name} has no physical {region}: name the body's region(s) with "
                                    f"Physical {region.capitalize()}(\"name\") so that its cells are kept")
                owner = {}          # an entity in two physical groups of cells would duplicate its cells
                for name, (dim, tag) in groups.items():
                    for e in (gmsh.model.getEntitiesForPhysicalGroup(gdim, tag) if dim == gdim else ()):
                        if e in owner:
                            raise MeshError(f"{path.name}: physical {region}s {owner[e]!r} and {name!r} share "
                                            f"{region} {e}: regions must not overlap (a cell lies in one region)")
                        owner[e] = name
                if gdim == 3:
                    _require_hexahedra(path.name, groups)
            except MeshError as e:
                error = str(e)
            except Exception as e:     # gmsh raises plain Exception with its last error
                log = [m for m in gmsh.logger.get() if "rror" in m]
                error = f"Gmsh cannot mesh {path.name}: {(log[-1] if log else str(e)).strip()}"
        else:
            gmsh.model.add(path.stem)
        error, groups = comm.bcast((error, groups), root=0)
        if error is not None:
            raise MeshError(error)
        mesh, cell_tags, facet_tags = gmshio.model_to_mesh(gmsh.model, comm, 0, gdim=gdim)
    finally:
        gmsh.logger.stop()
        gmsh.finalize()
    mesh.name = path.stem
    cell_tags.name = "cell_tags"
    facet_tags.name = "facet_tags"
    return mesh, cell_tags, facet_tags, groups
