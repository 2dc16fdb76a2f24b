"""Validation of a scene file's raw TOML data against :data:`fenics_plast.schema.SCHEMA`.

:func:`validate_tables` checks every section, key, type, range, choice and variant, then the rules
between keys (:func:`_cross_checks`), and returns the validated tables as :class:`Section` objects
(collections as dicts name -> Section). Every error is a :class:`fenics_plast.errors.SceneError`
whose message names the file and the dotted key; nothing else is raised. Values that vary in space
or time become :class:`fenics_plast.expressions.Value` (numbers, tables, checked expressions).
"""
from __future__ import annotations

import math
from typing import Any

from fenics_plast import meshed_tools
from fenics_plast.errors import SceneError
from fenics_plast.output import file_name_problem, reserved_name_problem
from fenics_plast.expressions import ExpressionError, check_times, parse_value
from fenics_plast.hardening_laws import laws
from fenics_plast.quantities.registry import column_names, kind
from fenics_plast.tool_shapes import shapes as tool_shapes
from fenics_plast.schema import (OPTIONAL, REQUIRED, SCHEMA, SECTIONS, US, Key, Table, VALUE_DOC, number_text,
                                  component_names, is_cell_count, vector_size)

__all__ = ["Section", "validate_tables"]


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




def _fmt(v) -> str:
    if isinstance(v, str):
        return repr(v)
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return number_text(v)
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k} = {_fmt(x)}" for k, x in v.items()) + "}"
    if isinstance(v, list):
        return "[" + ", ".join(_fmt(x) for x in v) + "]"
    return str(v)


_TYPE_TEXT = {"str": "a string", "int": "an integer", "float": "a number", "bool": "true or false",
              "floats": "a list of numbers", "strs": "a list of strings (or one string)",
              "vector": "a list of 2 numbers [x, y] (3 in 3-D: [x, y, z])", "value": VALUE_DOC,
              "values": "a value or a list of values, each " + VALUE_DOC,
              "segments": "a list of inline tables { line = ... } or { arc = ..., radius = ..., from = ..., to = ... }",
              "path": "an inline table { t = [...], x = [...], y = [...] } (and z = [...] in 3-D)"}


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
            bad = not isinstance(v, list) or len(v) not in (2, 3) or not all(_is_number(x) for x in v)
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
        explicit analyses are in µs in the file: the value's t is scaled to seconds by ``build.time_function``."""
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
        if not isinstance(v, dict) or "t" not in v or not (set(v) - {"t"}) or not set(v) <= {"t", "x", "y", "z"}:
            self.fail(f"{dotted} = {_fmt(v)} has the wrong type: must be {_TYPE_TEXT['path']}")
        out = {}
        for comp in ("x", "y", "z"):
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


def validate_tables(raw: dict, where: str) -> dict[str, Any]:
    """The validated tables of raw TOML data ``raw`` (``where``: the file, for messages)."""
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
            if not spec.collection and any(k.default is REQUIRED for k in spec.keys.values()):
                tables[sec] = None          # an optional table with required keys: absent = off ([remeshing])
                continue
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
    return tables


def _shown(name: str) -> str:
    """A name for a message: as is when short and printable, else quoted and cut."""
    if len(name) <= 60 and name.isprintable():
        return name
    return repr(name[:60]) + (f"... ({len(name)} characters)" if len(name) > 60 else "")


def _name_checks(t: dict[str, Any], v: _Validator):
    """Names that become file names (output.file_name_problem): scene.name (results/<name>), plots
    (<name>.png) and outputs (<name>.csv for a thickness profile; checked for every output); plots and
    outputs may not take the names of the run's own files (output.reserved_name_problem: history, summary,
    fields, final_shape, checkpoint, ...)."""
    name = t["scene"].name
    why = file_name_problem(name)
    if why:
        v.fail(f"scene.name = {_shown(name) if len(name) > 60 else _fmt(name)}: the name {why} (it names the "
               f"default output folder results/<name>)")
    for n in t["plots"]:
        why = file_name_problem(n) or reserved_name_problem(n)
        if why:
            v.fail(f"plots.{_shown(n)}: the plot's name {why} (it names the file <name>.png in the output folder)")
    for n in t["outputs"]:
        why = file_name_problem(n) or reserved_name_problem(n)
        if why:
            v.fail(f"outputs.{_shown(n)}: the output's name {why} (it names a column of history.csv and, for a "
                   f"thickness profile, the file <name>.csv in the output folder)")


