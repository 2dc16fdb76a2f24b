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

import contextlib
import math
import os
import re
import tempfile
from pathlib import Path

import gmsh
import numpy as np
from dolfinx.io import gmshio

from .geo_screen import MESH_DIR, GeoScreenError, mesh_file_kind, screen
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
    n = _cells(gdim)
    gmsh.clear()
    gmsh.onelab.clear()
    return n


def _cells(gdim) -> int:
    return sum(len(t) for t in gmsh.model.mesh.getElements(gdim)[1])


def _count_trials(path, values, gdim, large):
    """The two trial meshings of :func:`estimate_cells` (in the child): (s1, n1, n2) or None."""
    big = {k: float(v) for k, v in values.items() if is_cell_count(k) and float(v) > large}
    s1 = max(min(big.values()) / 16, max(big.values()) / (64 if gdim == 3 else 256))

    def scaled(s):
        return {**values, **{k: max(1, round(c / s)) for k, c in big.items()}}
    try:
        with gmsh_session():
            return s1, _trial_cells(path, scaled(s1), gdim), _trial_cells(path, scaled(2 * s1), gdim)
    except Exception:  # noqa: BLE001 - gmsh raises plain Exception; the real meshing reports it
        return None


def estimate_cells(path, values: dict, gdim: int, large: int = 64) -> float | None:
    """About how many cells Gmsh makes of the .geo ``path`` with the parameter ``values`` (after
    refine), without meshing it: the cell counts above ``large`` are scaled down by one factor s (the
    smallest of them to 16 or the largest to 64 in 3-D, 256 in 2-D, whichever is smaller), the file
    meshed with them and with them halved, and the number of cells extrapolated with the power of s
    the two trials give (1 when one count grows, 2 when two do in 2-D, ...). None when no given count
    is above ``large`` or Gmsh cannot mesh the trials (the real meshing reports that). Rank 0 only;
    Gmsh must not be initialized by the caller. The trials run in a child process
    (:func:`in_child`): MeshError when Gmsh dies in them."""
    big = {k: float(v) for k, v in values.items() if is_cell_count(k) and float(v) > large}
    if not big:
        return None
    if max(big.values()) > 1e15:        # (not finite after refine, or beyond any trial's precision)
        return math.inf
    trials = in_child(Path(path).name, _count_trials, path, values, gdim, large)
    if trials is None:
        return None
    s1, n1, n2 = trials
    if n1 <= 0 or n2 <= 0:
        return None
    power = min(max(math.log2(n1 / n2), 0.0), float(gdim))
    return n1 * s1 ** power


#: Gmsh's default Mesh.MeshSizeMax (no bound)
_NO_SIZE = 1e21


def _size_trials(path, values, gdim, large):
    """What :func:`estimate_cells_from_sizes` computes, in the child: (cells, what) or None."""
    values = {k: (min(float(v), large) if is_cell_count(k) else v) for k, v in values.items()}
    try:
        with gmsh_session():
            for key, value in values.items():
                gmsh.onelab.setNumber(f"Parameters/{key}", [float(value)])
            gmsh.open(str(path))
            gmsh.model.geo.synchronize()
            size_max = gmsh.option.getNumber("Mesh.MeshSizeMax")
            factor = gmsh.option.getNumber("Mesh.MeshSizeFactor")
            h = size_max * factor
            if not size_max < _NO_SIZE or not h > 0:
                return None
            x0, y0, z0, x1, y1, z1 = gmsh.model.getBoundingBox(-1, -1)
            span = math.sqrt((x1 - x0) ** 2 + (y1 - y0) ** 2 + (z1 - z0) ** 2)
            h2 = span / 32
            if not h < h2:
                return None
            gmsh.option.setNumber("Mesh.MeshSizeFactor", 1.0)
            gmsh.option.setNumber("Mesh.MeshSizeMin", 0.0)
            counts = []
            for trial in (2 * h2, h2):
                gmsh.model.mesh.clear()
                gmsh.option.setNumber("Mesh.MeshSizeMax", trial)
                gmsh.model.mesh.generate(gdim)
                counts.append(_cells(gdim))
    except Exception:  # noqa: BLE001 - gmsh raises plain Exception; the real meshing reports it
        return None
    n1, n2 = counts
    if n1 <= 0 or n2 <= n1:
        return None                     # (the sizes do not change the mesh: transfinite)
    power = min(math.log2(n2 / n1), float(gdim))
    what = f"Mesh.MeshSizeMax = {size_max:g}" + (f" times Mesh.MeshSizeFactor = {factor:g}" if factor != 1 else "")
    return n2 * (h2 / h) ** power, what


