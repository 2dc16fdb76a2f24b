"""Scene files: TOML -> validated :class:`Problem` (one format for every problem).

A scene file describes a problem the way an Abaqus or CalculiX deck does, as TOML data: the mesh
(a Gmsh file whose physical groups name the regions and boundaries), materials per region,
boundary conditions and loads on named facet groups, rigid tools and contact pairs, load steps,
and the quantities to record. Nothing in it is ever executed: values that vary in space or time
are numbers, tables or expressions read by :mod:`fenics_plast.expressions` (a whitelisting
parser, not ``eval``).

Every key is declared once, in :data:`SCHEMA`, with its type, default (or REQUIRED / OPTIONAL),
range or choices, unit and meaning; the validator, the ``--set`` overrides and the key reference
(``fenics-plast keys``, docs/SCENE_KEYS.md) all read that table. Keys that only apply to some
variants of a table (``analysis.type``, ``boundary.<name>.type``, ``tools.<name>.shape``,
``outputs.<name>.quantity``, ``materials.<name>.hardening.law``) say so in ``Key.when``.

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

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable

from fenics_plast.expressions import ExpressionError, parse_expression, parse_value

__all__ = ["SceneError", "Problem", "Section", "load_problem", "parse_problem", "SCHEMA", "REQUIRED",
           "OPTIONAL", "COMPONENTS"]


class SceneError(ValueError):
    """A scene file (or a ``--set`` override) is invalid. The message names the file and key."""


class _Marker:
    def __init__(self, name: str):
        self.name = name

    def __repr__(self) -> str:
        return self.name


REQUIRED = _Marker("REQUIRED")   # must be given
OPTIONAL = _Marker("OPTIONAL")   # may be omitted; then the attribute is None

#: component names of vectors: x = r and y = z in axisymmetry
COMPONENTS = {"x": 0, "y": 1, "r": 0, "z": 1}
LAWS = ("linear", "swift", "voce", "table")
STATIC, EXPLICIT = ("static",), ("explicit",)
US = 1e-6          # explicit times are written in microseconds
M_S = 1e3          # velocities are written in m/s -> mm/s
KG_M3 = 1e-12      # densities are written in kg/m^3 -> tonne/mm^3


@dataclass(frozen=True)
class Key:
    """One scene key. ``when`` = {discriminator key: allowed values} restricts it to table variants
    (e.g. {"type": ("static",)}); ``when_analysis`` restricts it to analysis types."""
    type: str                       # str | int | float | bool | floats | strs | vector | values | segments | path
    default: Any                    # a value, REQUIRED or OPTIONAL
    doc: str
    unit: str = ""
    choices: tuple | None = None
    lo: float | None = None
    lo_open: bool = True
    hi: float | None = None
    hi_open: bool = True
    when: dict | None = None
    when_analysis: tuple | None = None
    scale: float = 1.0              # file units -> internal units; the value as written stays in <name>_as_written
    analysis_default: dict | None = None   # {analysis type: default} when the default depends on it

    def range_text(self, name: str) -> str:
        lo = None if self.lo is None else f"{_num(self.lo)} {'<' if self.lo_open else '<='} "
        hi = None if self.hi is None else f" {'<' if self.hi_open else '<='} {_num(self.hi)}"
        if lo and hi:
            return f"{lo}{name}{hi}"
        if lo:
            return f"{name} {'>' if self.lo_open else '>='} {_num(self.lo)}"
        if hi:
            return f"{name}{hi}"
        return ""

    def in_range(self, v: float) -> bool:
        if self.lo is not None and (v <= self.lo if self.lo_open else v < self.lo):
            return False
        return not (self.hi is not None and (v >= self.hi if self.hi_open else v > self.hi))


def _num(x) -> str:
    if isinstance(x, float) and x.is_integer() and abs(x) < 1e15:
        return str(int(x))
    return repr(x) if isinstance(x, float) else str(x)


def _pos(**kw):
    return dict(lo=0.0, lo_open=True, **kw)


def _nonneg(**kw):
    return dict(lo=0.0, lo_open=False, **kw)


def _count(**kw):
    return dict(lo=1, lo_open=False, **kw)


@dataclass(frozen=True)
class Table:
    """A table of keys. ``collection``: the section holds any number of named tables of this shape.
    ``discriminator``: the key whose value selects which other keys apply. ``subtables``: nested
    tables (name -> Table). ``free``: a table of user-named numbers (mesh parameters)."""
    doc: str
    keys: dict[str, Key] = field(default_factory=dict)
    collection: bool = False
    discriminator: str | None = None
    subtables: dict[str, "Table"] = field(default_factory=dict)
    optional: bool = True
    free: bool = False
    when_analysis: tuple | None = None


_FORCE_UNITS = ("N", "kN")
_VALUE_DOC = ("a number, an expression of x, y, z, t in quotes (\"3.0*t\"), or a table "
              "{ t = [...], value = [...] } (piecewise linear, constant outside)")

SCHEMA: dict[str, Table] = {
    "scene": Table("What the problem is.", optional=False, keys={
        "name": Key("str", REQUIRED, "Problem name; the default output directory is results/<name>."),
        "description": Key("str", "", "Free text."),
    }),
    "analysis": Table(
        "How the problem is solved. `static`: quasi-static load incrementation over a pseudo-time t "
        "(from 0 to the end of the last step; 1 when there are no [steps]) with Newton (PETSc SNES, MUMPS) "
        "and cut-back. `explicit`: central differences with a lumped mass over real time, written in µs.",
        optional=False, discriminator="type", keys={
            "type": Key("str", REQUIRED, "Static or explicit.", choices=("static", "explicit")),
            "increments": Key("int", 20, "Initial number of equal increments of a step.", when={"type": STATIC},
                              **_count()),
            "min_increment": Key("float", 1e-4, "Smallest increment of pseudo-time before the run gives up.",
                                 when={"type": STATIC}, **_pos()),
            "max_increment": Key("float", 0.1, "Largest increment of pseudo-time.", when={"type": STATIC},
                                 **_pos()),
            "max_iterations": Key("int", 25, "Newton iterations per increment before cutting back.",
                                  when={"type": STATIC}, lo=2, lo_open=False),
            "rtol": Key("float", 1e-9, "Relative residual tolerance.", when={"type": STATIC}, **_pos()),
            "atol": Key("float", 1e-8, "Absolute residual tolerance.", "N", when={"type": STATIC}, **_pos()),
            "linesearch": Key("str", "bt", "SNES line search.", choices=("bt", "basic", "l2"),
                              when={"type": STATIC}),
            "end_time": Key("float", REQUIRED, "Simulated time.", "µs", when={"type": EXPLICIT}, scale=US, **_pos()),
            "dt_safety": Key("float", 0.8, "Time step = dt_safety x the stable limit.", when={"type": EXPLICIT},
                             lo=0.0, hi=1.0, hi_open=False),
            "time_steps": Key("int", OPTIONAL, "Fixes dt = end_time / time_steps; refused above the stable limit.",
                              when={"type": EXPLICIT}, **_count()),
            "internal_force": Key("str", "fused", "How the explicit internal force is computed: 'fused' (one "
                                  "compiled pass, the default) or 'ufl' (the UFL residual assembled by dolfinx, "
                                  "the definition). Same numbers to round-off.", when={"type": EXPLICIT},
                                  choices=("fused", "ufl")),
        }),
    "mesh": Table(
        "The mesh: a Gmsh `.geo` file (meshed when the run starts, with `[mesh.parameters]` set as its "
        "`DefineConstant` values \"Parameters/<name>\") or a `.msh` file. Regions and boundaries are Gmsh "
        "physical groups (surfaces and curves), referred to by name.", optional=False, keys={
            "file": Key("str", REQUIRED, "Path of the .geo or .msh file, relative to the scene file."),
            "geometry": Key("str", "axisymmetric", "2-D idealisation: x = r and y = z in axisymmetry.",
                            choices=("axisymmetric", "plane_strain")),
            "element": Key("str", "q1p0", "q1p0: Q1 displacement + DG0 dilatation (F-bar); q1: plain Q1.",
                           choices=("q1p0", "q1")),
            "refine": Key("int", 1, "Multiplies every mesh parameter whose name starts with `cells` (.geo only).",
                          **_count()),
        }, subtables={"parameters": Table("Named numbers passed to the .geo file (its DefineConstant "
                                          "\"Parameters/<name>\"); unknown names are refused.", free=True)}),
    "materials": Table(
        "Materials, one table per name. Each applies to the cell regions it lists; a single material "
        "without `regions` applies to the whole mesh.", optional=False, collection=True, keys={
            "regions": Key("strs", OPTIONAL, "Gmsh physical surface names (cell regions) this material fills."),
            "model": Key("str", "isochoric", "seed: be^-1 radial return (Almansi, Simo-Ortiz); isochoric: "
                         "exponential map in log strain.", choices=("seed", "isochoric")),
            "E": Key("float", REQUIRED, "Young's modulus.", "MPa", **_pos()),
            "nu": Key("float", REQUIRED, "Poisson's ratio.", "", lo=-1.0, hi=0.5),
            "density": Key("float", OPTIONAL, "Mass density (required in explicit analyses).", "kg/m³",
                           scale=KG_M3, **_pos()),
        }, subtables={"hardening": Table(
            "Optional: absent = purely elastic (plasticity off). Only the keys of the chosen `law` apply.",
            discriminator="law", keys={
                "law": Key("str", REQUIRED, "Hardening law.", choices=LAWS),
                "yield_stress": Key("float", REQUIRED, "Initial yield stress.", "MPa",
                                    when={"law": ("linear", "voce")}, **_nonneg()),
                "modulus": Key("float", 0.0, "Linear hardening modulus (voce: added linear term).", "MPa",
                               when={"law": ("linear", "voce")}, **_nonneg()),
                "K": Key("float", REQUIRED, "Swift: sigma_y = K (eps0 + eqps)^n.", "MPa", when={"law": ("swift",)},
                         **_pos()),
                "eps0": Key("float", REQUIRED, "Swift pre-strain.", "", when={"law": ("swift",)}, **_pos()),
                "n": Key("float", REQUIRED, "Swift exponent.", "", when={"law": ("swift",)}, lo=0.0,
                         lo_open=False, hi=1.0, hi_open=False),
                "Q": Key("float", REQUIRED, "Voce: sigma_y = yield_stress + Q (1 - exp(-b eqps)) + modulus eqps.",
                         "MPa", when={"law": ("voce",)}, **_nonneg()),
                "b": Key("float", REQUIRED, "Voce saturation rate.", "", when={"law": ("voce",)}, **_pos()),
                "strain": Key("floats", REQUIRED, "Table: equivalent plastic strains, >= 2, strictly "
                              "increasing, first 0.", "", when={"law": ("table",)}),
                "stress": Key("floats", REQUIRED, "Table: yield stress at each strain (piecewise linear), "
                              "each >= 0.", "MPa", when={"law": ("table",)}),
            })}),
    "boundary": Table(
        "Boundary conditions and loads, one table per name, each on a Gmsh facet group. Static: t is the "
        "pseudo-time; explicit: t is the time in µs. Values: " + _VALUE_DOC + ".",
        collection=True, discriminator="type", keys={
            "group": Key("str", REQUIRED, "Gmsh physical curve name (facet group)."),
            "type": Key("str", REQUIRED, "fixed: components held at 0; displacement: prescribed [mm]; velocity "
                        "(explicit): prescribed [m/s]; traction: dead load [MPa] per reference area; pressure: "
                        "normal dead load [MPa], positive pushes into the body; symmetry: the normal component "
                        "held at 0 (the group must be a straight line normal to x or y); axis: u_r = 0 "
                        "(axisymmetric).",
                        choices=("fixed", "displacement", "velocity", "traction", "pressure", "symmetry", "axis")),
            "components": Key("strs", REQUIRED, "Components: x, y (r, z in axisymmetry).",
                              when={"type": ("fixed", "displacement", "velocity", "traction")}),
            "value": Key("values", REQUIRED, "One value per component (a list), or one value for all.",
                         when={"type": ("displacement", "velocity", "traction", "pressure")}),
        }),
    "initial_velocity": Table(
        "Initial velocity (explicit), one table per name.", collection=True, when_analysis=EXPLICIT, keys={
            "regions": Key("strs", OPTIONAL, "Cell regions; absent = the whole body."),
            "value": Key("values", REQUIRED, "Velocity (x, y): numbers or expressions of x, y, z.", "m/s",
                         scale=M_S),
        }),
    "tools": Table(
        "Rigid analytic tools, one table per name, each moving along `path`. The body lies on the side the "
        "normal points to (plane), outside (circle), or on `body_side` of the profile.",
        collection=True, discriminator="shape", keys={
            "shape": Key("str", REQUIRED, "plane: half-space; circle: disc (a sphere or torus in axisymmetry); "
                         "profile: chain of line segments and circular arcs (revolved in axisymmetry).",
                         choices=("plane", "circle", "profile")),
            "point": Key("vector", REQUIRED, "A point of the plane.", "mm", when={"shape": ("plane",)}),
            "normal": Key("vector", REQUIRED, "Normal of the plane, pointing into the body.", "",
                          when={"shape": ("plane",)}),
            "center": Key("vector", REQUIRED, "Centre at t = 0.", "mm", when={"shape": ("circle",)}),
            "radius": Key("float", REQUIRED, "Radius.", "mm", when={"shape": ("circle",)}, **_pos()),
            "segments": Key("segments", REQUIRED, "Profile pieces in order: { line = [[x0, y0], [x1, y1]] } or "
                            "{ arc = [cx, cy], radius = R, from = deg, to = deg } (counter-clockwise when "
                            "to > from).", "mm", when={"shape": ("profile",)}),
            "body_side": Key("str", "left", "Side of the profile (walking along it) where the body lies.",
                             when={"shape": ("profile",)}, choices=("left", "right")),
            "path": Key("path", OPTIONAL, "Translation: { t = [...], x = [...], y = [...] } (piecewise linear; "
                        "a missing component stays 0); absent = fixed.", "mm"),
        }),
    "contact": Table(
        "Contact pairs, one table per name: a tool against a facet group of the body (penalty, nodal rule).",
        collection=True, keys={
            "tool": Key("str", REQUIRED, "Name of a [tools.<name>] table."),
            "group": Key("str", REQUIRED, "Gmsh physical curve name of the body's candidate facets."),
            "friction": Key("float", 0.0, "Coulomb coefficient mu (0: frictionless, no friction term).", "",
                            **_nonneg()),
            "law": Key("str", "quasi-coulomb", "coulomb: current p and N; quasi-coulomb: p and N frozen over an "
                       "increment (seed eq. 24, symmetric).", choices=("coulomb", "quasi-coulomb")),
            "penalty": Key("float", OPTIONAL, "Normal penalty; absent = 0.3 E / h, h the mean depth of the "
                           "cells along the group.", "N/mm³", **_pos()),
            "tangential_penalty": Key("float", OPTIONAL, "Tangential (stick) penalty; absent = the normal "
                                      "penalty.", "N/mm³", **_pos()),
        }),
    "steps": Table(
        "Static load steps, in order of `end`. Each ends at a pseudo-time where a converged state is "
        "written (profiles, fields); boundary values and tool paths are functions of t across steps.",
        collection=True, when_analysis=STATIC, keys={
            "end": Key("float", REQUIRED, "Pseudo-time at the end of the step.", "", **_pos()),
            "increments": Key("int", OPTIONAL, "Initial increments of this step (absent: analysis.increments).",
                              **_count()),
            "max_increment": Key("float", OPTIONAL, "Largest increment (absent: analysis.max_increment).",
                                 **_pos()),
        }),
    "outputs": Table(
        "Quantities recorded every increment (static) or history row (explicit): each is a history.csv "
        "column named <name>_<unit>, and its final value goes into summary.json.",
        collection=True, discriminator="quantity", keys={
            "quantity": Key("str", REQUIRED, "reaction: sum of the reactions on a constrained group; "
                            "tool_force: force of a tool on the body; tool_displacement: the tool's translation; "
                            "displacement / position: of the node "
                            "nearest `point`; extent: largest or smallest current coordinate of a group (or "
                            "the body); field: largest or smallest value of a field over a region (or the body); "
                            "energy: one of the energies; thickness: ln(t/t0) between two facing groups along "
                            "the first (a profile, written to <name>.csv at every step end); expression: a "
                            "value computed from other outputs (its column is the output's name as written: put "
                            "the unit in the name, e.g. pressure_MPa).",
                            choices=("reaction", "tool_force", "tool_displacement", "displacement", "position", "extent", "field",
                                     "energy", "thickness", "expression")),
            "group": Key("str", OPTIONAL, "Facet group (extent: absent = the whole body).",
                         when={"quantity": ("reaction", "extent", "thickness")}),
            "opposite": Key("str", REQUIRED, "The facing group (thickness).", when={"quantity": ("thickness",)}),
            "tool": Key("str", REQUIRED, "Tool name.", when={"quantity": ("tool_force", "tool_displacement")}),
            "component": Key("str", REQUIRED, "x or y (r or z).", choices=tuple(COMPONENTS),
                             when={"quantity": ("reaction", "tool_force", "tool_displacement", "displacement",
                                                "position", "extent")}),
            "point": Key("vector", REQUIRED, "Reference coordinates; the nearest node is used.", "mm",
                         when={"quantity": ("displacement", "position")}),
            "which": Key("str", "max", "Largest or smallest.", choices=("max", "min"),
                         when={"quantity": ("extent", "field")}),
            "field": Key("str", REQUIRED, "eqps: equivalent plastic strain; von_mises: Kirchhoff von Mises "
                         "stress [MPa].", choices=("eqps", "von_mises"), when={"quantity": ("field",)}),
            "regions": Key("strs", OPTIONAL, "Cell regions (absent = the whole body).", when={"quantity": ("field",)}),
            "energy": Key("str", REQUIRED, "kinetic, elastic, plastic (dissipation), external_work, "
                          "balance_error (relative) or all (the five).",
                          choices=("kinetic", "elastic", "plastic", "external_work", "balance_error", "all"),
                          when={"quantity": ("energy",)}),
            "unit": Key("str", "kN", "Force unit of the column.", choices=_FORCE_UNITS,
                        when={"quantity": ("reaction", "tool_force")}),
            "expression": Key("str", REQUIRED, "An expression (see [boundary] values) of t and of the names "
                              "of other one-column outputs declared before it, each in its column's unit.",
                              when={"quantity": ("expression",)}),
            "scale": Key("float", 1.0, "Factor applied to the measured value: e.g. 2 for the elongation of a "
                         "half model, 4 for the force on a quarter model.",
                         when={"quantity": ("reaction", "tool_force", "tool_displacement", "displacement")}),
            "at_max_of": Key("str", OPTIONAL, "Name of another one-column output: summary.json also gets this "
                             "output's value where that one is largest (<column>_at_max_<its column>)."),
            "summary": Key("strs", ["final"], "What goes into summary.json: final, max, min (max adds "
                           "max_<column> and, for static runs, the pseudo-time of the maximum)."),
            "key": Key("bool", False, "A key result: `fenics-plast study` reports its error."),
            "reference": Key("float", OPTIONAL, "A published value of the final result (study: err_paper_)."),
            "reference_source": Key("str", "", "Where `reference` comes from."),
        }),
    "plots": Table(
        "Figures drawn from history.csv (and the profiles, final shape) at the end of the run and by "
        "`fenics-plast plot DIR`.", collection=True, discriminator="type", keys={
            "type": Key("str", "history", "history: columns against a column; profile: a thickness output "
                        "along its group at each step end; shape: the final deformed mesh coloured by eqps.",
                        choices=("history", "profile", "shape")),
            "x": Key("str", REQUIRED, "Column of history.csv on the x axis.", when={"type": ("history",)}),
            "y": Key("strs", REQUIRED, "Columns on the y axis (one line each).", when={"type": ("history",)}),
            "output": Key("str", REQUIRED, "Name of a thickness output.", when={"type": ("profile",)}),
            "title": Key("str", "", "Figure title (default: the scene name)."),
        }),
    "output": Table("What is written to the output directory.", keys={
        "xdmf": Key("bool", True, "Write fields to fields.xdmf."),
        "every": Key("int", 1, "Write fields every N increments (static) or history rows (explicit).", **_count()),
        "plots": Key("bool", True, "Draw the [plots] as PNG files."),
        "history_points": Key("int", 200, "Number of history rows (explicit).", when_analysis=EXPLICIT,
                              lo=2, lo_open=False),
        "checkpoint_every": Key("int", None, "Checkpoint every N steps (explicit) or converged increments "
                                "(static) into checkpoint/ (0: never); `--resume DIR` continues a killed run.",
                                analysis_default={"explicit": 2000, "static": 10}, lo=0, lo_open=False),
    }),
}

SECTIONS = tuple(SCHEMA)


# ----------------------------------------------------------------------------------------------
# Validated data


class Section:
    """Read-only attribute access to one validated table (``problem.analysis.dt_safety``).

    ``name`` is the user's name of a collection member (``contact.punch`` -> "punch"); ``to_dict()``
    gives the keys (nested tables as dicts)."""

    def __init__(self, dotted: str, values: dict[str, Any], name: str | None = None):
        object.__setattr__(self, "_dotted", dotted)
        object.__setattr__(self, "name", name)
        for k, v in values.items():
            object.__setattr__(self, k, v)

    @property
    def _values(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if not k.startswith("_") and k != "name"}

    def __getattr__(self, key: str):
        if key.startswith("__"):
            raise AttributeError(key)
        raise AttributeError(f"[{self.__dict__.get('_dotted')}] has no key {key!r} "
                             f"(has: {', '.join(self._values)})")

    def __setattr__(self, key, value):
        raise AttributeError("scene tables are read-only; use --set to override keys")

    def get(self, key: str, default=None):
        return self._values.get(key, default)

    def __contains__(self, key: str) -> bool:
        return key in self._values

    def to_dict(self) -> dict[str, Any]:
        def plain(v):
            if isinstance(v, Section):
                return v.to_dict()
            if isinstance(v, dict):
                return {k: plain(x) for k, x in v.items()}
            if isinstance(v, (tuple, list)):
                return [plain(x) for x in v]
            if hasattr(v, "describe"):
                return v.describe()
            return v
        return {k: plain(v) for k, v in self._values.items()}

    def __repr__(self) -> str:
        return f"Section[{self._dotted}]({self.to_dict()!r})"


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
        """What the problem assembles: plasticity, inertia, contact, friction, tractions."""
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
# Validation


def _fmt(v) -> str:
    if isinstance(v, str):
        return repr(v)
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return _num(v)
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k} = {_fmt(x)}" for k, x in v.items()) + "}"
    if isinstance(v, list):
        return "[" + ", ".join(_fmt(x) for x in v) + "]"
    return str(v)


_TYPE_TEXT = {"str": "a string", "int": "an integer", "float": "a number", "bool": "true or false",
              "floats": "a list of numbers", "strs": "a list of strings (or one string)",
              "vector": "a list of 2 numbers [x, y]", "value": _VALUE_DOC,
              "values": "a value or a list of values, each " + _VALUE_DOC,
              "segments": "a list of inline tables { line = ... } or { arc = ..., radius = ..., from = ..., to = ... }",
              "path": "an inline table { t = [...], x = [...], y = [...] }"}


def _is_number(x) -> bool:
    return not isinstance(x, bool) and isinstance(x, (int, float))


class _Validator:
    def __init__(self, where: str, analysis: str | None = None):
        self.where = where
        self.analysis = analysis

    def fail(self, msg: str):
        raise SceneError(f"{self.where}: {msg}")

    def finite(self, dotted, x) -> float:
        x = float(x)
        if not math.isfinite(x):
            self.fail(f"{dotted} = {_fmt(x)} is not a finite number")
        return x

    def coerce(self, dotted: str, key: Key, v):
        """Check the type, choices and range of one value; returns it in internal units."""
        t = key.type
        bad = False
        if t == "str":
            bad = not isinstance(v, str)
        elif t == "bool":
            bad = not isinstance(v, bool)
        elif t == "int":
            bad = isinstance(v, bool) or not isinstance(v, int)
        elif t == "float":
            bad = not _is_number(v)
            if not bad:
                v = self.finite(dotted, v)
        elif t == "floats":
            bad = not isinstance(v, list) or not all(_is_number(x) for x in v)
            if not bad:
                v = tuple(self.finite(dotted, x) for x in v)
        elif t == "strs":
            if isinstance(v, str):
                v = [v]
            bad = not isinstance(v, list) or not v or not all(isinstance(x, str) for x in v)
            if not bad:
                v = tuple(v)
        elif t == "vector":
            bad = not isinstance(v, list) or len(v) != 2 or not all(_is_number(x) for x in v)
            if not bad:
                v = tuple(self.finite(dotted, x) for x in v)
        elif t in ("value", "values"):
            return self.values(dotted, key, v)
        elif t == "segments":
            return self.segments(dotted, v)
        elif t == "path":
            return self.path(dotted, v)
        if bad:
            self.fail(f"{dotted} = {_fmt(v)} has the wrong type: must be {_TYPE_TEXT[t]}")
        if key.choices is not None:
            for x in (v if t == "strs" else (v,)):
                if x not in key.choices:
                    self.fail(f"{dotted} = {_fmt(x)} is not allowed: must be one of {', '.join(key.choices)}")
        if t in ("int", "float") and not key.in_range(v):
            self.fail(f"{dotted} = {_fmt(v)} is out of range: must satisfy {key.range_text(dotted.split('.')[-1])}")
        if t == "float" and key.scale != 1.0:
            v = v * key.scale
        return v

    def values(self, dotted: str, key: Key, v):
        """A value spec or a list of them (one per component); expressions in x, y, z, t. Times of
        explicit analyses are in µs in the file: the value's t is scaled to seconds by the runner."""
        items = v if (key.type == "values" and isinstance(v, list)) else [v]
        if not items:
            self.fail(f"{dotted} = []: must be {_TYPE_TEXT[key.type]}")
        out = []
        for i, item in enumerate(items):
            where = dotted if len(items) == 1 and not isinstance(v, list) else f"{dotted}[{i}]"
            try:
                out.append(parse_value(item, where))
            except ExpressionError as e:
                self.fail(str(e))
        return tuple(out) if isinstance(v, list) else out[0]

    def segments(self, dotted: str, v):
        if not isinstance(v, list) or not v:
            self.fail(f"{dotted} = {_fmt(v)} has the wrong type: must be {_TYPE_TEXT['segments']}")
        out = []
        for i, s in enumerate(v):
            where = f"{dotted}[{i}]"
            if not isinstance(s, dict):
                self.fail(f"{where} = {_fmt(s)} has the wrong type: must be an inline table")
            if "line" in s:
                if set(s) != {"line"}:
                    self.fail(f"{where}: a line has only the key `line` = [[x0, y0], [x1, y1]] (got {', '.join(s)})")
                pts = s["line"]
                if not (isinstance(pts, list) and len(pts) == 2 and all(
                        isinstance(p, list) and len(p) == 2 and all(_is_number(x) for x in p) for p in pts)):
                    self.fail(f"{where}.line = {_fmt(pts)} must be [[x0, y0], [x1, y1]]")
                p0, p1 = (tuple(self.finite(where, x) for x in p) for p in pts)
                if p0 == p1:
                    self.fail(f"{where}.line has zero length")
                out.append(("line", p0, p1))
            elif "arc" in s:
                if set(s) != {"arc", "radius", "from", "to"}:
                    self.fail(f"{where}: an arc has the keys arc = [cx, cy], radius, from, to (got {', '.join(s)})")
                c = s["arc"]
                if not (isinstance(c, list) and len(c) == 2 and all(_is_number(x) for x in c)):
                    self.fail(f"{where}.arc = {_fmt(c)} must be the centre [cx, cy]")
                for k in ("radius", "from", "to"):
                    if not _is_number(s[k]):
                        self.fail(f"{where}.{k} = {_fmt(s[k])} must be a number")
                r = self.finite(f"{where}.radius", s["radius"])
                if r <= 0:
                    self.fail(f"{where}.radius = {_fmt(r)} is out of range: must be > 0")
                a0, a1 = self.finite(f"{where}.from", s["from"]), self.finite(f"{where}.to", s["to"])
                if a0 == a1:
                    self.fail(f"{where}: from = to = {_fmt(a0)}: the arc is empty")
                out.append(("arc", tuple(float(x) for x in c), r, a0, a1))
            else:
                self.fail(f"{where} = {_fmt(s)}: must be {{ line = ... }} or {{ arc = ..., radius, from, to }}")
        return tuple(out)

    def path(self, dotted: str, v):
        if not isinstance(v, dict) or "t" not in v or not (set(v) - {"t"}) or not set(v) <= {"t", "x", "y"}:
            self.fail(f"{dotted} = {_fmt(v)} has the wrong type: must be {_TYPE_TEXT['path']}")
        out = {}
        for comp in ("x", "y"):
            if comp in v:
                try:
                    out[comp] = parse_value({"t": v["t"], "value": v[comp]}, f"{dotted}.{comp}")
                except ExpressionError as e:
                    self.fail(str(e))
        return out

    # -- tables ---------------------------------------------------------------------------------
    def table(self, dotted: str, spec: Table, given: dict, name: str | None = None) -> Section:
        if not isinstance(given, dict):
            self.fail(f"{dotted} = {_fmt(given)}: [{dotted}] must be a table")
        variant = None
        if spec.discriminator is not None:
            dkey = spec.keys[spec.discriminator]
            if spec.discriminator in given:
                variant = self.coerce(f"{dotted}.{spec.discriminator}", dkey, given[spec.discriminator])
            elif dkey.default is REQUIRED:
                self.fail(f"{dotted}.{spec.discriminator} is missing: required, one of {', '.join(dkey.choices)}")
            else:
                variant = dkey.default
        allowed = {k: key for k, key in spec.keys.items() if self._applies(key, spec.discriminator, variant)}
        for k, x in given.items():
            if k in allowed or k in spec.subtables:
                continue
            what = f"{spec.discriminator} {variant!r}" if variant is not None else f"[{dotted}]"
            if k in spec.keys:
                key = spec.keys[k]
                if key.when_analysis and self.analysis not in key.when_analysis:
                    self.fail(f"{dotted}.{k} is only for {'/'.join(key.when_analysis)} analyses")
                self.fail(f"{dotted}.{k} is not a key of {what}: allowed keys are {', '.join(allowed)}")
            self.fail(f"{dotted}.{k} is an unknown key: allowed keys in [{dotted}] are "
                      f"{', '.join(list(allowed) + list(spec.subtables))}")
        values: dict[str, Any] = {}
        for k, key in allowed.items():
            kd = f"{dotted}.{k}"
            if k in given:
                val = self.coerce(kd, key, given[k])
                if key.type == "float" and key.scale != 1.0:
                    values[f"{k}_as_written"] = given[k]
            else:
                default = key.default
                if key.analysis_default is not None:
                    default = key.analysis_default[self.analysis]
                if default is REQUIRED:
                    self.fail(f"{kd} is missing: required ({self._what(k, key)})")
                val = None if default is OPTIONAL else (tuple(default) if isinstance(default, list) else default)
            values[k] = val
        for sub, subspec in spec.subtables.items():
            sd = f"{dotted}.{sub}"
            if sub not in given:
                values[sub] = {} if subspec.free else None
            elif subspec.free:
                values[sub] = self.free(sd, given[sub])
            else:
                values[sub] = self.table(sd, subspec, given[sub])
        return Section(dotted, values, name)

    def free(self, dotted: str, given) -> dict[str, float]:
        if not isinstance(given, dict):
            self.fail(f"{dotted} = {_fmt(given)}: [{dotted}] must be a table of numbers")
        out = {}
        for k, x in given.items():
            if not _is_number(x):
                self.fail(f"{dotted}.{k} = {_fmt(x)} has the wrong type: must be a number")
            out[k] = x if isinstance(x, int) else self.finite(f"{dotted}.{k}", x)
        return out

    def _applies(self, key: Key, disc: str | None, variant) -> bool:
        if key.when_analysis and self.analysis not in key.when_analysis:
            return False
        if key.when:
            return all(variant in allowed for allowed in key.when.values())
        return True

    @staticmethod
    def _what(name: str, key: Key) -> str:
        if key.choices:
            return "one of " + ", ".join(key.choices)
        rng = key.range_text(name)
        return _TYPE_TEXT.get(key.type, key.type) + (f", {rng}" if rng else "") + (f" [{key.unit}]" if key.unit else "")


