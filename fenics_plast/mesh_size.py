"""How large a mesh a Gmsh ``.geo`` makes, found before meshing it: the ``DefineConstant`` parameters the
file declares (:func:`geo_parameters`, read from its text) and the number of cells its parameters
(:func:`estimate_cells`) or the element sizes it sets (:func:`estimate_cells_from_sizes`) make, from
two coarse trial meshings in a child process (:func:`fenics_plast.gmsh_child.in_child`). The scene's
mesh checks (:func:`fenics_plast.scene_mesh.check_mesh_parameters`) refuse a mesh that cannot fit
in the machine's memory with these. Rank 0 only; Gmsh must not be initialized by the caller.
"""
from __future__ import annotations

import math
import re
from pathlib import Path

import gmsh

from .gmsh_child import in_child
from .gmsh_session import gmsh_session
from .schema import is_cell_count

__all__ = ["geo_parameters", "estimate_cells", "estimate_cells_from_sizes"]


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