def estimate_cells_from_sizes(path, values: dict, gdim: int, large: int = 64):
    """About how many cells the element sizes the .geo ``path`` sets make (``Mesh.MeshSizeMax``, alias
    ``Mesh.CharacteristicLengthMax``, times ``Mesh.MeshSizeFactor``, as they stand once the file is
    read with the parameter ``values``, cell counts above ``large`` lowered to it): the file meshed with
    the largest size 1/16 and 1/32 of its bounding box's diagonal, the number of cells extrapolated to
    the file's size with the power the two trials give (0 for a transfinite mesh). Returns
    ``(cells, "Mesh.MeshSizeMax = ...")`` or None (no bound on the size set, the size coarser than the
    trials, or Gmsh cannot mesh the trials: the real meshing reports that). Rank 0 only; the trials run
    in a child process (:func:`in_child`)."""
    return in_child(Path(path).name, _size_trials, path, values, gdim, large)


class MeshError(ValueError):
    """A mesh file cannot be read or meshed, or names a parameter it does not define."""


#: the memory Gmsh may take in its child process, beyond what the run's process already maps: this share
#: of the machine's memory (:func:`in_child`)
CHILD_MEMORY_SHARE = 0.75


def _mapped_bytes() -> int:
    """The address space this process maps now [bytes] (/proc/self/statm; 0 where it cannot be read)."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


def _memory_cap() -> int | None:
    """The address-space limit of the Gmsh child [bytes]: what is mapped now plus
    :data:`CHILD_MEMORY_SHARE` of the machine's memory (None: no limit)."""
    memory = machine_memory()
    if not memory:
        return None
    return _mapped_bytes() + int(CHILD_MEMORY_SHARE * memory)


