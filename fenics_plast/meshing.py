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
