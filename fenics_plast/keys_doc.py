"""The scene-key reference (docs/SCENE_KEYS.md), generated from the schema.

``fenics-plast keys`` prints it, ``make keys`` rewrites docs/SCENE_KEYS.md, and
tests/test_problem.py checks that the file is up to date: the reference cannot drift from what the
validator accepts, because both read :data:`fenics_plast.schema.SCHEMA`.
"""
from __future__ import annotations

from pathlib import Path

from fenics_plast.schema import KG_M3, M_S, OPTIONAL, REQUIRED, SCHEMA, US, Key, Table

DOCS_PATH = Path(__file__).resolve().parent.parent / "docs" / "SCENE_KEYS.md"

_TYPES = {"str": "string", "int": "integer", "float": "number", "bool": "boolean", "floats": "list of numbers",
          "strs": "list of strings", "vector": "[x, y] (3-D: [x, y, z])", "values": "value(s)", "segments": "list of segments",
          "path": "table {t, x, y (, z)}"}
_SCALES = {US: "written in µs", M_S: "written in m/s", KG_M3: "written in kg/m³"}


def _fmt(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float) and v.is_integer() and abs(v) < 1e15:
        return str(int(v))
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_fmt(x) for x in v) + "]"
    return str(v)


def _default(k: Key) -> str:
    if k.default is REQUIRED:
        return "**required**"
    if k.default is OPTIONAL:
        return "optional"
    if k.analysis_default:
        return "; ".join(f"`{_fmt(v)}` ({a})" for a, v in k.analysis_default.items())
    return f"`{_fmt(k.default)}`"


def _allowed(name: str, k: Key) -> str:
    if k.choices is not None:
        return " \\| ".join(f"`{c}`" for c in k.choices)
    r = k.range_text(name)
    return r.replace("<=", "≤").replace(">=", "≥") if r else ""


def _scope(k: Key, discriminator: str | None) -> str:
    parts = []
    if k.when:
        parts += [f"{d} = {', '.join(v)}" for d, v in k.when.items()]
    if k.when_analysis:
        parts.append(f"analysis {', '.join(k.when_analysis)}")
    return "; ".join(parts) or "all"


def _table(L: list[str], header: str, t: Table) -> None:
    L += [f"## {header}", ""]
    scope = f" Only in {', '.join(t.when_analysis)} analyses." if t.when_analysis else ""
    named = " One table per name you choose." if t.collection else ""
    L += [t.doc + named + scope, ""]
    if t.free:
        L += ["Free keys: any name, a number each.", ""]
        return
    if t.keys:
        L += ["| key | type | default | allowed | unit | applies to | meaning |", "|---|---|---|---|---|---|---|"]
        for name, k in t.keys.items():
            unit = k.unit + (f" ({_SCALES[k.scale]})" if k.scale in _SCALES and k.unit == "" else "")
            L.append(f"| `{name}` | {_TYPES.get(k.type, k.type)} | {_default(k)} | {_allowed(name, k)} | "
                     f"{unit} | {_scope(k, t.discriminator)} | {k.doc} |")
        L.append("")
    for sub, st in t.subtables.items():
        _table(L, f"{header[:-1]}.{sub}]", st)


def keys_markdown() -> str:
    """The text of docs/SCENE_KEYS.md."""
    L = [
        "# Scene file keys",
        "",
        "<!-- Generated from fenics_plast/schema.py (SCHEMA) by `make keys` (fenics-plast keys > "
        "docs/SCENE_KEYS.md). Do not edit by hand; tests/test_problem.py checks it is up to date. -->",
        "",
        "Scene files are TOML data (nothing in them is executed). Units: **mm, N, MPa, s**, with three",
        "exceptions converted on reading, because they are the numbers people quote: densities in kg/m³,",
        "velocities in m/s and the times of explicit analyses in µs (tables and expressions of `t` in",
        "explicit analyses take µs too). Static analyses run over a pseudo-time `t` (the load factor):",
        "from 0 to the end of the last `[steps]`, or to 1.",
        "",
        "`<name>` in a header is a name you choose (`[tools.punch]`, `[contact.punch]`); groups and regions",
        "are the names of the mesh's Gmsh physical groups. A key that applies only to some variants of its",
        "table (\"applies to\") is an error elsewhere; an unknown key or name is an error, with the",
        "allowed ones listed.",
        "",
        "Geometry (`mesh.geometry`): 2-D scenes (axisymmetric, plane strain) give points and directions as",
        "[x, y] and name components x, y (r, z); 3-D scenes (`geometry = \"3d\"`, hexahedral meshes whose",
        "regions are physical volumes and boundaries physical surfaces) give [x, y, z] and name x, y, z.",
        "",
        "Any key can be overridden from the command line: `fenics-plast run SCENE.toml --set",
        "contact.punch.friction=0.15` (the value is parsed as a TOML value, else taken as a string, and",
        "validated like a file key); `fenics-plast study --vary` takes the same dotted keys.",
        "",
    ]
    for section, t in SCHEMA.items():
        _table(L, f"[{section}.<name>]" if t.collection else f"[{section}]", t)
    return "\n".join(L).rstrip() + "\n"


def write_keys_doc(path: str | Path = DOCS_PATH) -> Path:
    """Rewrite docs/SCENE_KEYS.md."""
    path = Path(path)
    path.write_text(keys_markdown(), encoding="utf-8")
    return path


if __name__ == "__main__":  # python -m fenics_plast.keys_doc -> rewrite docs/SCENE_KEYS.md
    print(write_keys_doc())