def _remeshing_checks(t: dict[str, Any], v: _Validator, geometry: str):
    """[remeshing]: 2-D bodies; boundary values that do not depend on x, y, z (a new mesh's reference
    coordinates are the deformed ones, so a value of the initial coordinates has no meaning there)."""
    rm = t["remeshing"]
    if geometry == "3d":
        v.fail("remeshing: [remeshing] is for 2-D bodies (mesh.geometry axisymmetric or plane_strain), "
               "not 3d")
    if rm.refine_size is not None and rm.refine_size > rm.size:
        v.fail(f"remeshing.refine_size = {_fmt(rm.refine_size)} is out of range: must not exceed "
               f"remeshing.size = {_fmt(rm.size)}")
    if v.analysis == "explicit":
        ana = t["analysis"]
        why = ([f"contact.{n}" for n in t["contact"]]
               + [f"boundary.{n} (type {b.type})" for n, b in t["boundary"].items()
                  if b.type in ("velocity", "displacement", "traction", "pressure")]
               + (["analysis.erosion_ratio > 0"] if ana.erosion_ratio > 0.0 else [])
               + (["analysis.mass_scaling_dt > 0"] if ana.mass_scaling_dt > 0.0 else []))
        if why:
            v.fail(f"remeshing: explicit runs remesh bodies without contact pairs, prescribed motions, loads, "
                   f"erosion and mass scaling (not yet built): {', '.join(why)}")
    for n, b in t["boundary"].items():
        value = b.get("value")
        for val in (value if isinstance(value, tuple) else (value,)):
            if getattr(val, "depends_on_space", False):
                v.fail(f"boundary.{n}.value depends on x, y or z: with [remeshing] boundary values must be "
                       f"functions of t alone (a new mesh's reference is the deformed shape)")


def _thermal_checks(t: dict[str, Any], v: _Validator):
    """[thermal] and what it needs: physical time, each material's heat capacity and conductivity, the tool's
    temperature of a pair with a conductance; a Johnson-Cook law's heat keys the material's (its points take
    the field's temperature); not yet friction heat or a pressure-dependent conductance between two facet
    groups of the body. Thermal keys without [thermal] would be ignored: refused."""
    thermal = t.get("thermal")
    if thermal is None:
        for n, c in t["contact"].items():
            if c.conductance is not None:
                v.fail(f"contact.{n}.conductance is given but there is no [thermal] table: it would be ignored")
        for n, tool in t["tools"].items():
            if tool.get("temperature") is not None:
                v.fail(f"tools.{n}.temperature is given but there is no [thermal] table: it would be ignored")
        if t["thermal_boundary"]:
            v.fail(f"thermal_boundary.{next(iter(t['thermal_boundary']))}: thermal boundaries need a [thermal] table")
        for n, m in t["materials"].items():
            if m.hardening is not None and m.hardening.law == "hensel_spittel":
                v.fail(f"materials.{n}.hardening.law = 'hensel_spittel' needs a [thermal] table (its temperature is "
                       f"the temperature field's, its rate in physical time)")
        for n, m in t["materials"].items():
            for k in ("conductivity", "specific_heat", "expansion"):
                if m.get(k) is not None:
                    v.fail(f"materials.{n}.{k} is given but there is no [thermal] table (heat conduction): it "
                           f"would be ignored")
        return
    if v.analysis == "static" and t["analysis"].duration is None:
        v.fail("analysis.duration is missing: required by [thermal] (the physical time of the static "
               "analysis, s)")
    if v.analysis == "explicit":
        why = ([f"contact.{n} (friction or conductance)" for n, c in t["contact"].items()
                if c.friction > 0.0 or c.conductance is not None]
               + [f"materials.{n}.expansion" for n, m in t["materials"].items() if m.get("expansion")]
               + (["[remeshing]"] if t.get("remeshing") is not None else []))
        if why:
            v.fail(f"thermal: explicit runs with [thermal] take no heat at tool contacts, thermal expansion or "
                   f"remeshing yet (not built): {', '.join(why)}")
    for n, m in t["materials"].items():
        for k, unit in (("density", "kg/m³"), ("conductivity", "W/(m K)"), ("specific_heat", "J/(kg K)")):
            if m.get(k) is None:
                v.fail(f"materials.{n}.{k} is missing: required by [thermal] [{unit}]")
        h = m.hardening
        if h is not None and h.law == "johnson_cook":     # its points take the field's temperature
            if h.initial_temperature is not None:
                v.fail(f"materials.{n}.hardening.initial_temperature is given with [thermal]: the temperature "
                       f"starts at thermal.initial_temperature (leave the law's out)")
            for k in ("specific_heat", "taylor_quinney"):
                if getattr(h, k) != m.get(k):
                    v.fail(f"materials.{n}.hardening.{k} = {_fmt(getattr(h, k))} differs from materials.{n}.{k} = "
                           f"{_fmt(m.get(k))}: with [thermal] they are one property of the material")
    for n, c in t["contact"].items():
        if c.get("master") is not None and c.friction > 0.0:
            v.fail(f"contact.{n}: friction heat between two facet groups of the body is not built yet: "
                   f"contact.{n}.master with friction > 0 and [thermal]")
        if c.get("master") is not None and c.conductance_pressure is not None:
            v.fail(f"contact.{n}.conductance_pressure: a pressure-dependent conductance between two facet groups "
                   f"of the body is not built yet")
        if c.conductance_pressure is not None and c.conductance is None:
            v.fail(f"contact.{n}.conductance_pressure is given without contact.{n}.conductance: it would be ignored")
        if c.conductance is not None and c.get("tool") is not None and t["tools"][c.tool].get("temperature") is None:
            v.fail(f"tools.{c.tool}.temperature is missing: required by contact.{n}.conductance (the tool's "
                   f"temperature) [K]")


