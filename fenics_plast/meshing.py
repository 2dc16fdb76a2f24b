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


def mesh_from_file(comm, path, parameters=None, refine=1, gdim=2):
    """A dolfinx mesh and its named groups from a Gmsh ``.geo`` (meshed here) or ``.msh`` file.

    ``parameters`` (name -> number) set the .geo's ``DefineConstant`` values "Parameters/<name>";
    ``refine`` multiplies those whose name starts with ``cells`` (rounded to an integer). A name
    the file does not define, a .msh with parameters or refine, and Gmsh's own errors raise
    :class:`MeshError` with Gmsh's message. Returns ``(mesh, cell_tags, facet_tags, groups)`` with
    ``groups`` = {physical name: (dim, tag)} (dim 2: cell regions, dim 1: facet groups).
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
                    gmsh.model.mesh.generate(2)
                for dim, tag in gmsh.model.getPhysicalGroups():
                    groups[gmsh.model.getPhysicalName(dim, tag)] = (dim, tag)
                if not any(d == 2 for d, _ in groups.values()):
                    raise MeshError(f"{path.name} has no physical surface: name the body's region(s) with "
                                    f"Physical Surface(\"name\") so that its cells are kept")
                owner = {}          # a surface in two physical surfaces would duplicate its cells
                for name, (dim, tag) in groups.items():
                    for e in (gmsh.model.getEntitiesForPhysicalGroup(2, tag) if dim == 2 else ()):
                        if e in owner:
                            raise MeshError(f"{path.name}: physical surfaces {owner[e]!r} and {name!r} share "
                                            f"surface {e}: regions must not overlap (a cell lies in one region)")
                        owner[e] = name
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