def _validate(raw: dict, where: str, path: Path, overrides: tuple[str, ...]) -> Problem:
    v = _Validator(where)
    for top in raw:
        if top not in SCHEMA:
            v.fail(f"{top}: unknown section [{top}]: allowed sections are "
                   f"{', '.join('[' + s + ']' for s in SECTIONS)}")
    ana = raw.get("analysis")
    if not isinstance(ana, dict) or "type" not in ana:
        v.fail("analysis.type is missing: required, one of static, explicit")
    v.analysis = v.coerce("analysis.type", SCHEMA["analysis"].keys["type"], ana["type"])
    tables: dict[str, Any] = {}
    for sec, spec in SCHEMA.items():
        given = raw.get(sec)
        if spec.when_analysis and v.analysis not in spec.when_analysis:
            if given:
                v.fail(f"{sec}: [{sec}] is only for {'/'.join(spec.when_analysis)} analyses")
            tables[sec] = {} if spec.collection else None
            continue
        if given is None:
            if not spec.optional:
                v.fail(f"{sec}: missing required section [{sec}]")
            given = {}
        if spec.collection:
            if not isinstance(given, dict):
                v.fail(f"{sec} = {_fmt(given)}: [{sec}] must hold named tables [{sec}.<name>]")
            if not given and not spec.optional:
                v.fail(f"{sec}: needs at least one [{sec}.<name>] table")
            tables[sec] = {n: v.table(f"{sec}.{n}", spec, t, name=n) for n, t in given.items()}
        else:
            tables[sec] = v.table(sec, spec, given)
    _cross_checks(tables, v)
    if tables["steps"]:
        tables["steps"] = dict(sorted(tables["steps"].items(), key=lambda kv: kv[1].end))
    return Problem(path=path, name=tables["scene"].name, tables=tables, overrides=overrides)


