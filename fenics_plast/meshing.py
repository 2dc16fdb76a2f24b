"""Parametric Gmsh geometries (meshes/*.geo) -> dolfinx meshes and tags.

The .geo files are the single definition of each geometry: their ``DefineConstant``
parameters are set through ONELAB ("Parameters/<name>") before the file is opened, on
rank 0 only; the mesh is distributed with ``dolfinx.io.gmshio.model_to_mesh``.
Every function returns ``(mesh, cell_tags, facet_tags, tag_ids)`` with ``tag_ids`` the
map physical-group name -> integer tag (cells and facets).

A mesh file is screened (:mod:`fenics_plast.geo_screen`) before Gmsh reads it: a script that runs
programs or touches files is refused (:class:`MeshError`) unless the caller trusts it. A scene's mesh
file is meshed in a child process (:mod:`fenics_plast.gmsh_child`) and its Gmsh model checked before
it is distributed (:mod:`fenics_plast.gmsh_model_checks`); how large a mesh a .geo makes is found
beforehand by :mod:`fenics_plast.mesh_size`.
"""
from __future__ import annotations

import contextlib
import math
import os
import tempfile
from pathlib import Path

import gmsh
from dolfinx.io import gmshio

from .geo_screen import MESH_DIR, GeoScreenError, mesh_file_kind, screen
from .gmsh_child import MeshError, in_child
from .gmsh_model_checks import check_facet_groups, require_linear_cells
from .gmsh_session import gmsh_session
from .schema import default, is_cell_count

__all__ = ["MeshError", "mesh_from_file", "mesh_from_geo", "bar_mesh", "blank_mesh", "ring_mesh", "refined",
           "geo_path"]


def geo_path(name: str) -> Path:
    p = MESH_DIR / f"{name}.geo"
    if not p.exists():
        raise FileNotFoundError(f"geometry file {p} not found")
    return p


def mesh_from_geo(comm, name: str, parameters: dict, gdim: int = 2):
    """Mesh meshes/<name>.geo with the given ONELAB parameters ("Parameters/<key>")."""
    path = geo_path(name)
    try:
        screen(path)
    except GeoScreenError as e:
        raise MeshError(str(e)) from None
    with gmsh_session():
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


def refined(parameters: dict, refine: float) -> dict:
    """The .geo parameters with ``refine`` applied: each cell count (a name that starts with ``cells`` or
    ends in ``_cells``, :func:`fenics_plast.schema.is_cell_count`) multiplied by it, rounded to the
    nearest integer and at least 1 (refine 1.5: 6 cells -> 9; an integer refine keeps the exact product)."""
    def count(v):
        if isinstance(refine, int) or float(refine).is_integer():
            return v * int(refine)
        x = v * refine
        return max(1, int(round(x))) if math.isfinite(x) and x < 2 ** 62 else x
    return {k: (count(v) if is_cell_count(k) else v) for k, v in parameters.items()}


def _mesh_in_child(path, opened, suffix, values, gdim, msh):
    """(In the child of :func:`fenics_plast.gmsh_child.in_child`) Gmsh reads ``opened`` (the file ``path``
    names) with the parameter ``values``, meshes a .geo, and writes the mesh to ``msh`` (binary MSH 4.1,
    unscaled)."""
    with gmsh_session(log=True):
        try:
            if values:     # the names the file defines: open it once without ours
                gmsh.open(str(opened))
                known = {n.split("/", 1)[1] for n in gmsh.onelab.getNames("Parameters/.*")}
                unknown = sorted(set(values) - known)
                if unknown:
                    raise MeshError(f"{path.name} defines no parameter {', '.join(unknown)} "
                                    f"(its parameters: {', '.join(sorted(known)) or 'none'})")
                gmsh.clear()
                gmsh.onelab.clear()
            for key, value in values.items():
                gmsh.onelab.setNumber(f"Parameters/{key}", [float(value)])
            gmsh.open(str(opened))
            if suffix == ".geo":
                gmsh.model.geo.synchronize()
                gmsh.model.mesh.generate(gdim)
            for option, value in (("Mesh.Binary", 1), ("Mesh.MshFileVersion", 4.1), ("Mesh.ScalingFactor", 1),
                                  ("Mesh.SaveAll", 0), ("Mesh.SaveParametric", 0)):
                gmsh.option.setNumber(option, value)
            gmsh.write(msh)
        except MeshError:
            raise
        except Exception as e:     # gmsh raises plain Exception with its last error
            log = [m for m in gmsh.logger.get() if "rror" in m]
            raise MeshError(f"Gmsh cannot mesh {path.name}: {(log[-1] if log else str(e)).strip()}") from None


