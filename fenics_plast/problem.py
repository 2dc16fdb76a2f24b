"""Scene files: TOML -> validated :class:`Problem` (one format for every problem).

A scene file describes a problem the way an Abaqus or CalculiX deck does, as TOML data: the mesh
(a Gmsh file whose physical groups name the regions and boundaries), materials per region,
boundary conditions and loads on named facet groups, rigid tools and contact pairs, load steps,
and the quantities to record. Nothing in it is ever executed: values that vary in space or time
are numbers, tables or expressions read by :mod:`fenics_plast.expressions` (a whitelisting
parser, not ``eval``).

Every key is declared once, in :data:`fenics_plast.schema.SCHEMA`, with its type, default, range
or choices, unit and meaning; :mod:`fenics_plast.validation` checks the data against it, and the
key reference (``fenics-plast keys``, docs/SCENE_KEYS.md) is generated from it. This module reads
the file, applies the ``--set`` overrides and builds the :class:`Problem`.

Sections:

* single tables: ``[scene]``, ``[analysis]``, ``[mesh]`` (+ its free table ``[mesh.parameters]``),
  ``[output]``;
* named collections, one sub-table per user-chosen name: ``[materials.<name>]`` (+ ``.hardening``),
  ``[boundary.<name>]``, ``[initial_velocity.<name>]``, ``[tools.<name>]``, ``[contact.<name>]``,
  ``[steps.<name>]``, ``[outputs.<name>]``, ``[plots.<name>]``. Names are what ``--set`` and
  ``study --vary`` address, e.g. ``--set contact.punch.friction=0.15``.

Units inside the package: mm, N, MPa, s, tonne/mm^3. Converted on reading (the value as written is
kept under ``<key>_as_written``): densities in kg/m^3, velocities in m/s, explicit times in us.
This module knows nothing of dolfinx; group names are checked against the mesh by the runner.
"""
from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable

from fenics_plast.errors import SceneError
from fenics_plast.validation import Section, validate_tables

__all__ = ["SceneError", "Problem", "load_problem", "parse_problem", "apply_overrides"]


@dataclass
class Problem:
    """A validated scene file. Single tables are :class:`Section`; collections are dicts name ->
    Section (in file order; ``steps`` sorted by ``end``); absent optional tables are None / {}."""
    path: Path
    name: str
    tables: dict[str, Any]
    overrides: tuple[str, ...] = field(default_factory=tuple)

    def __getattr__(self, key: str):
        tables = self.__dict__.get("tables", {})
        if key in tables:
            return tables[key]
        raise AttributeError(f"Problem has no attribute {key!r}")

    @property
    def explicit(self) -> bool:
        return self.tables["analysis"].type == "explicit"

    @property
    def mesh_file(self) -> Path:
        """The mesh file, resolved against the scene file's folder."""
        p = Path(self.tables["mesh"].file)
        return p if p.is_absolute() else (self.path.parent / p)

    @property
    def active_physics(self) -> list[str]:
        """What the problem assembles: plasticity, inertia, contact, friction, tractions, walls (rigid
        walls' stops), erosion (element erosion in the force pass), heat conduction ([thermal])."""
        phys = set()
        if any(m.hardening is not None for m in self.materials.values()):
            phys.add("plasticity")
        if self.explicit:
            phys.add("inertia")
        if self.contact:
            phys.add("contact")
            if any(c.friction > 0 for c in self.contact.values()):
                phys.add("friction")
        if any(b.type in ("traction", "pressure") for b in self.boundary.values()):
            phys.add("tractions")
        if any(b.type == "wall" for b in self.boundary.values()):
            phys.add("walls")
        if self.explicit and self.analysis.erosion_ratio > 0.0:
            phys.add("erosion")
        if self.tables.get("thermal") is not None:
            phys.add("heat conduction")
        return sorted(phys)

    def to_dict(self) -> dict[str, Any]:
        out = {}
        for k, v in self.tables.items():
            if isinstance(v, Section):
                out[k] = v.to_dict()
            elif isinstance(v, dict):
                out[k] = {n: s.to_dict() for n, s in v.items()}
            else:
                out[k] = v
        return out



# ----------------------------------------------------------------------------------------------
# Overrides and loading


def _parse_override(text: str, where: str) -> tuple[list[str], Any]:
    if "=" not in text:
        raise SceneError(f"{where}: --set {text!r} must have the form section.key=value")
    dotted, value = text.split("=", 1)
    parts = dotted.strip().split(".")
    if len(parts) < 2 or any(not p for p in parts):
        raise SceneError(f"{where}: --set {text!r}: {dotted.strip()!r} must be a dotted key such as "
                         f"analysis.rtol")
    try:
        parsed = tomllib.loads(f"v = {value.strip()}")["v"]
    except (ValueError, RecursionError):     # not TOML (TOMLDecodeError is a ValueError): a string
        parsed = value.strip()
    return parts, parsed