def _cross_checks(t: dict[str, Any], v: _Validator):
    """Rules between keys (each message names the keys)."""
    ana, explicit = t["analysis"], v.analysis == "explicit"
    if not explicit and ana.min_increment > ana.max_increment:
        v.fail(f"analysis.min_increment = {_fmt(ana.min_increment)} is out of range: must not exceed "
               f"analysis.max_increment = {_fmt(ana.max_increment)}")
    mats = t["materials"]
    if len(mats) > 1:
        for n, m in mats.items():
            if m.regions is None:
                v.fail(f"materials.{n}.regions is missing: required when there are several materials")
        seen: dict[str, str] = {}
        for n, m in mats.items():
            for r in m.regions:
                if r in seen:
                    v.fail(f"materials.{n}.regions: region {r!r} is also in materials.{seen[r]}.regions "
                           f"(materials must not overlap)")
                seen[r] = n
    for n, m in mats.items():
        if explicit and m.density is None:
            v.fail(f"materials.{n}.density is missing: required in explicit analyses [kg/m³]")
        h = m.hardening
        if h is not None and h.law == "table":
            eps, sig, d = h.strain, h.stress, f"materials.{n}.hardening"
            if len(eps) < 2:
                v.fail(f"{d}.strain has {len(eps)} entries: must have at least 2")
            if eps[0] != 0.0:
                v.fail(f"{d}.strain = {list(eps)} is not allowed: the first entry must be 0")
            if any(b <= a for a, b in zip(eps, eps[1:])):
                v.fail(f"{d}.strain = {list(eps)} is not allowed: must be strictly increasing")
            if len(sig) != len(eps):
                v.fail(f"{d}.stress has {len(sig)} entries: must have as many as {d}.strain ({len(eps)})")
            if any(x < 0 for x in sig):
                v.fail(f"{d}.stress = {list(sig)} is out of range: each entry must be >= 0")
    for n, b in t["boundary"].items():
        d = f"boundary.{n}"
        if b.type == "velocity" and not explicit:
            v.fail(f"{d}.type = 'velocity' is only for explicit analyses (static: type = 'displacement')")
        if b.type == "axis" and t["mesh"].geometry != "axisymmetric":
            v.fail(f"{d}.type = 'axis' needs mesh.geometry = 'axisymmetric'")
        comps = b.get("components")
        if comps is not None:
            for c in comps:
                if c not in COMPONENTS:
                    v.fail(f"{d}.components = {list(comps)}: {c!r} is not a component: must be one of "
                           f"{', '.join(COMPONENTS)}")
            if len(set(COMPONENTS[c] for c in comps)) != len(comps):
                v.fail(f"{d}.components = {list(comps)} names a component twice")
            val = b.get("value")
            if isinstance(val, tuple) and len(val) != len(comps):
                v.fail(f"{d}.value has {len(val)} entries: must have one per component ({len(comps)}) or be one value")
        if b.type == "pressure" and isinstance(b.value, tuple):
            v.fail(f"{d}.value must be one value (the pressure)")
    for n, iv in t["initial_velocity"].items():
        val = iv.value
        if not isinstance(val, tuple) or len(val) != 2:
            v.fail(f"initial_velocity.{n}.value must be a list of 2 values [vx, vy] [m/s]")
        for i, x in enumerate(val):
            if x.depends_on_time:
                v.fail(f"initial_velocity.{n}.value[{i}] may depend on x, y, z only, not on t")
    tools = t["tools"]
    for n, c in t["contact"].items():
        if c.tool not in tools:
            v.fail(f"contact.{n}.tool = {c.tool!r} is not a tool: tools are {', '.join(tools) or 'none'}")
    column_count = {n: (0 if o.quantity == "thickness" else 5 if o.quantity == "energy" and o.energy == "all"
                        else 1) for n, o in t["outputs"].items()}
    # expressions may name the one-column outputs declared before them; at_max_of any one-column one
    single_columns = [n for n, o in t["outputs"].items() if column_count[n] == 1 and o.quantity != "expression"]
    for n, o in t["outputs"].items():
        d = f"outputs.{n}"
        if o.quantity in ("tool_force", "tool_displacement") and o.tool not in tools:
            v.fail(f"{d}.tool = {o.tool!r} is not a tool: tools are {', '.join(tools) or 'none'}")
        if o.quantity == "thickness" and o.group is None:
            v.fail(f"{d}.group is missing: required for a thickness profile")
        if o.quantity == "reaction" and o.group is None:
            v.fail(f"{d}.group is missing: required for a reaction")
        for s in o.summary:
            if s not in ("final", "max", "min"):
                v.fail(f"{d}.summary = {list(o.summary)}: entries must be final, max or min")
        if o.quantity == "energy" and not explicit:
            v.fail(f"{d}: energies are recorded in explicit analyses only")
        if o.quantity == "expression":
            try:
                parse_expression(o.expression, f"{d}.expression", symbols=("t",) + tuple(single_columns))
            except ExpressionError as e:
                v.fail(str(e))
        if o.at_max_of is not None and (column_count.get(o.at_max_of) != 1 or o.at_max_of == n
                                        or column_count[n] != 1):
            ones = [m for m, c in column_count.items() if c == 1 and m != n]
            v.fail(f"{d}.at_max_of = {o.at_max_of!r}: must name another one-column output (and this output "
                   f"must have one column); one-column outputs: {', '.join(ones) or 'none'}")
        if o.quantity == "expression":
            single_columns.append(n)
    for n, p in t["plots"].items():
        if p.type == "profile" and (p.output not in t["outputs"] or t["outputs"][p.output].quantity != "thickness"):
            v.fail(f"plots.{n}.output = {p.output!r} is not a thickness output")
    ends = [s.end for s in t["steps"].values()]
    if len(set(ends)) != len(ends):
        v.fail("steps: two steps have the same end")


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
    a key that came from the command line says so. Shared by both scene formats."""
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


def parse_problem(text: str, path: str | Path = "<string>", overrides: Iterable[str] = ()) -> Problem:
    """Validate TOML text (``path`` names it in messages and resolves the mesh file)."""
    return parse_with(_validate, text, path, overrides)


def load_problem(path: str | Path, overrides: Iterable[str] = ()) -> Problem:
    """Read and validate a scene file; ``overrides`` are ``"a.b.c=value"`` strings (``--set``)."""
    return parse_problem(read_scene_file(path), path, overrides)


def is_general(text: str) -> bool:
    """A scene file of the general format has an [analysis] table (the old kind files do not)."""
    try:
        return "analysis" in tomllib.loads(text)
    except (ValueError, RecursionError):        # TOMLDecodeError, a huge integer, deep nesting
        return False