def _cross_checks(t: dict[str, Any], v: _Validator):
    """Rules between keys (each message names the keys)."""
    _name_checks(t, v)
    ana, explicit = t["analysis"], v.analysis == "explicit"
    geometry = t["mesh"].geometry
    dim = vector_size(geometry)
    _geometry_checks(t, v, geometry)
    if t.get("remeshing") is not None:
        _remeshing_checks(t, v, geometry)
    _thermal_checks(t, v)
    if explicit and ana.erosion_ratio > 0.0 and ana.internal_force != "fused":
        v.fail(f"analysis.erosion_ratio = {_fmt(ana.erosion_ratio)} needs analysis.internal_force = 'fused': "
               f"element erosion is a part of the compiled force pass")
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
        law = None if m.hardening is None else laws()[m.hardening.law]
        if law is not None and law.check is not None:
            law.check(f"materials.{n}", m, v.fail)
    for n, b in t["boundary"].items():
        d = f"boundary.{n}"
        if b.group is None and b.type != "wall":
            v.fail(f"{d}.group is missing: required (a facet group) for type = {b.type!r}")
        if b.type == "velocity" and not explicit:
            v.fail(f"{d}.type = 'velocity' is only for explicit analyses (static: type = 'displacement')")
        if b.type == "wall" and not explicit:
            v.fail(f"{d}.type = 'wall' is only for explicit analyses (static: a contact pair with a plane tool)")
        if b.type == "wall" and len(b.components) != 1:
            v.fail(f"{d}.components = {list(b.components)}: a wall takes one component, the axis its plane is "
                   f"normal to")
        if b.type == "axis" and t["mesh"].geometry != "axisymmetric":
            v.fail(f"{d}.type = 'axis' needs mesh.geometry = 'axisymmetric'")
        comps = b.get("components")
        if comps is not None:
            names = component_names(geometry)
            for c in comps:
                if c not in names:
                    v.fail(f"{d}.components = {list(comps)}: {c!r} is not a component with mesh.geometry = "
                           f"{geometry!r}: must be one of {', '.join(names)}")
            if len(set(names[c] for c in comps)) != len(comps):
                v.fail(f"{d}.components = {list(comps)} names a component twice")
            val = b.get("value")
            if isinstance(val, tuple) and len(val) != len(comps):
                v.fail(f"{d}.value has {len(val)} entries: must have one per component ({len(comps)}) or be one value")
        if b.type == "pressure" and isinstance(b.value, tuple):
            v.fail(f"{d}.value must be one value (the pressure)")
    for n, iv in t["initial_velocity"].items():
        val = iv.value
        if not isinstance(val, tuple) or len(val) != dim:
            v.fail(f"initial_velocity.{n}.value must be a list of {dim} values "
                   f"[{', '.join('v' + c for c in 'xyz'[:dim])}] [m/s] with mesh.geometry = {geometry!r}")
        for i, x in enumerate(val):
            if x.depends_on_time:
                v.fail(f"initial_velocity.{n}.value[{i}] may depend on x, y, z only, not on t")
    tools = t["tools"]
    for n, c in t["contact"].items():
        master = c.get("master")
        if (c.tool is None) == (master is None):
            v.fail(f"contact.{n}: give exactly one master surface, tool (a rigid tool) or master (a facet group "
                   f"of the body)")
        elif c.tool is not None and c.tool not in tools:
            v.fail(f"contact.{n}.tool = {c.tool!r} is not a tool: tools are {', '.join(tools) or 'none'}")
        elif master is not None and master == c.group and c.get("two_pass") is not None:
            v.fail(f"contact.{n}.two_pass: a self-contact pair (master = group) has one pass, its nodes against "
                   f"its own facets")
        if c.get("two_pass") is not None and master is None:
            v.fail(f"contact.{n}.two_pass applies to a pair with master (a facet group of the body)")
    column_count = {n: len(column_names(n, o)) for n, o in t["outputs"].items()}
    # expressions may name the one-column outputs declared before them; at_max_of any one-column one
    single_columns = [n for n, o in t["outputs"].items()
                      if column_count[n] == 1 and not getattr(kind(o.quantity), "DERIVED", False)]
    ctx = dict(tools=tools, contacts=t["contact"], explicit=explicit, symbols=single_columns, end=analysis_end(t),
               loads=[n for n, b in t["boundary"].items() if b.type in ("traction", "pressure")],
               thermal=t.get("thermal") is not None, thermal_boundaries=tuple(t["thermal_boundary"]))
    for n, o in t["outputs"].items():
        d = f"outputs.{n}"
        _kind_check(o, "check", d, ctx, v)
        for s in o.summary:
            if s not in ("final", "max", "min"):
                v.fail(f"{d}.summary = {list(o.summary)}: entries must be final, max or min")
        if o.at_max_of is not None and (column_count.get(o.at_max_of) != 1 or o.at_max_of == n
                                        or column_count[n] != 1):
            ones = [m for m, c in column_count.items() if c == 1 and m != n]
            v.fail(f"{d}.at_max_of = {o.at_max_of!r}: must name another one-column output (and this output "
                   f"must have one column); one-column outputs: {', '.join(ones) or 'none'}")
        if getattr(kind(o.quantity), "DERIVED", False):
            single_columns.append(n)
    for n, p in t["plots"].items():
        if p.type == "profile" and (p.output not in t["outputs"]
                                    or not getattr(kind(t["outputs"][p.output].quantity), "PROFILE", False)):
            v.fail(f"plots.{n}.output = {p.output!r} is not a thickness output")
    # a temperature is the state of the materials of a thermal law only
    thermal = any(m.hardening is not None and laws()[m.hardening.law].thermal for m in mats.values())
    asks = [f"outputs.{n}.field" for n, o in t["outputs"].items() if o.quantity == "field" and o.field == "temperature"]
    if t.get("thermal") is None:        # (with [thermal] a shape plot takes the temperature field's cell means)
        asks += [f"plots.{n}.field" for n, p in t["plots"].items() if p.type == "shape" and p.field == "temperature"]
    if asks and not thermal:
        names = " or ".join(repr(law.name) for law in laws().values() if law.thermal)
        v.fail(f"{asks[0]} = 'temperature' needs a material with a temperature: hardening.law = {names}"
               + (" (the temperature field of [thermal]: quantity = 'temperature')" if t.get("thermal") else
                  " or a [thermal] table for a shape plot"))
    ends = [s.end for s in t["steps"].values()]
    if len(set(ends)) != len(ends):
        v.fail("steps: two steps have the same end")
    _before_run_checks(t, v)