def apply_overrides(raw: dict, overrides: Iterable[str], where: str) -> dict:
    """Apply ``--set`` texts ``a.b.c=value`` to the raw TOML dict. A part ``*`` stands for every
    table at that level (``contact.*.friction=0.15`` sets the friction of every contact pair)."""
    for text in overrides:
        parts, value = _parse_override(text, where)
        targets = [raw]
        for i, p in enumerate(parts[:-1]):
            nxt = []
            for d in targets:
                if p == "*":
                    subs = [v for v in d.values() if isinstance(v, dict)]
                    if not subs:
                        raise SceneError(f"{where}: --set {text!r}: {'.'.join(parts[:i]) or 'the scene'} has "
                                         f"no tables for '*' to stand for")
                    nxt += subs
                    continue
                sub = d.setdefault(p, {})
                if not isinstance(sub, dict):
                    raise SceneError(f"{where}: --set {text!r}: {'.'.join(parts[:i + 1])} is not a table")
                nxt.append(sub)
            targets = nxt
        for d in targets:
            d[parts[-1]] = value
    return raw


def _check_integers(raw, where: str, path: str = "") -> None:
    """Refuse integers outside the 64-bit range anywhere in the raw TOML (they overflow when read as
    numbers): a SceneError naming the dotted key."""
    items = raw.items() if isinstance(raw, dict) else enumerate(raw) if isinstance(raw, list) else ()
    for k, v in items:
        key = f"{path}[{k}]" if isinstance(k, int) else (f"{path}.{k}" if path else str(k))
        if isinstance(v, int) and not isinstance(v, bool) and abs(v) >= 2 ** 63:
            raise SceneError(f"{where}: {key}: an integer of {v.bit_length()} bits is out of range (|n| < 2^63)")
        _check_integers(v, where, key)


def parse_with(validate, text: str, path: str | Path = "<string>", overrides: Iterable[str] = ()):
    """TOML text -> ``validate(raw, where, path, overrides)`` after the ``--set`` overrides; an error on
    a key that came from the command line says so."""
    path = Path(path)
    where = str(path)
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise SceneError(f"{where}: TOML syntax error: {e}") from None
    except ValueError as e:             # an integer of more than 4300 digits (Python's conversion limit)
        raise SceneError(f"{where}: an integer is too long to read: {str(e).split(';')[0]}") from None
    except RecursionError:
        raise SceneError(f"{where}: the file nests too deeply") from None
    overrides = tuple(overrides)
    apply_overrides(raw, overrides, where)
    try:
        _check_integers(raw, where)
        return validate(raw, where, path, overrides)
    except SceneError as e:
        msg = str(e)
        body = msg[len(where) + 2:] if msg.startswith(where + ": ") else msg
        for o in overrides:
            key = o.split("=", 1)[0].strip()
            if body == key or body.startswith(key + " ") or body.startswith(key + ":") or body.startswith(key + "["):
                raise SceneError(f"{msg} (from --set {o})") from None
        raise
    except RecursionError:
        raise SceneError(f"{where}: the file nests too deeply") from None


def read_scene_file(path: str | Path) -> str:
    """The text of a scene file; SceneError naming the file when it cannot be read."""
    path = Path(path)
    try:
        return path.read_text(encoding="utf-8")
    except OSError as e:
        raise SceneError(f"{path}: cannot read scene file: {e.strerror or e}") from None
    except UnicodeDecodeError as e:
        raise SceneError(f"{path}: not UTF-8 text: {e}") from None


def _validate(raw: dict, where: str, path: Path, overrides: tuple[str, ...]) -> Problem:
    tables = validate_tables(raw, where)
    return Problem(path=path, name=tables["scene"].name, tables=tables, overrides=overrides)


def parse_problem(text: str, path: str | Path = "<string>", overrides: Iterable[str] = ()) -> Problem:
    """Validate TOML text (``path`` names it in messages and resolves the mesh file)."""
    return parse_with(_validate, text, path, overrides)


def load_problem(path: str | Path, overrides: Iterable[str] = ()) -> Problem:
    """Read and validate a scene file; ``overrides`` are ``"a.b.c=value"`` strings (``--set``)."""
    return parse_problem(read_scene_file(path), path, overrides)