def in_child(what: str, fn, *args):
    """``fn(*args)`` run in a forked child process whose address space is capped (:func:`_memory_cap`), so
    that Gmsh dying (a signal, an abort, running out of memory) ends the child, not the run; returns
    ``fn``'s (picklable) result. A :class:`MeshError` in the child is raised again here; any other
    exception, and the child dying, raise MeshError naming ``what`` (the file being meshed):
    "Gmsh died (signal 11, SIGSEGV) while meshing <what>", "... (out of memory: ...)". Call it on one
    rank only (it uses no MPI); the child leaves with ``os._exit`` (no MPI, no atexit, no flush)."""
    import pickle
    import resource
    import signal
    import warnings
    cap = _memory_cap()
    err = tempfile.TemporaryFile()      # the child's stderr (what a dying Gmsh or C++ runtime says)
    r, w = os.pipe()
    with warnings.catch_warnings():     # (Python >= 3.12 warns of fork in a process with threads)
        warnings.simplefilter("ignore", DeprecationWarning)
        pid = os.fork()
    if pid == 0:                        # the child
        status = 0
        try:
            os.close(r)
            os.dup2(err.fileno(), 2)
            import faulthandler
            faulthandler.disable()      # (pytest's) and MPI's crash handlers: the parent reports the signal
            for sig in (signal.SIGSEGV, signal.SIGABRT, signal.SIGBUS, signal.SIGFPE, signal.SIGILL):
                signal.signal(sig, signal.SIG_DFL)
            if cap is not None:
                hard = resource.getrlimit(resource.RLIMIT_AS)[1]
                resource.setrlimit(resource.RLIMIT_AS, (cap if hard == resource.RLIM_INFINITY else
                                                        min(cap, hard), hard))
            try:
                out = ("ok", fn(*args))
            except MeshError as e:
                out = ("error", str(e))
            except MemoryError:
                out = ("memory", None)
            except BaseException as e:  # noqa: BLE001 - reported by the parent
                out = ("error", f"Gmsh cannot mesh {what}: {type(e).__name__}: {e}")
            data = pickle.dumps(out)
            with os.fdopen(w, "wb") as f:
                f.write(data)
        except BaseException:           # noqa: BLE001 - the parent reports the child's status
            status = 70
        finally:
            os._exit(status)
    os.close(w)
    with os.fdopen(r, "rb") as f:
        data = f.read()
    while True:
        try:
            _, status, usage = os.wait4(pid, 0)
            break
        except InterruptedError:
            continue
    with err:
        err.seek(0)
        said = [line.strip() for line in err.read()[-4000:].decode("utf-8", "replace").splitlines() if line.strip()]
    limit = f"its limit {cap / 2**30:.3g} GiB of address space" if cap else "no limit set"
    peak = usage.ru_maxrss * 1024
    if data:
        kind, value = pickle.loads(data)
        if kind == "ok":
            return value
        if kind == "memory":
            raise MeshError(f"Gmsh ran out of memory while meshing {what} ({limit}; it had taken "
                            f"{peak / 2**30:.3g} GiB): the mesh is too fine for this machine")
        raise MeshError(value)
    memory = machine_memory() or 0
    oom = (any("bad_alloc" in line or "emory" in line for line in said)
           or memory and peak > 0.5 * CHILD_MEMORY_SHARE * memory)
    last = f": {said[-1][:300]}" if said else ""
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        try:
            name = signal.Signals(sig).name
        except ValueError:
            name = "unknown signal"
        why = (f"out of memory: {limit}, it had taken {peak / 2**30:.3g} GiB" if oom else
               f"signal {sig}, {name}")
        raise MeshError(f"Gmsh died ({why}) while meshing {what}{last}")
    code = os.WEXITSTATUS(status) if os.WIFEXITED(status) else status
    raise MeshError(f"Gmsh ended (exit status {code}{', out of memory' if oom else ''}) while meshing {what} "
                    f"without a mesh (an Exit command in the file ends the process that reads it)")


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



def _mesh_in_child(path, opened, suffix, values, gdim, msh):
    """(In the child of :func:`in_child`) Gmsh reads ``opened`` (the file ``path`` names) with the
    parameter ``values``, meshes a .geo, and writes the mesh to ``msh`` (binary MSH 4.1, unscaled)."""
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


def _element_rows(dim, entity):
    """{nodes per element: sorted node tags (n, k)} of the elements of one entity."""
    out = {}
    types, _, nodes = gmsh.model.mesh.getElements(dim, entity)
    for t, nd in zip(types, nodes):
        k = gmsh.model.mesh.getElementProperties(t)[3]
        rows = np.sort(np.asarray(nd, dtype=np.int64).reshape(-1, k), axis=1)
        out.setdefault(k, []).append(rows)
    return {k: np.concatenate(v) for k, v in out.items()}


def _check_facet_groups(name, groups, gdim, used):
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

    Gmsh reads and meshes the file in a child process (:func:`in_child`, its memory capped), which
    writes the mesh as a .msh into a private temporary folder that this process reads: Gmsh dying
    (a signal, out of memory) is a MeshError. The facet groups are checked before the mesh is
    distributed (:func:`_check_facet_groups`): two groups sharing a facet (a line in 2-D, a surface
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
                _require_hexahedra(path.name, groups, gdim)
                _check_facet_groups(path.name, groups, gdim, used_groups)
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