def mesh_from_file(comm, path, parameters=None, refine=default("mesh.refine"), gdim=2, trust_script=False,
                   scene_dir=None, used_groups=None):
    """A dolfinx mesh and its named groups from a Gmsh ``.geo`` (meshed here) or ``.msh`` file.

    ``parameters`` (name -> number) set the .geo's ``DefineConstant`` values "Parameters/<name>";
    ``refine`` multiplies the cell counts among them (:func:`refined`). A name
    the file does not define, a .msh with parameters or refine, and Gmsh's own errors raise
    :class:`MeshError` with Gmsh's message. ``gdim``: 2 (quadrilaterals; physical surfaces are the cell
    regions, physical curves the facet groups) or 3 (hexahedra only, meshed with ``generate(3)``;
    physical volumes are the cell regions, physical surfaces the facet groups). Returns
    ``(mesh, cell_tags, facet_tags, groups)`` with ``groups`` = {physical name: (dim, tag)} (dim = gdim:
    cell regions, dim = gdim - 1: facet groups).

    The file is screened first (:func:`fenics_plast.geo_screen.screen`, rank 0, before Gmsh reads it):
    a command that runs programs or touches files, or an Include or Merge outside ``scene_dir`` (the
    scene file's folder; default: the mesh file's) and the package's meshes/, raises
    :class:`MeshError` naming the file, line and command. ``trust_script=True`` skips the screen.

    Gmsh reads and meshes the file in a child process (:func:`fenics_plast.gmsh_child.in_child`, its
    memory capped), which
    writes the mesh as a .msh into a private temporary folder that this process reads: Gmsh dying
    (a signal, out of memory) is a MeshError. The facet groups are checked before the mesh is
    distributed (:func:`fenics_plast.gmsh_model_checks.check_facet_groups`): two groups sharing a facet (a line in 2-D, a surface
    in 3-D, or the same facet element), when ``used_groups`` (group name -> the scene key naming it;
    None: every group is used) names one of them (a facet has one tag in dolfinx's mesh: the other
    group would come out without it), and a group with elements whose nodes lie on no cell of the body
    (dolfinx cannot distribute it) raise MeshError naming both groups (and the key).
    """
    path = Path(path)
    parameters = dict(parameters or {})
    if not path.exists():
        raise MeshError(f"mesh file {path} not found")
    opened, suffix = mesh_file_kind(path)     # links resolved: Gmsh opens the file the screen reads (issue 34)
    if suffix not in (".geo", ".msh"):
        raise MeshError(f"mesh file {path}: must end in .geo or .msh"
                        + (f" (it is a symbolic link to {opened})" if opened.name != path.name else ""))
    if suffix == ".msh" and (parameters or refine != 1):
        raise MeshError(f"mesh file {path}: a .msh file takes no parameters and no refine (use a .geo)")
    values = refined(parameters, refine)
    if gdim not in (2, 3):
        raise ValueError(f"gdim must be 2 or 3, got {gdim}")
    region = "surface" if gdim == 2 else "volume"
    error, groups = None, {}
    with contextlib.ExitStack() as stack:
        if comm.rank == 0:
            folder = stack.enter_context(tempfile.TemporaryDirectory(prefix="fenics-plast-mesh-"))
            msh = os.path.join(folder, "mesh.msh")
            try:
                if not trust_script:
                    screen(path, scene_dir)
                in_child(path.name, _mesh_in_child, path, opened, suffix, values, gdim, msh)
            except (MeshError, GeoScreenError) as e:
                error = str(e)
        stack.enter_context(gmsh_session(log=True))
        if comm.rank == 0 and error is None:
            try:
                gmsh.open(msh)
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
                require_linear_cells(path.name, groups, gdim)
                check_facet_groups(path.name, groups, gdim, used_groups)
            except MeshError as e:
                error = str(e)
            except Exception as e:     # gmsh raises plain Exception with its last error
                log = [m for m in gmsh.logger.get() if "rror" in m]
                error = f"Gmsh cannot read the mesh of {path.name}: {(log[-1] if log else str(e)).strip()}"
        elif comm.rank != 0:
            gmsh.model.add(path.stem)
        error, groups = comm.bcast((error, groups), root=0)
        if error is not None:
            raise MeshError(error)
        mesh, cell_tags, facet_tags = gmshio.model_to_mesh(gmsh.model, comm, 0, gdim=gdim)
    mesh.name = path.stem
    cell_tags.name = "cell_tags"
    facet_tags.name = "facet_tags"
    return mesh, cell_tags, facet_tags, groups