def _geometry_checks(t: dict[str, Any], v: _Validator, geometry: str):
    """What depends on mesh.geometry: vectors of 2 entries in 2-D and 3 in 3-D, the tool shapes of each,
    the output components, and what exists in 2-D only (thickness profiles, shape plots, axis)."""
    dim, three_d = vector_size(geometry), geometry == "3d"
    where = f"with mesh.geometry = {geometry!r}"

    def vector(dotted, x):
        if x is not None and len(x) != dim:
            v.fail(f"{dotted} = {_fmt(list(x))} has {len(x)} entries: must have {dim} "
                   f"([{', '.join('xyz'[:dim])}]) {where}")
    for n, b in t["boundary"].items():
        if b.type == "axis" and three_d:
            v.fail(f"boundary.{n}.type = 'axis' is for axisymmetric meshes only: in 3-D use type = 'symmetry' "
                   f"on the planes of a sector model")
    for n, tool in t["tools"].items():
        d = f"tools.{n}"
        if tool.path is not None and "z" in tool.path and not three_d:
            v.fail(f"{d}.path.z: a 2-D tool moves in x and y only")
        if tool.shape == meshed_tools.SHAPE:
            continue                # its file and group are read, and checked, at the set-up (meshed_tools)
        for k, key in tool_shapes()[tool.shape].params.items():
            if key.type == "vector":
                vector(f"{d}.{k}", tool.get(k))
        _tool_shape_checks(d, tool, dim, where, v)
    names = component_names(geometry)
    for n, o in t["outputs"].items():
        d = f"outputs.{n}"
        _kind_check(o, "check_mesh", d, dict(geometry=geometry, three_d=three_d, where=where, vector=vector), v)
        comp = o.get("component")
        if comp == "radial":
            if not getattr(kind(o.quantity), "RADIAL", False):
                v.fail(f"{d}.component = 'radial' is for extent outputs only")
            if geometry == "plane_strain":
                v.fail(f"{d}.component = 'radial' (distance from the z axis) needs mesh.geometry = '3d' or "
                       f"'axisymmetric'")
        elif comp is not None and comp not in names:
            v.fail(f"{d}.component = {comp!r} is not a component {where}: must be one of "
                   f"{', '.join(names)}" + (" (or radial, the distance from the z axis)" if three_d else ""))
    for n, p in t["plots"].items():
        if p.type == "shape" and three_d:
            v.fail(f"plots.{n}.type = 'shape' draws 2-D meshes only: not available {where} (open fields.xdmf "
                   f"in ParaView)")


