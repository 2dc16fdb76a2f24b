"""Parametric Gmsh geometries (meshes/*.geo) -> dolfinx meshes and tags.

The .geo files are the single definition of each geometry: their ``DefineConstant``
parameters are set through ONELAB ("Parameters/<name>") before the file is opened, on
rank 0 only; the mesh is distributed with ``dolfinx.io.gmshio.model_to_mesh``.
Every function returns ``(mesh, cell_tags, facet_tags, tag_ids)`` with ``tag_ids`` the
map physical-group name -> integer tag (cells and facets).

A mesh file is screened (:mod:`fenics_plast.geo_screen`) before Gmsh reads it: a script that runs
programs or touches files is refused (:class:`MeshError`) unless the caller trusts it.
"""
from __future__ import annotations

import math
import os
import re
from pathlib import Path

import gmsh
from dolfinx.io import gmshio

from .geo_screen import MESH_DIR, GeoScreenError, screen
from .gmsh_session import gmsh_session
from .schema import default, is_cell_count


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


def refined(parameters: dict, refine: int) -> dict:
    """The .geo parameters with ``refine`` applied: each cell count (a name that starts with ``cells`` or
    ends in ``_cells``, :func:`fenics_plast.schema.is_cell_count`) multiplied by it."""
    return {k: (v * refine if is_cell_count(k) else v) for k, v in parameters.items()}


#: a number in a .geo file's DefineConstant
_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_DEFINE = re.compile(r"\{([^{}]*?)\bName\s*\"Parameters/([^\"]+)\"([^{}]*)\}")


_INCLUDE = re.compile(r'\bInclude\s*"([^"]+)"\s*;')
_MAX_INCLUDES = 1000    # files read through Includes: a bound, so that a cycle ends
_MAX_INCLUDE_BYTES = 16 << 20   # a larger Include'd file is not read for its parameters (no .geo is that big)


def geo_parameters(path, _seen: set | None = None) -> dict[str, dict]:
    """The ``DefineConstant`` parameters "Parameters/<name>" written in a .geo file and the files it
    Includes (resolved next to the including file, read where the Include stands), read from their text
    (Gmsh is not run): {name: {"value": default, "min": ..., "max": ...}}, each entry present when the
    file writes it as a number (``x = {1.5, Min 0, Max 2, Name "Parameters/x"}``). As in Gmsh, the first
    definition of a name counts. Comments are skipped; an Include that is missing, not a regular file or
    over 16 MiB is skipped (the mesh screen and Gmsh report what is wrong with it)."""
    path = Path(path)
    seen = set() if _seen is None else _seen
    if path.resolve() in seen or len(seen) >= _MAX_INCLUDES:
        return {}
    seen.add(path.resolve())
    text = path.read_text(encoding="utf-8", errors="replace")
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    text = re.sub(r"//[^\n]*", " ", text)
    statements = sorted([(m.start(), m) for m in _DEFINE.finditer(text)]
                        + [(m.start(), m) for m in _INCLUDE.finditer(text)], key=lambda e: e[0])
    out: dict[str, dict] = {}
    for _, m in statements:
        if m.re is _INCLUDE:
            included = path.parent / m.group(1)
            if included.is_file() and included.stat().st_size <= _MAX_INCLUDE_BYTES:
                for name, info in geo_parameters(included, seen).items():
                    out.setdefault(name, info)
            continue
        inside, info = m.group(1) + " " + m.group(3), {}
        first = re.match(rf"\s*({_NUMBER})\s*,", m.group(1))
        if first:
            info["value"] = float(first.group(1))
        for key in ("Min", "Max"):
            found = re.search(rf"\b{key}\s+({_NUMBER})", inside)
            if found:
                info[key.lower()] = float(found.group(1))
        out.setdefault(m.group(2), info)
    return out


def machine_memory() -> int | None:
    """The machine's physical memory [bytes] (os.sysconf), or None where it cannot be read."""
    try:
        return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


def _trial_cells(path, values, gdim) -> int:
    """Cells of dimension ``gdim`` Gmsh makes of the .geo with these parameter values (rank 0; gmsh
    initialized, left cleared)."""
    gmsh.clear()
    gmsh.onelab.clear()
    for key, value in values.items():
        gmsh.onelab.setNumber(f"Parameters/{key}", [float(value)])
    gmsh.open(str(path))
    gmsh.model.geo.synchronize()
    gmsh.model.mesh.generate(gdim)
    n = sum(len(t) for t in gmsh.model.mesh.getElements(gdim)[1])
    gmsh.clear()
    gmsh.onelab.clear()
    return n


def estimate_cells(path, values: dict, gdim: int, large: int = 64) -> float | None:
    """About how many cells Gmsh makes of the .geo ``path`` with the parameter ``values`` (after
    refine), without meshing it: the cell counts above ``large`` are scaled down by one factor s (the
    smallest of them to 16 or the largest to 64 in 3-D, 256 in 2-D, whichever is smaller), the file
    meshed with them and with them halved, and the number of cells extrapolated with the power of s
    the two trials give (1 when one count grows, 2 when two do in 2-D, ...). None when no given count
    is above ``large`` or Gmsh cannot mesh the trials (the real meshing reports that). Rank 0 only;
    Gmsh must not be initialized by the caller."""
    big = {k: float(v) for k, v in values.items() if is_cell_count(k) and float(v) > large}
    if not big:
        return None
    if max(big.values()) > 1e15:        # (not finite after refine, or beyond any trial's precision)
        return math.inf
    s1 = max(min(big.values()) / 16, max(big.values()) / (64 if gdim == 3 else 256))

    def scaled(s):
        return {**values, **{k: max(1, round(c / s)) for k, c in big.items()}}
    try:
        with gmsh_session():
            n1, n2 = _trial_cells(path, scaled(s1), gdim), _trial_cells(path, scaled(2 * s1), gdim)
    except Exception:  # noqa: BLE001 - gmsh raises plain Exception; the real meshing reports it
        return None
    if n1 <= 0 or n2 <= 0:
        return None
    power = min(max(math.log2(n1 / n2), 0.0), float(gdim))
    return n1 * s1 ** power


class MeshError(ValueError):
    """A mesh file cannot be read or meshed, or names a parameter it does not define."""


_GMSH_HEXAHEDRON = 5
_GMSH_QUADRANGLE = 3


def _require_hexahedra(name, groups, gdim=3):
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


def mesh_from_file(comm, path, parameters=None, refine=default("mesh.refine"), gdim=2, trust_script=False,
                   scene_dir=None):
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
    values = refined(parameters, refine)
    if gdim not in (2, 3):
        raise ValueError(f"gdim must be 2 or 3, got {gdim}")
    region = "surface" if gdim == 2 else "volume"
    with gmsh_session(log=True):
        error, groups = None, {}
        if comm.rank == 0:
            try:
                if not trust_script:
                    screen(path, scene_dir)
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
                _require_hexahedra(path.name, groups, gdim)
            except (MeshError, GeoScreenError) as e:
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
    mesh.name = path.stem
    cell_tags.name = "cell_tags"
    facet_tags.name = "facet_tags"
    return mesh, cell_tags, facet_tags, groups
