"""Scene files: TOML -> validated :class:`Scene`.

Everything a scene file may contain is declared once, in :data:`SCHEMA` (section -> key ->
type, default or REQUIRED, allowed range/choices, unit, one-line doc, scene kinds allowed).
The validator, the ``--set`` overrides and ``docs/SCENE_KEYS.md`` (see :func:`keys_markdown`)
all read that table. This module knows nothing of dolfinx.

Units inside the package: mm, N, MPa, s, tonne/mm^3. Two keys are converted on reading:
``material.density`` is given in kg/m^3 and stored in tonne/mm^3 (x 1e-12), the value as
written stays in ``material.density_kg_m3``; ``loading.velocity`` is given in m/s and stored in
mm/s (x 1e3), the value as written stays in ``loading.velocity_m_s``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable

__all__ = [
    "SceneError", "Scene", "Section", "load_scene", "parse_scene", "load_any", "keys_markdown", "SCHEMA",
    "KINDS", "REQUIRED", "OPTIONAL",
]


from fenics_plast.problem import SceneError, is_general, parse_with, read_scene_file


class _Marker:
    def __init__(self, name: str):
        self.name = name

    def __repr__(self) -> str:
        return self.name


REQUIRED = _Marker("REQUIRED")   # must be given
OPTIONAL = _Marker("OPTIONAL")   # may be omitted; then the attribute is None

KINDS = ("bar_tension", "taylor_bar", "thick_cylinder", "punch_stretching")
BAR = ("bar_tension", "taylor_bar")
STATIC = ("bar_tension", "thick_cylinder", "punch_stretching")
EXPLICIT = ("taylor_bar",)
LAWS = ("linear", "swift", "voce", "table")

# Optional sections: when absent the attribute is None and the physics is off.
OPTIONAL_SECTIONS = ("material.hardening", "contact")
# Sections restricted to some kinds.
SECTION_KINDS = {"tools": ("punch_stretching",), "contact": ("punch_stretching",)}
SECTION_DOCS = {
    "scene": "What the scene is.",
    "mesh": "Geometry and discretisation. `refine` multiplies every cell count.",
    "material": "Elastic constants and the finite-strain model.",
    "material.hardening": "Optional: absent = purely elastic (plasticity off). "
                          "Only the keys of the chosen `law` are allowed.",
    "loading": "What drives the scene.",
    "tools": "Rigid tools of the punch-stretching test (punch_stretching only).",
    "contact": "Optional (punch_stretching only): punch/die contact parameters. `contact` counts as "
               "active physics when the section is present, `friction` when friction > 0.",
    "solver": "Static kinds: load incrementation and Newton (SNES) settings. "
              "taylor_bar: explicit central differences.",
    "output": "What is written to the output directory.",
}


@dataclass(frozen=True)
class Key:
    type: str                       # str | int | float | bool | floats (list of floats)
    default: Any                    # a value, REQUIRED or OPTIONAL
    doc: str
    unit: str = ""
    choices: tuple | None = None
    lo: float | None = None         # lower bound
    lo_open: bool = True            # True: strictly greater than lo
    hi: float | None = None
    hi_open: bool = True
    kinds: tuple = KINDS            # scene kinds that allow the key
    laws: tuple | None = None       # hardening laws that allow the key (material.hardening only)
    required_if: str | None = None  # "inertia": required when inertia is active, else OPTIONAL
    scale: float = 1.0              # factor from file units to internal units
    raw_name: str | None = None     # attribute keeping the value as written (when scale != 1)

    def range_text(self, name: str) -> str:
        """E.g. '-1 < nu < 0.5', 'E > 0', '1 <= refine'."""
        if self.lo is not None and self.hi is not None:
            return (f"{_num(self.lo)} {'<' if self.lo_open else '<='} {name} "
                    f"{'<' if self.hi_open else '<='} {_num(self.hi)}")
        if self.lo is not None:
            return f"{name} {'>' if self.lo_open else '>='} {_num(self.lo)}"
        if self.hi is not None:
            return f"{name} {'<' if self.hi_open else '<='} {_num(self.hi)}"
        return ""

    def in_range(self, v: float) -> bool:
        if self.lo is not None and (v <= self.lo if self.lo_open else v < self.lo):
            return False
        if self.hi is not None and (v >= self.hi if self.hi_open else v > self.hi):
            return False
        return True


def _num(x) -> str:
    if isinstance(x, float) and x.is_integer() and abs(x) < 1e15:
        return str(int(x))
    return repr(x) if isinstance(x, float) else str(x)


def _pos(**kw):
    return dict(lo=0.0, lo_open=True, **kw)


def _nonneg(**kw):
    return dict(lo=0.0, lo_open=False, **kw)


# section -> key -> Key, or a list of Key when the same name differs between kinds
SCHEMA: dict[str, dict[str, Key | list[Key]]] = {
    "scene": {
        "name": Key("str", REQUIRED, "Scene name; default output directory is results/<name>."),
        "kind": Key("str", REQUIRED, "Which runner solves the scene.", choices=KINDS),
        "description": Key("str", "", "Free text."),
    },
    "mesh": {
        "geometry": Key("str", "axisymmetric", "2-D idealisation of the 3-D body.",
                        choices=("axisymmetric", "plane_strain")),
        "element": Key("str", "q1p0", "q1p0: Q1 displacement + DG0 dilatation (F-bar); q1: plain Q1.",
                       choices=("q1p0", "q1")),
        "refine": Key("int", 1, "Multiplies every cell count (mesh convergence studies).", lo=1, lo_open=False),
        "radius": Key("float", REQUIRED, "Bar radius.", "mm", kinds=BAR, **_pos()),
        "length": Key("float", REQUIRED, "Bar length (full length, symmetry is the runner's business).",
                      "mm", kinds=BAR, **_pos()),
        "cells_radial": [
            Key("int", REQUIRED, "Cells across the radius / wall.", kinds=BAR + ("thick_cylinder",),
                lo=1, lo_open=False),
            Key("int", 60, "Cells along the blank radius.", kinds=("punch_stretching",), lo=1, lo_open=False),
        ],
        "cells_axial": Key("int", REQUIRED, "Cells along the bar length.", kinds=BAR, lo=1, lo_open=False),
        "imperfection": Key("float", 0.0, "Relative radius reduction at mid-length (triggers necking).",
                            kinds=BAR, lo=0.0, lo_open=False, hi=0.5, hi_open=True),
        "inner_radius": Key("float", REQUIRED, "Inner radius of the cylinder.", "mm",
                            kinds=("thick_cylinder",), **_pos()),
        "outer_radius": Key("float", REQUIRED, "Outer radius of the cylinder (> inner_radius).", "mm",
                            kinds=("thick_cylinder",), **_pos()),
        "cells_circumferential": Key("int", 4, "Cells along the axis / out of the radial direction.",
                                     kinds=("thick_cylinder",), lo=1, lo_open=False),
        "blank_radius": Key("float", 65.53, "Radius of the circular blank.", "mm",
                            kinds=("punch_stretching",), **_pos()),
        "thickness": Key("float", 1.0, "Blank thickness.", "mm", kinds=("punch_stretching",), **_pos()),
        "cells_thickness": Key("int", 4, "Cells through the thickness.", kinds=("punch_stretching",),
                               lo=1, lo_open=False),
        "grading": Key("float", 1.0, "Ratio of the radial cell size at the rim to that at the centre.",
                       kinds=("punch_stretching",), **_pos()),
    },
    "material": {
        "model": Key("str", "isochoric",
                     "seed: be^-1 radial return (Almansi, Simo-Ortiz); isochoric: exponential map in log strain.",
                     choices=("seed", "isochoric")),
        "E": Key("float", REQUIRED, "Young's modulus.", "MPa", **_pos()),
        "nu": Key("float", REQUIRED, "Poisson's ratio.", "", lo=-1.0, hi=0.5),
        "density": Key("float", OPTIONAL,
                       "Mass density, given in kg/m^3; stored as material.density in tonne/mm^3 (x 1e-12), "
                       "the value as written in material.density_kg_m3. Required when inertia is active.",
                       "kg/m^3", required_if="inertia", scale=1e-12, raw_name="density_kg_m3", **_pos()),
    },
    "material.hardening": {
        "law": Key("str", REQUIRED, "Hardening law; fixes which other keys are allowed.", choices=LAWS),
        "yield_stress": Key("float", REQUIRED, "Initial yield stress.", "MPa", laws=("linear", "voce"), **_nonneg()),
        "modulus": Key("float", 0.0, "Linear hardening modulus (voce: added linear term).", "MPa",
                       laws=("linear", "voce"), **_nonneg()),
        "K": Key("float", REQUIRED, "Swift: sigma_y = K (eps0 + eqps)^n.", "MPa", laws=("swift",), **_pos()),
        "eps0": Key("float", REQUIRED, "Swift pre-strain.", "", laws=("swift",), **_pos()),
        "n": Key("float", REQUIRED, "Swift exponent.", "", laws=("swift",), lo=0.0, lo_open=False, hi=1.0,
                 hi_open=False),
        "Q": Key("float", REQUIRED, "Voce: sigma_y = yield_stress + Q (1 - exp(-b eqps)) + modulus eqps.", "MPa",
                 laws=("voce",), **_nonneg()),
        "b": Key("float", REQUIRED, "Voce saturation rate.", "", laws=("voce",), **_pos()),
        "strain": Key("floats", REQUIRED, "Table: equivalent plastic strains, >= 2, strictly increasing, first 0.",
                      "", laws=("table",)),
        "stress": Key("floats", REQUIRED, "Table: yield stress at each strain (piecewise linear), each >= 0.",
                      "MPa", laws=("table",)),
    },
    "loading": {
        "displacement": Key("float", REQUIRED, "Total end displacement (elongation) of the bar.", "mm",
                            kinds=("bar_tension",), **_pos()),
        "velocity": Key("float", REQUIRED,
                        "Impact velocity, given in m/s; stored as loading.velocity in mm/s (x 1e3), "
                        "the value as written in loading.velocity_m_s.",
                        "m/s", kinds=("taylor_bar",), scale=1e3, raw_name="velocity_m_s", **_nonneg()),
        "end_time_us": Key("float", REQUIRED, "Simulated time.", "us", kinds=("taylor_bar",), **_pos()),
        "pressure": Key("float", REQUIRED, "Final internal pressure.", "MPa", kinds=("thick_cylinder",), **_pos()),
        "travel": Key("float", 40.0, "Punch travel.", "mm", kinds=("punch_stretching",), **_pos()),
    },
    "tools": {
        "punch_radius": Key("float", 50.8, "Hemispherical punch radius.", "mm", kinds=("punch_stretching",), **_pos()),
        "die_opening_radius": Key("float", 59.18, "Die opening radius.", "mm", kinds=("punch_stretching",),
                                  **_pos()),
        "die_shoulder_radius": Key("float", 6.35, "Die shoulder (profile) radius.", "mm",
                                   kinds=("punch_stretching",), **_pos()),
    },
    "contact": {
        "friction": Key("float", 0.0, "Coulomb friction coefficient (> 0 turns friction on).", "",
                        kinds=("punch_stretching",), **_nonneg()),
        "law": Key("str", "quasi-coulomb", "Tangential law.", choices=("coulomb", "quasi-coulomb"),
                   kinds=("punch_stretching",)),
        "penalty": Key("float", OPTIONAL, "Normal penalty; absent = chosen by the runner.", "N/mm^3",
                       kinds=("punch_stretching",), **_pos()),
        "tangential_penalty": Key("float", OPTIONAL, "Tangential (stick) penalty; absent = chosen by the runner.",
                                  "N/mm^3", kinds=("punch_stretching",), **_pos()),
    },
    "solver": {
        "increments": Key("int", 20, "Initial number of equal load steps.", kinds=STATIC, lo=1, lo_open=False),
        "min_increment": Key("float", 1e-4, "Smallest load step (fraction of the total load) before giving up.",
                             kinds=STATIC, lo=0.0, hi=1.0, hi_open=False),
        "max_increment": Key("float", 0.1, "Largest load step (fraction of the total load).",
                             kinds=STATIC, lo=0.0, hi=1.0, hi_open=False),
        "max_iterations": Key("int", 25, "Newton iterations per step before cutting back.", kinds=STATIC,
                              lo=2, lo_open=False),
        "rtol": Key("float", 1e-9, "Relative residual tolerance.", kinds=STATIC, **_pos()),
        "atol": Key("float", 1e-8, "Absolute residual tolerance.", "N", kinds=STATIC, **_pos()),
        "linesearch": Key("str", "bt", "SNES line search.", choices=("bt", "basic", "l2"), kinds=STATIC),
        "dt_safety": Key("float", 0.8, "Time step = dt_safety x stable limit.", kinds=EXPLICIT,
                         lo=0.0, hi=1.0, hi_open=False),
        "steps": Key("int", OPTIONAL, "Fixes dt = end_time/steps; refused if above the stable limit.",
                     kinds=EXPLICIT, lo=1, lo_open=False),
        "internal_force": Key("str", "fused", "How the explicit internal force is computed: 'fused' "
                              "(one compiled pass: kinematics, material, force; ~5x faster) or 'ufl' (the UFL "
                              "residual assembled by dolfinx). Same numbers to round-off.",
                              kinds=EXPLICIT, choices=("fused", "ufl")),
    },
    "output": {
        "xdmf": Key("bool", True, "Write fields to fields.xdmf."),
        "every": Key("int", 1, "Write fields every N increments / output steps.", lo=1, lo_open=False),
        "plots": Key("bool", True, "Write PNG plots."),
        "history_points": Key("int", 200, "Number of history rows (explicit runs).", kinds=EXPLICIT,
                              lo=2, lo_open=False),
        "checkpoint_every": [
            Key("int", 2000, "Checkpoint the run's state every N steps into `checkpoint/` of the output "
                "directory (0: never); `fenics-plast run SCENE --resume DIR` continues a killed run. "
                "Removed when the run succeeds.", kinds=EXPLICIT, lo=0, lo_open=False),
            Key("int", 10, "Checkpoint the run's state every N converged increments into `checkpoint/` of the "
                "output directory (0: never); `fenics-plast run SCENE --resume DIR` continues a killed run. "
                "Removed when the run succeeds.", kinds=STATIC, lo=0, lo_open=False),
        ],
    },
}

SECTIONS = tuple(SCHEMA)


def _entries(section: str, name: str) -> list[Key]:
    e = SCHEMA[section][name]
    return e if isinstance(e, list) else [e]


def _key_for(section: str, name: str, kind: str) -> Key | None:
    for k in _entries(section, name):
        if kind in k.kinds:
            return k
    return None


def _keys_for_kind(section: str, kind: str, law: str | None = None) -> dict[str, Key]:
    out = {}
    for name in SCHEMA[section]:
        k = _key_for(section, name, kind)
        if k is None:
            continue
        if section == "material.hardening" and k.laws is not None and law is not None and law not in k.laws:
            continue
        out[name] = k
    return out


def _section_allowed(section: str, kind: str) -> bool:
    return kind in SECTION_KINDS.get(section, KINDS)


# ----------------------------------------------------------------------------------------------
# Scene objects


class Section:
    """Read-only attribute access to one validated section (``scene.material.E``).

    The keys are plain instance attributes, so ``vars(section)`` works too (it also holds
    ``_dotted``, the section's dotted name; skip names starting with ``_``). ``to_dict()`` gives the
    keys only. Keys that do not apply to the scene kind are absent (AttributeError)."""

    def __init__(self, dotted: str, values: dict[str, Any]):
        object.__setattr__(self, "_dotted", dotted)
        for k, v in values.items():
            object.__setattr__(self, k, v)

    @property
    def _values(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if not k.startswith("_")}

    def __getattr__(self, name: str):
        if name.startswith("__"):
            raise AttributeError(name)
        raise AttributeError(f"scene section [{self.__dict__.get('_dotted')}] has no key {name!r} "
                             f"(has: {', '.join(self._values)})")

    def __setattr__(self, name, value):
        raise AttributeError("scene sections are read-only; use --set to override keys")

    def _set(self, name: str, value) -> None:
        object.__setattr__(self, name, value)

    def __getitem__(self, name: str):
        return self._values[name]

    def __contains__(self, name: str) -> bool:
        return name in self._values

    def __iter__(self):
        return iter(self._values)

    def get(self, name: str, default=None):
        return self._values.get(name, default)

    def keys(self):
        return self._values.keys()

    def to_dict(self) -> dict[str, Any]:
        return {k: (v.to_dict() if isinstance(v, Section) else (list(v) if isinstance(v, tuple) else v))
                for k, v in self._values.items()}

    def __repr__(self) -> str:
        return f"Section[{self._dotted}]({self.to_dict()!r})"


@dataclass
class Scene:
    path: Path
    kind: str
    name: str
    sections: dict[str, Section | None]
    overrides: tuple[str, ...] = field(default_factory=tuple)

    def __getattr__(self, name: str):
        sections = self.__dict__.get("sections", {})
        if name in sections:
            return sections[name]
        raise AttributeError(f"Scene has no attribute {name!r}")

    @property
    def description(self) -> str:
        return self.sections["scene"].description

    @property
    def active_physics(self) -> list[str]:
        phys = set()
        if self.sections["material"].hardening is not None:
            phys.add("plasticity")
        contact = self.sections.get("contact")
        if contact is not None:
            phys.add("contact")
            if contact.friction > 0:
                phys.add("friction")
        if self.kind in EXPLICIT:
            phys.add("inertia")
        return sorted(phys)

    @property
    def explicit(self) -> bool:
        return self.kind in EXPLICIT

    def to_dict(self) -> dict[str, Any]:
        """Nested plain dict in internal units (plus the ``*_kg_m3`` / ``*_m_s`` keys as written);
        absent optional sections are None."""
        return {s: (sec.to_dict() if sec is not None else None) for s, sec in self.sections.items()}


# ----------------------------------------------------------------------------------------------
# Validation


def _fmt(v) -> str:
    if isinstance(v, str):
        return repr(v)
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return _num(v)
    return str(v)


class _Validator:
    def __init__(self, where: str):
        self.where = where

    def fail(self, msg: str):
        raise SceneError(f"{self.where}: {msg}")

    def coerce(self, dotted: str, key: Key, v):
        tname = {"str": "a string", "int": "an integer", "float": "a number", "bool": "true or false",
                 "floats": "a list of numbers"}[key.type]
        bad = False
        if key.type == "str":
            bad = not isinstance(v, str)
        elif key.type == "bool":
            bad = not isinstance(v, bool)
        elif key.type == "int":
            bad = isinstance(v, bool) or not isinstance(v, int)
        elif key.type == "float":
            bad = isinstance(v, bool) or not isinstance(v, (int, float))
            if not bad:
                v = float(v)
                if not math.isfinite(v):
                    self.fail(f"{dotted} = {_fmt(v)} is not a finite number")
        elif key.type == "floats":
            bad = not isinstance(v, list) or any(isinstance(x, bool) or not isinstance(x, (int, float)) for x in v)
            if not bad:
                v = tuple(float(x) for x in v)
        if bad:
            self.fail(f"{dotted} = {_fmt(v)} has the wrong type: must be {tname}")
        if key.choices is not None and v not in key.choices:
            self.fail(f"{dotted} = {_fmt(v)} is not allowed: must be one of {', '.join(key.choices)}")
        if key.type in ("int", "float") and not key.in_range(v):
            self.fail(f"{dotted} = {_fmt(v)} is out of range: must satisfy {key.range_text(dotted.split('.')[-1])}")
        return v


def _flatten_sections(raw: dict, v: _Validator) -> dict[str, dict]:
    """Top-level tables -> {'scene': {...}, 'material': {...}, 'material.hardening': {...}}."""
    out: dict[str, dict] = {}
    for top, val in raw.items():
        if top not in SCHEMA:
            v.fail(f"{top}: unknown section [{top}]: allowed sections are "
                   f"{', '.join('[' + s + ']' for s in SECTIONS)}")
        if not isinstance(val, dict):
            v.fail(f"{top} = {_fmt(val)}: [{top}] must be a table")
        out[top] = {}
        for k, x in val.items():
            sub = f"{top}.{k}"
            if sub in SCHEMA:
                if not isinstance(x, dict):
                    v.fail(f"{sub} = {_fmt(x)}: [{sub}] must be a table")
                out[sub] = dict(x)
            else:
                out[top][k] = x
    return out


def _validate(raw: dict, where: str, path: Path, overrides: tuple[str, ...]) -> Scene:
    v = _Validator(where)
    tables = _flatten_sections(raw, v)

    if "scene" not in tables:
        v.fail("scene: missing required section [scene] (with name and kind)")
    sc = tables["scene"]
    if "kind" not in sc:
        v.fail(f"scene.kind is missing: required, one of {', '.join(KINDS)}")
    kind = v.coerce("scene.kind", SCHEMA["scene"]["kind"], sc["kind"])
    inertia = kind in EXPLICIT

    sections: dict[str, Section | None] = {}
    for section in SECTIONS:
        given = tables.get(section)
        if not _section_allowed(section, kind):
            if given is not None:
                allowed = ", ".join(SECTION_KINDS[section])
                v.fail(f"{section}: section [{section}] is not allowed for kind {kind!r} (only for {allowed})")
            sections[section] = None   # e.g. scene.contact / scene.tools are None for a bar
            continue
        if section in OPTIONAL_SECTIONS and given is None:
            sections[section] = None
            continue
        given = given or {}

        law = None
        if section == "material.hardening":
            if "law" not in given:
                v.fail(f"material.hardening.law is missing: required, one of {', '.join(LAWS)}")
            law = v.coerce("material.hardening.law", SCHEMA[section]["law"], given["law"])
        allowed = _keys_for_kind(section, kind, law)

        for name in given:
            dotted = f"{section}.{name}"
            if name in allowed:
                continue
            if name in SCHEMA[section]:
                if section == "material.hardening":
                    v.fail(f"{dotted} is not a parameter of law {law!r}: allowed keys are {', '.join(allowed)}")
                kinds = sorted({k for e in _entries(section, name) for k in e.kinds})
                v.fail(f"{dotted} is not allowed for kind {kind!r} (only for {', '.join(kinds)}); "
                       f"allowed keys in [{section}] are {', '.join(allowed)}")
            v.fail(f"{dotted} is an unknown key: allowed keys in [{section}] for kind {kind!r} are "
                   f"{', '.join(allowed)}")

        values: dict[str, Any] = {}
        for name, key in allowed.items():
            dotted = f"{section}.{name}"
            if name in given:
                val = v.coerce(dotted, key, given[name])
            else:
                required = key.default is REQUIRED or (key.required_if == "inertia" and inertia)
                if required:
                    if section not in tables and section != "material.hardening":
                        v.fail(f"{section}: missing required section [{section}] (needs {dotted})")
                    why = " when inertia is active" if key.required_if else ""
                    rng = key.range_text(name)
                    what = (f"one of {', '.join(key.choices)}" if key.choices else
                            f"{'a list of numbers' if key.type == 'floats' else key.type}"
                            + (f", {rng}" if rng else "") + (f" [{key.unit}]" if key.unit else ""))
                    v.fail(f"{dotted} is missing: required{why} ({what})")
                val = None if key.default is OPTIONAL else key.default
            if key.raw_name is not None:
                values[key.raw_name] = val
                val = None if val is None else val * key.scale
            values[name] = val
        sections[section] = Section(section, values)

    _cross_checks(sections, kind, v)

    # nest hardening into material
    mat = sections["material"]
    mat._set("hardening", sections.pop("material.hardening"))
    scene = Scene(path=path, kind=kind, name=sections["scene"].name, sections=sections, overrides=overrides)
    return scene


def _cross_checks(s: dict[str, Section | None], kind: str, v: _Validator):
    mesh = s["mesh"]
    if kind == "thick_cylinder" and mesh.outer_radius <= mesh.inner_radius:
        v.fail(f"mesh.outer_radius = {_fmt(mesh.outer_radius)} is out of range: must be greater than "
               f"mesh.inner_radius = {_fmt(mesh.inner_radius)}")
    sol = s["solver"]
    if kind in STATIC and sol.min_increment > sol.max_increment:
        v.fail(f"solver.min_increment = {_fmt(sol.min_increment)} is out of range: must not exceed "
               f"solver.max_increment = {_fmt(sol.max_increment)}")
    h = s.get("material.hardening")
    if h is not None and h.law == "table":
        eps, sig = h.strain, h.stress
        if len(eps) < 2:
            v.fail(f"material.hardening.strain has {len(eps)} entries: must have at least 2")
        if eps[0] != 0.0:
            v.fail(f"material.hardening.strain = {list(eps)} is not allowed: the first entry must be 0")
        if any(b <= a for a, b in zip(eps, eps[1:])):
            v.fail(f"material.hardening.strain = {list(eps)} is not allowed: must be strictly increasing")
        if len(sig) != len(eps):
            v.fail(f"material.hardening.stress has {len(sig)} entries: must have as many as "
                   f"material.hardening.strain ({len(eps)})")
        if any(x < 0 for x in sig):
            v.fail(f"material.hardening.stress = {list(sig)} is out of range: each entry must be >= 0")


# ----------------------------------------------------------------------------------------------
# Overrides and loading


def parse_scene(text: str, path: str | Path = "<string>", overrides: Iterable[str] = ()) -> Scene:
    """Validate TOML text (``path`` is only used in messages and as ``scene.path``)."""
    return parse_with(_validate, text, path, overrides)


def load_scene(path: str | Path, overrides: Iterable[str] = ()) -> Scene:
    """Read and validate a scene file; ``overrides`` are ``"a.b.c=value"`` strings (``--set``)."""
    return parse_scene(read_scene_file(path), path, overrides)


def load_any(path: str | Path, overrides: Iterable[str] = ()):
    """A :class:`fenics_plast.problem.Problem` for a file of the general format (it has [analysis]),
    else a :class:`Scene` of the old kinds (until those are removed)."""
    from fenics_plast.problem import parse_problem
    text = read_scene_file(path)
    return (parse_problem if is_general(text) else parse_scene)(text, path, overrides)


# ----------------------------------------------------------------------------------------------
# Documentation


def _default_text(k: Key) -> str:
    if k.default is REQUIRED:
        return "**required**"
    if k.required_if == "inertia":
        return "required with inertia"
    if k.default is OPTIONAL:
        return "optional"
    if isinstance(k.default, bool):
        return f"`{_fmt(k.default)}`"
    if isinstance(k.default, str):
        return f'`"{k.default}"`'
    return f"`{_fmt(k.default)}`"


def _allowed_text(name: str, k: Key) -> str:
    if k.choices is not None:
        return " \\| ".join(f"`{c}`" for c in k.choices)
    r = k.range_text(name)
    return r.replace("<=", "≤").replace(">=", "≥") if r else ""


def keys_markdown() -> str:
    """The text of docs/SCENE_KEYS.md, generated from :data:`SCHEMA`."""
    L = [
        "# Scene file keys",
        "",
        "<!-- Generated from fenics_plast/scene.py (SCHEMA) by `fenics-plast keys > docs/SCENE_KEYS.md`."
        " Do not edit by hand; tests/test_scene.py checks it is up to date. -->",
        "",
        "Scene files are TOML. Units: **mm, N, MPa, s**. Two exceptions are converted on reading:",
        "`material.density` is written in kg/m³ and available to runners as `scene.material.density` in",
        "tonne/mm³ (× 1e-12; the value as written is `scene.material.density_kg_m3`), and `loading.velocity`",
        "is written in m/s and available as `scene.loading.velocity` in mm/s (× 1e3; as written:",
        "`scene.loading.velocity_m_s`).",
        "",
        "Any key can be overridden from the command line: `fenics-plast run SCENE.toml --set material.nu=0.3`",
        "(the value is parsed as a TOML value, else taken as a string, and validated like a file key).",
        "",
        "Active physics (reported in summary.json): `plasticity` if `[material.hardening]` is present,",
        "`contact` if `[contact]` is present, `friction` if `contact.friction > 0`, `inertia` for `taylor_bar`.",
        "",
        "Kinds: " + ", ".join(f"`{k}`" for k in KINDS) + ". A key listed for some kinds only is an error in",
        "a scene of another kind.",
        "",
    ]
    for section in SECTIONS:
        L.append(f"## [{section}]")
        L.append("")
        sk = SECTION_KINDS.get(section)
        L.append(SECTION_DOCS[section] + (f" Kinds: {', '.join(sk)}." if sk else ""))
        L.append("")
        hard = section == "material.hardening"
        L.append("| key | type | default | allowed | unit | " + ("laws" if hard else "kinds") + " | meaning |")
        L.append("|---|---|---|---|---|---|---|")
        for name in SCHEMA[section]:
            for k in _entries(section, name):
                if hard:
                    scope = "all" if k.laws is None else ", ".join(k.laws)
                else:
                    scope = "all" if k.kinds == KINDS else ", ".join(k.kinds)
                typ = "list of floats" if k.type == "floats" else k.type
                L.append(f"| `{name}` | {typ} | {_default_text(k)} | {_allowed_text(name, k)} | {k.unit} | "
                         f"{scope} | {k.doc} |")
        L.append("")
    L += [
        "## Cross-key rules",
        "",
        "* `mesh.outer_radius > mesh.inner_radius` (thick_cylinder).",
        "* `solver.min_increment ≤ solver.max_increment` (static kinds).",
        "* `material.hardening` table law: `strain` has ≥ 2 entries, starts at 0, strictly increasing;"
        " `stress` has the same length, each ≥ 0.",
        "* `material.density` is required when inertia is active (taylor_bar).",
        "",
    ]
    return "\n".join(L)


DOCS_PATH = Path(__file__).resolve().parent.parent / "docs" / "SCENE_KEYS.md"
README_PATH = DOCS_PATH.parent.parent / "README.md"
README_MARKERS = ("<!-- scene-keys:start (generated: `make keys`) -->", "<!-- scene-keys:end -->")


def readme_keys_section() -> str:
    """The key reference as embedded in README.md: headings one level down, between the markers."""
    body = "\n".join(("#" + line) if line.startswith("#") else line
                     for line in keys_markdown().splitlines()[1:])      # without the "# Scene file keys" title
    return f"{README_MARKERS[0]}\n{body.strip()}\n{README_MARKERS[1]}"


def readme_with_keys(text: str) -> str:
    """README text with the section between the markers replaced by :func:`readme_keys_section`."""
    start, end = text.find(README_MARKERS[0]), text.find(README_MARKERS[1])
    if start < 0 or end < start:
        raise ValueError(f"README.md lacks the markers {README_MARKERS}")
    return text[:start] + readme_keys_section() + text[end + len(README_MARKERS[1]):]


def write_keys_doc(path: str | Path = DOCS_PATH, readme: str | Path | None = README_PATH) -> Path:
    """Rewrite docs/SCENE_KEYS.md and the key reference embedded in README.md."""
    path = Path(path)
    path.write_text(keys_markdown(), encoding="utf-8")
    if readme is not None and Path(readme).exists():
        readme = Path(readme)
        readme.write_text(readme_with_keys(readme.read_text(encoding="utf-8")), encoding="utf-8")
    return path


if __name__ == "__main__":  # python -m fenics_plast.scene  -> rewrite docs/SCENE_KEYS.md and README's copy
    print(write_keys_doc())