def _tool_shape_checks(d: str, tool, dim: int, where: str, v: _Validator):
    """The rules of the tool ``tool``'s shape (:mod:`fenics_plast.tool_shapes`) in ``dim`` dimensions: the
    shape exists there, the keys it requires there are given, its own check, and its parameters pack."""
    shape = tool_shapes()[tool.shape]
    if dim not in shape.dims:
        other = 5 - dim                      # 2 <-> 3
        names = [repr(s.name) for s in tool_shapes().values() if s.dims == (dim,)]
        alike = names[0] if len(names) == 1 else f"{', '.join(names[:-1])} or {names[-1]}"
        needs = " (mesh.geometry = '3d')" if other == 3 else ""
        v.fail(f"{d}.shape = {shape.name!r} is a {other}-D tool{needs}: in {dim}-D use {alike}")
    for k in shape.required.get(dim, ()):
        if tool.get(k) is None:
            unit = shape.params[k].unit
            v.fail(f"{d}.{k} is missing: required for shape = {shape.name!r} {where}" + (f" [{unit}]" if unit else ""))
    if shape.check is not None:
        shape.check(d, tool, dim, v.fail)
    try:
        shape.pack({k: tool.get(k) for k in shape.params}, dim)
    except ValueError as e:
        v.fail(f"{d}: {e}")


def _kind_check(o, rule: str, d: str, ctx: dict, v: _Validator):
    """The output ``o``'s quantity kind's validation ``rule`` (check, check_mesh, check_boundary; see
    :mod:`fenics_plast.quantities.registry`), if it has one."""
    check = getattr(kind(o.quantity), rule, None)
    if check is not None:
        check(d, o, ctx, v.fail)


def analysis_end(t: dict[str, Any]) -> float:
    """The end of the analysis's time range, in the unit of t in the scene's values: static, the
    pseudo-time at the end of the last step (1 without [steps]); explicit, end_time in µs."""
    if t["analysis"].type == "explicit":
        return t["analysis"].end_time / US
    return max([s.end for s in t["steps"].values()] or [1.0])


#: the kinds of [boundary] table that hold components of their group (axis: the radial one)
_HOLDS = ("fixed", "displacement", "velocity", "axis")


def held_components(b, geometry: str) -> list[int]:
    """Indices of the components a [boundary] table holds (fixed, displacement, velocity: its
    components; axis: r); a symmetry holds the one normal to its group, known on the mesh only."""
    if b.type == "axis":
        return [0]
    if b.type in _HOLDS:
        names = component_names(geometry)
        return [names[c] for c in b.components]
    return []


def _before_run_checks(t: dict[str, Any], v: _Validator):
    """What the scene alone tells about the run (issue 21): cell counts, one condition per component
    of a group, reactions only where a condition holds, explicit motions and loads uniform, and every
    value of t finite over the analysis (:func:`check_times` from 0 to :func:`analysis_end`). What
    needs the mesh (values of x, y, z, symmetry groups) is checked by ``scene_mesh.read_mesh``."""
    explicit, geometry = t["analysis"].type == "explicit", t["mesh"].geometry
    for k, x in t["mesh"].parameters.items():
        if is_cell_count(k) and not (float(x).is_integer() and x >= 1):
            v.fail(f"mesh.parameters.{k} = {_fmt(x)} is out of range: a cell count (a name that starts with "
                   f"'cells' or ends in '_cells') must be an integer >= 1")
    holder: dict[tuple[str, int], str] = {}
    for n, b in t["boundary"].items():
        for c in held_components(b, geometry):
            if (b.group, c) in holder:
                other = holder[(b.group, c)]
                label = {"3d": "xyz", "plane_strain": "xy"}.get(geometry, "rz")[c]
                v.fail(f"boundary.{n}: component {label} of group {b.group!r} is "
                       f"also held by boundary.{other} (type = {t['boundary'][other].type!r}): one condition per "
                       f"component of a group (merge boundary.{other} and boundary.{n})")
            holder[(b.group, c)] = n
    names = component_names(geometry)         # (a traction or pressure on a held component: scene_mesh.check_on_mesh)
    symmetric = {b.group for b in t["boundary"].values() if b.type == "symmetry"}
    # a reaction on a group no condition holds is refused on the mesh (scene_mesh.check_on_mesh), once the
    # groups the scene names are known to exist: a misspelt boundary group is named there as such, not as
    # the reaction's missing condition
    deferred = dict(holder)
    if any(b.group is not None for b in t["boundary"].values()):
        deferred.update({(o.group, c): "(checked on the mesh)" for o in t["outputs"].values()
                         if o.get("group") is not None for c in set(names.values()) if (o.group, c) not in holder})
    ctx = dict(explicit=explicit, components=names, holder=deferred, symmetric=symmetric)
    for n, o in t["outputs"].items():
        _kind_check(o, "check_boundary", f"outputs.{n}", ctx, v)
    times = check_times(analysis_end(t))
    for n, b in t["boundary"].items():
        val = b.get("value")
        if val is None:
            continue
        for x in (val if isinstance(val, tuple) else (val,)):
            if explicit and x.depends_on_space:
                what = ("prescribed motion" if b.type in ("velocity", "displacement") else "tractions")
                v.fail(f"boundary.{n}.value: explicit {what} must be uniform over the group (a function of t only)")
            if not x.depends_on_space:
                try:
                    x.check_finite(times)
                except ExpressionError as e:
                    v.fail(str(e))
        if explicit and b.type == "pressure":
            v.fail(f"boundary.{n}.type = 'pressure' is for static analyses (explicit: a uniform traction)")
