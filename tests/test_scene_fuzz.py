"""Property-based fuzzing of the scene loader (issue 12): a broken scene file gives exit 2, never a traceback.

Random mutations of the shipped general-format scene files (demos/*.toml, demos/general/*.toml,
tests/scenes/*.toml; a file of the general format has an [analysis] table) are written back as TOML
text and read through :func:`fenics_plast.problem.load_problem`, the loader of ``fenics-plast run``:

* deleted keys, table entries and list elements, anywhere in the nesting;
* values of the wrong type (string, list, table, bool, int, float);
* out-of-range numbers (negative, zero, tiny, huge, beyond 64 bits) and nan / inf;
* unknown key, table and section names, names of other sections' keys, other keys' choices;
* expressions: random text, code (``__import__('os')``, attributes, lambdas, comprehensions),
  unknown names and functions, wrong arity, long and deeply nested expressions;
* tables ``{ t = [...], value = [...] }``, tool paths and hardening tables with non-increasing
  times, lengths that differ, empty or non-finite entries;
* text edits of the file itself (a line deleted, duplicated or inserted; the text truncated;
  arrays and inline tables nested thousands deep; numbers of thousands of digits) and ``--set``
  overrides;
* (issue 21) plot, output, material and scene names with path separators and dots.

Property: the loader returns a valid problem (its numbers finite, ``to_dict`` and
``active_physics`` work, as ``fenics-plast run`` uses them before meshing) or raises SceneError
whose message starts with the file name; any other exception is a bug. Validation only: the mesh
is read (and group names are checked against it) by the runner, not here.

The default suite runs 300 examples, derandomized (the same ones every run), plus the edge cases
of number literals the generated ones may miss; ``-m slow`` runs 6000 random ones and keeps failures
in .hypothesis/ to replay them. A few end-to-end checks run ``fenics-plast run`` on broken files:
exit 2, the file and key on stderr, nothing written.

Issue 21 adds what is checked on the mesh before anything is written: mesh parameters and
``mesh.refine`` made zero, negative, fractional, tiny or huge (cell counts far beyond any machine's
memory) on small scenes, read in-process through ``runner.read_mesh`` and ``runner.prepare`` (the
phase of ``fenics-plast run`` before its output folder exists): SceneError naming the file and a key,
or a set-up ready to run; and copies of a shipped ``.geo`` with a command that runs programs or
writes files inserted (SystemCall, Shell, Printf > file, Save, Include and Merge from outside...):
refused in-process, and through ``fenics-plast run`` end to end (exit 2 naming mesh.file, no
traceback, no file written anywhere, the command never run).
"""
from __future__ import annotations

import copy
import math
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
import tomli_w
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.database import DirectoryBasedExampleDatabase

from fenics_plast.expressions import FUNCTIONS
from fenics_plast.problem import SceneError, load_problem
from fenics_plast.schema import SCHEMA

ROOT = Path(__file__).resolve().parent.parent


def _general(path: Path) -> bool:
    """A scene file of the general format has an [analysis] table (the old kind files do not)."""
    return "analysis" in tomllib.loads(path.read_text(encoding="utf-8"))


SCENES = sorted(p for pattern in ("demos/*.toml", "demos/general/*.toml", "tests/scenes/*.toml")
                for p in ROOT.glob(pattern) if _general(p))
BASE = {p: tomllib.loads(p.read_text(encoding="utf-8")) for p in SCENES}

# Default suite: 300 examples in all, the same every run. Slow suite: ~20x, random, failures kept.
QUICK = settings(derandomize=True, database=None, deadline=None, print_blob=True,
                 suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
SLOW = settings(database=DirectoryBasedExampleDatabase(str(ROOT / ".hypothesis" / "examples")),
                deadline=None, print_blob=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


# ----------------------------------------------------------------------------------------------
# What a mutation may put in a scene

def _schema_names():
    names, choices = set(SCHEMA), set()
    for table in SCHEMA.values():
        for spec in (table, *table.subtables.values()):
            names |= set(spec.keys) | set(table.subtables)
            choices |= {c for k in spec.keys.values() for c in (k.choices or ())}
    return sorted(names), sorted(choices)


KNOWN_NAMES, KNOWN_CHOICES = _schema_names()
NAMES = st.one_of(st.sampled_from(KNOWN_NAMES + ["kind", "t", "x", "y", "value", "line", "arc"]),
                  st.text(max_size=12))
FLOATS = st.floats(allow_nan=True, allow_infinity=True)
BAD_NUMBERS = st.one_of(
    st.sampled_from([0, -1, 0.0, -0.0, -1.0, 1e-320, 1e308, -1e308, 2**63 - 1, -2**63, 2**63, -2**63 - 1,
                     10**30, 10**400, -10**400, math.nan, math.inf, -math.inf]),
    FLOATS, st.integers())
STRINGS = st.one_of(st.sampled_from(KNOWN_CHOICES + KNOWN_NAMES), st.text(max_size=20))
SCALARS = st.one_of(st.booleans(), st.integers(-3, 3), BAD_NUMBERS, STRINGS)
WRONG = st.one_of(SCALARS, st.lists(SCALARS, max_size=3), st.dictionaries(NAMES, SCALARS, max_size=3))

# Expressions: near-valid ones built from a grammar (whitelisted and refused pieces), known
# attacks, random text, and long or deeply nested ones.
_ATOMS = st.sampled_from(["x", "y", "z", "t", "pi", "e", "1", "2.5", "1e308", "1e999", "0x1f", "1_0", "q",
                          "True", "None", "'s'", "1j", "...", "__x__", "sin", "ｘ"])
_BINARY = ["+", "-", "*", "/", "**", "//", "%", "@", "<", "==", " and ", " or ", "|", "^", "<<"]
_CALLS = list(FUNCTIONS) + ["open", "eval", "exec", "getattr", "__import__", "print", "len"]


def _grow(inner):
    return st.one_of(
        st.tuples(inner, st.sampled_from(_BINARY), inner).map(lambda a: f"({a[0]}{a[1]}{a[2]})"),
        st.tuples(st.sampled_from(_CALLS), st.lists(inner, max_size=3)).map(lambda a: f"{a[0]}({', '.join(a[1])})"),
        st.tuples(st.sampled_from(["-", "+", "~", "not ", "lambda: ", "*", "await ", "yield "]), inner)
        .map("".join),
        st.tuples(inner, st.sampled_from([".real", ".__class__", "[0]", "(1)", " if t else 0", " for c in x"]))
        .map("".join),
        inner.map(lambda s: f"[{s}]"), inner.map(lambda s: f"{{{s}}}"), inner.map(lambda s: f"f'{{{s}}}'"),
        st.tuples(st.sampled_from(["min", "max", "atan2", "sin"]), inner).map(lambda a: f"{a[0]}({a[1]}, x={a[1]})"),
    )


ATTACKS = ["__import__('os').system('true')", "__import__('os')", "().__class__.__bases__[0].__subclasses__()",
           "x.__class__", "lambda: 0", "[c for c in 'ab']", "open('/etc/passwd').read()", "eval('1')",
           "exec('x=1')", "globals()", "__builtins__", "9**9**9", "1e999", "-1e999 + 1e999", "x if t else y",
           "x; y", "x\ny", "# comment", "", "   ", "\\", "\x00", "x\x00", "(x", "x)", "**x", "x := 1", "*x",
           "sin(x=1)", "sin(*x)", "max(x)", "abs(x, y)", "sin", "'a' * 10**9", "b'x'", "1 if 1 else 2",
           "x.real", "(lambda: __import__('os'))()", "𝑥 + 𝑦", "t\u2028+1"]
_ONE_ARG = [f for f, (n, *_) in FUNCTIONS.items() if n == 1]
_TWO_ARGS = [f for f, (n, *_) in FUNCTIONS.items() if n == 2]
VALID_EXPRESSIONS = st.recursive(
    st.sampled_from(["x", "y", "z", "t", "pi", "e", "0", "1", "2.5", "1e3"]),
    lambda inner: st.one_of(
        st.tuples(inner, st.sampled_from(["+", "-", "*", "/", "**"]), inner).map(lambda a: f"({a[0]} {a[1]} {a[2]})"),
        st.tuples(st.sampled_from(_ONE_ARG), inner).map(lambda a: f"{a[0]}({a[1]})"),
        st.tuples(st.sampled_from(_TWO_ARGS), inner, inner).map(lambda a: f"{a[0]}({a[1]}, {a[2]})"),
        inner.map(lambda s: f"-{s}")),
    max_leaves=8)
EXPRESSIONS = st.one_of(
    VALID_EXPRESSIONS,
    st.recursive(_ATOMS, _grow, max_leaves=12),
    st.sampled_from(ATTACKS),
    st.text(max_size=40),
    st.text(alphabet="xyzt+-*/() .0123456789esincoqrtp,", max_size=60),
    st.builds(lambda n, a, b, c: a * n + c + b * n, st.integers(1, 600),
              st.sampled_from(["(", "-", "sin(", "[", "x**", "x+", "abs(-"]), st.sampled_from([")", "", "]"]),
              st.sampled_from(["x", "1", ""])),
)
TIME_LISTS = st.one_of(st.lists(st.one_of(FLOATS, st.integers(-3, 3)), max_size=5),
                       st.lists(st.floats(-10, 10), min_size=1, max_size=5, unique=True).map(sorted))
TABLES = st.fixed_dictionaries({"t": TIME_LISTS, "value": TIME_LISTS})
VALID_VALUES = st.one_of(VALID_EXPRESSIONS, st.floats(-1e3, 1e3), st.integers(-5, 5), st.integers(1, 5).flatmap(
    lambda n: st.fixed_dictionaries({"t": st.lists(st.floats(0, 1), min_size=n, max_size=n, unique=True).map(sorted),
                                     "value": st.lists(st.floats(-10, 10), min_size=n, max_size=n)})))
VALUES = st.one_of(VALID_VALUES, st.lists(VALID_VALUES, min_size=1, max_size=2), EXPRESSIONS, BAD_NUMBERS, TABLES,
                   st.lists(st.one_of(EXPRESSIONS, BAD_NUMBERS, TABLES), max_size=3), WRONG)


# ----------------------------------------------------------------------------------------------
# Mutations: each edits the scene dict in place and says what it did


def _places(node, prefix=()):
    """Every entry of a nested dict/list, as a path of keys and indices."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    out = []
    for k, v in items:
        out.append(prefix + (k,))
        out += _places(v, prefix + (k,))
    return out


def _get(raw, place):
    for k in place:
        raw = raw[k]
    return raw


def _pick(draw, raw, want=lambda v: True):
    places = [p for p in _places(raw) if want(_get(raw, p))]
    return draw(st.sampled_from(places)) if places else None


def _text(place):
    return ".".join(map(str, place))


def delete(draw, raw):
    place = _pick(draw, raw)
    if place:
        del _get(raw, place[:-1])[place[-1]]
    return f"delete {_text(place or ())}"


def wrong_type(draw, raw):
    place = _pick(draw, raw)
    if place:
        _get(raw, place[:-1])[place[-1]] = value = draw(WRONG)
        return f"{_text(place)} = {value!r}"
    return "nothing"


def bad_number(draw, raw):
    place = (_pick(draw, raw, lambda v: isinstance(v, (int, float)) and not isinstance(v, bool))
             or _pick(draw, raw))
    if place:
        _get(raw, place[:-1])[place[-1]] = value = draw(BAD_NUMBERS)
        return f"{_text(place)} = {value!r}"
    return "nothing"


def other_string(draw, raw):
    """Unknown enum values and names: a string replaced by another key's choice or by random text."""
    place = _pick(draw, raw, lambda v: isinstance(v, str))
    if place:
        _get(raw, place[:-1])[place[-1]] = value = draw(STRINGS)
        return f"{_text(place)} = {value!r}"
    return "nothing"


def unknown_name(draw, raw):
    """A new key, table or section (a known name in the wrong place, or random text)."""
    tables = [()] + [p for p in _places(raw) if isinstance(_get(raw, p), dict)]
    place = draw(st.sampled_from(tables))
    name = draw(NAMES)
    _get(raw, place)[name] = value = draw(st.one_of(WRONG, st.dictionaries(NAMES, WRONG, max_size=4)))
    return f"{_text(place + (name,))} = {value!r}"


def expression(draw, raw):
    """An expression, a table or a list of them as a boundary value, an initial velocity, a tool path
    or any value that is already a number or a string."""
    where = draw(st.sampled_from(["boundary", "initial_velocity", "path", "anywhere"]))
    value = draw(VALUES)
    if where == "boundary":
        if not isinstance(raw.get("boundary"), dict):
            raw["boundary"] = {}
        name = draw(st.sampled_from(sorted(raw["boundary"]) + ["fuzz"]))
        b = raw["boundary"].setdefault(name, {})
        if isinstance(b, dict):
            b.update(group=b.get("group", "axis"), value=value,
                     type=draw(st.sampled_from(["displacement", "velocity", "traction", "pressure"])))
            if b["type"] != "pressure":
                b["components"] = draw(st.lists(st.sampled_from(["x", "y", "r", "z", "q"]), min_size=1, max_size=3))
            else:
                b.pop("components", None)
        return f"boundary.{name} = {b!r}"
    if where == "initial_velocity":
        raw["initial_velocity"] = {"fuzz": {"value": value}}
        return f"initial_velocity.fuzz.value = {value!r}"
    if where == "path":
        tools = raw.get("tools")
        if isinstance(tools, dict) and tools:
            name = draw(st.sampled_from(sorted(tools)))
            if isinstance(tools[name], dict):
                tools[name]["path"] = path = draw(st.one_of(
                    st.fixed_dictionaries({"t": TIME_LISTS}, optional={"x": VALUES, "y": VALUES}),
                    st.dictionaries(NAMES, VALUES, max_size=3)))
                return f"tools.{name}.path = {path!r}"
        return "nothing"
    place = _pick(draw, raw, lambda v: isinstance(v, (str, int, float)))
    if place:
        _get(raw, place[:-1])[place[-1]] = value
        return f"{_text(place)} = {value!r}"
    return "nothing"


def table(draw, raw):
    """Hardening tables and the lists of tool paths: non-increasing, mismatched, empty, non-finite."""
    mats = raw.get("materials")
    if draw(st.booleans()) and isinstance(mats, dict) and mats:
        name = draw(st.sampled_from(sorted(mats)))
        if isinstance(mats[name], dict):
            mats[name]["hardening"] = h = {"law": "table", "strain": draw(TIME_LISTS), "stress": draw(TIME_LISTS)}
            return f"materials.{name}.hardening = {h!r}"
    place = _pick(draw, raw, lambda v: isinstance(v, list))
    if place:
        lst = _get(raw, place)
        edit = draw(st.sampled_from(["reverse", "repeat", "drop", "clear", "append"]))
        if edit == "reverse":
            lst.reverse()
        elif edit == "repeat" and lst:
            lst.append(lst[-1])
        elif edit == "drop" and lst:
            lst.pop(draw(st.integers(0, len(lst) - 1)))
        elif edit == "clear":
            lst.clear()
        else:
            lst.append(draw(SCALARS))
        return f"{edit} {_text(place)}"
    return "nothing"


PATH_NAMES = st.one_of(
    st.sampled_from(["../../x", "..", ".", "a/b", "/tmp/x", "a\\b", "x/..", "../", "./x", "a/../../../etc/passwd",
                     "C:\\x", "..\\..\\x", "x\x00y", " x", "x/"]),
    st.builds(lambda a, sep, b: a + sep + b, st.text(max_size=6), st.sampled_from(["/", "\\", "/../", "../"]),
              st.text(max_size=6)))


def path_name(draw, raw):
    """Names that become file names (issue 21): scene.name, a plot's or an output's (or a material's,
    not a file name) renamed to one with path separators or dots."""
    name = draw(PATH_NAMES)
    where = draw(st.sampled_from(["scene", "plots", "outputs", "materials"]))
    if where == "scene":
        if isinstance(raw.get("scene"), dict):
            raw["scene"]["name"] = name
        return f"scene.name = {name!r}"
    section = raw.get(where)
    if isinstance(section, dict) and section:
        old = draw(st.sampled_from(sorted(section)))
        section[name] = section.pop(old)
        return f"{where}.{old} renamed {name!r}"
    raw[where] = {name: {}}
    return f"[{where}.{name!r}]"


MUTATIONS = [delete, wrong_type, bad_number, other_string, unknown_name, expression, table, path_name]


@st.composite
def mutated_scenes(draw):
    path = draw(st.sampled_from(SCENES))
    raw = copy.deepcopy(BASE[path])
    done = [draw(st.sampled_from(MUTATIONS))(draw, raw) for _ in range(draw(st.sampled_from([1, 1, 2, 3])))]
    return path, raw, done


NUMBER_LINE = re.compile(r"^(\s*[A-Za-z_][\w-]*\s*=\s*)[-+]?[0-9][0-9_.eE+-]*")


@st.composite
def edited_texts(draw):
    """Text edits the dict mutations cannot make: TOML syntax, duplicate keys, deep nesting."""
    path = draw(st.sampled_from(SCENES))
    lines = path.read_text(encoding="utf-8").splitlines()
    edit = draw(st.sampled_from(["delete line", "duplicate line", "insert line", "truncate", "nest", "number"]))
    i = draw(st.integers(0, len(lines) - 1))
    numbers = [j for j, line in enumerate(lines) if NUMBER_LINE.match(line)]
    if edit == "number" and numbers:      # long literals: beyond 64 bits, 4300 digits, float range
        j = draw(st.sampled_from(numbers))
        n = draw(st.one_of(st.sampled_from([19, 309, 4301, 6000]), st.integers(15, 6000)))
        number = draw(st.sampled_from(["1" + "0" * n, "-" + "9" * n, "0x" + "f" * n, "1" + "0" * n + ".5",
                                       f"1e{n}", f"-1e-{n}", "0o7" + "7" * n, "0b1" + "0" * n]))
        lines[j] = NUMBER_LINE.sub(lambda m: m.group(1) + number, lines[j])
        edit = f"line {j + 1}: {lines[j][:60]}..."
    elif edit == "delete line":
        del lines[i]
    elif edit == "duplicate line":
        lines.insert(i, lines[i])
    elif edit == "insert line":
        lines.insert(i, draw(st.one_of(st.text(max_size=40), st.sampled_from(
            ["[analysis]", "[[steps]]", "[materials]", "materials = 1", "a.b.c = 1", "[boundary.clamp]",
             "E = 1", "type = 'explicit'", "\ufeff", "x = \"\\uD800\""]))))
    elif edit == "truncate":
        text = "\n".join(lines)
        return path, text[:draw(st.integers(0, len(text)))], edit
    else:
        n = draw(st.integers(1, 3000))
        opener, closer = draw(st.sampled_from([("[", "]"), ("{a = ", "}"), ("[{a = ", "}]")]))
        lines.insert(i, f"{draw(st.sampled_from(KNOWN_NAMES))} = {opener * n}1{closer * n}")
        edit = f"nest {n} deep at line {i + 1}"
    return path, "\n".join(lines) + "\n", edit


@st.composite
def overrides(draw):
    """``--set`` options: dotted keys of the scene (or random ones) with random TOML values."""
    path = draw(st.sampled_from(SCENES))
    keys = [_text(p) for p in _places(BASE[path]) if all(isinstance(k, str) for k in p)]
    sets = []
    for _ in range(draw(st.integers(1, 3))):
        key = draw(st.one_of(st.sampled_from(keys), st.text(max_size=15)))
        value = draw(st.one_of(
            st.text(max_size=20), STRINGS.map(lambda s: f"'{s}'"), BAD_NUMBERS.map(str),
            st.builds(lambda n, o, c: o * n + c * n, st.integers(1, 3000), st.sampled_from(["[", "{a="]),
                      st.sampled_from(["]", "}", ""]))))
        sets.append(f"{key}={value}")
    return path, sets


# ----------------------------------------------------------------------------------------------
# The property


def _numbers(obj, where=""):
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _numbers(v, f"{where}.{k}")
    elif isinstance(obj, (list, tuple)):
        for i, v in enumerate(obj):
            yield from _numbers(v, f"{where}[{i}]")
    elif isinstance(obj, (int, float)) and not isinstance(obj, bool):
        yield where, obj


def _finite(x) -> bool:
    try:
        return math.isfinite(float(x))
    except OverflowError:
        return False


# A message names the file, then the key (dotted, from its section) or what is wrong with the file.
FILE_LEVEL = ("TOML syntax error", "the file nests too deeply", "an integer is too long", "--set")


def _leading_names(path: Path, sets) -> set[str]:
    """What a message about this file may start with: its sections (as read), the schema's, --set's."""
    try:
        names = set(tomllib.loads(path.read_text(encoding="utf-8")))
    except (ValueError, RecursionError):
        names = set()
    given = {s.split("=", 1)[0].split(".")[0].strip() for s in sets} - {""}
    return names | set(SCHEMA) | set(FILE_LEVEL) | given


def loads_or_refuses(path: Path, sets=(), what=""):
    """The property: a valid problem (finite numbers, usable by the CLI) or SceneError naming the
    file and then a key; any other exception fails the test (with the mutation in its message)."""
    try:
        problem = load_problem(path, sets)
    except SceneError as e:
        msg = str(e)
        assert msg.startswith(f"{path}: "), f"{what}: {msg!r}"
        body = msg[len(f"{path}: "):]
        assert any(body.startswith(n) for n in _leading_names(path, sets)), f"{what}: names no key: {msg!r}"
        return msg
    assert isinstance(problem.name, str), what
    assert isinstance(problem.active_physics, list) and isinstance(problem.mesh_file, Path), what
    bad = [f"{w} = {x!r}" for w, x in _numbers(problem.to_dict()) if not _finite(x)]
    assert not bad, f"{what}: a valid scene holds non-finite numbers: {bad}"
    return None


def write_and_check(path: Path, raw: dict, what: str, sets=()):
    text = tomli_w.dumps(raw)
    assert _same(tomllib.loads(text), raw), f"{what}: the TOML writer changed the scene"
    path.write_text(text, encoding="utf-8")
    return loads_or_refuses(path, sets, what)


def _same(a, b) -> bool:
    """Equal as TOML data (nan equals nan)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return type(a) is type(b) and a == b


@pytest.fixture(scope="module")
def scratch(tmp_path_factory):
    return tmp_path_factory.mktemp("fuzz")


def test_shipped_scenes_are_found_and_load(scratch):
    """The demos load (as written and as rewritten by the TOML writer); a test scene may be one that
    is refused on purpose, but cleanly."""
    assert any("demos" in p.relative_to(ROOT).parts for p in SCENES), SCENES
    for p in SCENES:
        demo = "demos" in p.relative_to(ROOT).parts
        for path in (p, scratch / p.name):
            if path != p:
                path.write_text(tomli_w.dumps(BASE[p]), encoding="utf-8")
            msg = loads_or_refuses(path, (), f"{p} unchanged")
            assert msg is None or not demo, msg


def _run_mutated(scratch, case):
    path, raw, done = case
    write_and_check(scratch / path.name, raw, f"{path.name}: " + "; ".join(done))


def _run_text(scratch, case):
    path, text, edit = case
    (scratch / path.name).write_text(text, encoding="utf-8")
    loads_or_refuses(scratch / path.name, (), f"{path.name}: {edit}")


def _run_overrides(scratch, case):
    path, sets = case
    target = scratch / path.name
    target.write_text(path.read_text(encoding="utf-8"), encoding="utf-8")
    loads_or_refuses(target, sets, f"{path.name} --set {sets}")


@settings(QUICK, max_examples=200)
@given(case=mutated_scenes())
def test_mutated_scenes_load_or_are_refused(scratch, case):
    _run_mutated(scratch, case)


@settings(QUICK, max_examples=60)
@given(case=edited_texts())
def test_edited_texts_load_or_are_refused(scratch, case):
    _run_text(scratch, case)


@settings(QUICK, max_examples=40)
@given(case=overrides())
def test_overrides_load_or_are_refused(scratch, case):
    _run_overrides(scratch, case)


@pytest.mark.parametrize("literal", ["9223372036854775808", "-9223372036854775809", "1" + "0" * 400,
                                     "1" + "0" * 4400, "0x" + "f" * 6000, "1e400", "-inf"],
                         ids=["2^63", "-2^63-1", "400 digits", "4400 digits", "hex 24000 bits", "1e400", "-inf"])
def test_out_of_range_literals_are_refused(scratch, literal):
    """The edges the generated cases may miss: 2^63, float range, Python's 4300-digit limit, hex."""
    path = next(p for p in SCENES if "demos" in p.relative_to(ROOT).parts)
    lines = path.read_text(encoding="utf-8").splitlines()
    j = next(j for j, line in enumerate(lines) if NUMBER_LINE.match(line))
    key = lines[j].split("=")[0].strip()
    lines[j] = NUMBER_LINE.sub(lambda m: m.group(1) + literal, lines[j])
    target = scratch / path.name
    target.write_text("\n".join(lines) + "\n", encoding="utf-8")
    msg = loads_or_refuses(target, (), f"{key} = {literal[:30]}")
    assert msg is not None and (key in msg or "too long" in msg), msg
    target.write_text(path.read_text(encoding="utf-8"), encoding="utf-8")
    sets = [f"mesh.parameters.fuzz={literal}"]
    msg = loads_or_refuses(target, sets, f"--set {sets[0][:40]}")
    assert msg is not None and "mesh.parameters.fuzz" in msg, msg


@pytest.mark.slow
@settings(SLOW, max_examples=4000)
@given(case=mutated_scenes())
def test_mutated_scenes_slow(scratch, case):
    _run_mutated(scratch, case)


@pytest.mark.slow
@settings(SLOW, max_examples=1000)
@given(case=edited_texts())
def test_edited_texts_slow(scratch, case):
    _run_text(scratch, case)


@pytest.mark.slow
@settings(SLOW, max_examples=1000)
@given(case=overrides())
def test_overrides_slow(scratch, case):
    _run_overrides(scratch, case)


# ----------------------------------------------------------------------------------------------
# End to end: `fenics-plast run` on broken files


PUNCH = next(p for p in SCENES if p.name == "punch_stretching.toml")


def _punch(**edits):
    raw = copy.deepcopy(tomllib.loads(PUNCH.read_text(encoding="utf-8")))
    raw["mesh"]["file"] = str(ROOT / "meshes" / "circular_blank.geo")
    for dotted, value in edits.items():
        *parents, last = dotted.split("__")
        d = _get(raw, parents)
        if value is None:
            del d[last]
        else:
            d[last] = value
    return raw


@pytest.mark.parametrize("edits, words", [
    ({"materials__aluminium__E": None}, ["materials.aluminium.E is missing"]),
    ({"materials__aluminium__nu": math.nan}, ["materials.aluminium.nu = nan", "not a finite number"]),
    ({"boundary__clamp__type": "displacement", "boundary__clamp__components": ["r"],
      "boundary__clamp__value": "__import__('os').system('touch PWNED')"},
     ["boundary.clamp.value", "only named functions can be called"]),
    ({"loads": {"x": 1}}, ["loads: unknown section [loads]"]),
])
def test_cli_run_refuses_broken_files(tmp_path, edits, words):
    scene = tmp_path / "punch_stretching.toml"
    scene.write_text(tomli_w.dumps(_punch(**edits)), encoding="utf-8")
    out = tmp_path / "out"
    p = subprocess.run([sys.executable, "-m", "fenics_plast.cli", "run", str(scene), "--out", str(out)],
                       capture_output=True, text=True, cwd=tmp_path,
                       env=dict(os.environ, FENICS_PLAST_PROGRESS="off"))
    assert p.returncode == 2, p.stderr
    assert p.stderr.startswith(f"error: {scene}: "), p.stderr
    for w in words:
        assert w in p.stderr, p.stderr
    assert "Traceback" not in p.stderr and not p.stdout
    assert not out.exists() and sorted(os.listdir(tmp_path)) == ["punch_stretching.toml"]


# ----------------------------------------------------------------------------------------------
# Issue 21: mesh parameters and mesh scripts, checked on the mesh before anything is written

MESH_SCENES = [ROOT / "tests" / "scenes" / n for n in ("bar.toml", "ring.toml", "bar_on_wall.toml",
                                                         "two_region_bar.toml")]
# counts: not integers >= 1, or far beyond any machine's memory (1e10 cells and up); refine likewise
COUNTS = st.sampled_from([0, -4, -1, 1, 2, 3, 2.5, 1e-3, 10 ** 10, 10 ** 12, 1e15, 2 ** 62, 1e300])
REFINES = st.sampled_from([0, -1, 1, 2, 10 ** 6, 2 ** 40, 2 ** 62])
LENGTHS = st.one_of(st.sampled_from([0, 0.0, -1, -6.413, 1e-300, 1e-12, 1e-3, 0.5, 2.5, 1e9, 1e12, 1e300,
                                     -1e300, 0.9, 1.5]), st.floats(-10, 10))


@st.composite
def mesh_mutations(draw):
    """--set options on mesh.parameters (cell counts and the other numbers) and mesh.refine."""
    path = draw(st.sampled_from(MESH_SCENES))
    params = sorted(BASE[path]["mesh"].get("parameters", {}))
    sets = []
    for _ in range(draw(st.integers(1, 3))):
        what = draw(st.sampled_from(["count", "other", "refine"]))
        if what == "refine" or not params:
            sets.append(f"mesh.refine={draw(REFINES)}")
            continue
        names = [n for n in params if n.startswith("cells")] if what == "count" else \
            [n for n in params if not n.startswith("cells")]
        if names:
            value = draw(COUNTS if what == "count" else LENGTHS)
            sets.append(f"mesh.parameters.{draw(st.sampled_from(names))}={value!r}")
    return path, sets


def checked_on_mesh(path: Path, sets, what: str):
    """The property of the phase before the output folder: SceneError naming the file and a key, or
    a set-up ready to run; any other exception (or a Gmsh crash, which ends the test process) is a bug."""
    from mpi4py import MPI

    from fenics_plast.runner import prepare, read_mesh
    msg = loads_or_refuses(path, sets, what)
    if msg is not None:
        return msg
    problem = load_problem(path, sets)
    try:
        built = prepare(problem, MPI.COMM_WORLD, read_mesh(problem, MPI.COMM_WORLD))
    except SceneError as e:
        msg = str(e)
        assert msg.startswith(f"{path}: "), f"{what}: {msg!r}"
        assert any(msg[len(f"{path}: "):].startswith(n) for n in _leading_names(path, sets)), f"{what}: {msg!r}"
        return msg
    assert built.solver is not None, what
    return None


@settings(QUICK, max_examples=40)
@given(case=mesh_mutations())
def test_mesh_parameters_refused_or_ready(case):
    path, sets = case
    checked_on_mesh(path, sets, f"{path.name} --set {sets}")


@pytest.mark.slow
@settings(SLOW, max_examples=400)
@given(case=mesh_mutations())
def test_mesh_parameters_slow(case):
    path, sets = case
    checked_on_mesh(path, sets, f"{path.name} --set {sets}")


# Commands that run programs or write files (each aimed at a marker file in the test's folder: were
# one to run, it would only create that file).
GEO_COMMANDS = [
    'SystemCall "touch {m}";', 'SystemCall/* x */"touch {m}";', 'SystemCall StrCat("touch ", "{m}");',
    'NonBlockingSystemCall "touch {m}";', 'System "touch {m}";', 'Shell "touch {m}";',
    'Printf("x") > "{m}";', 'Printf("%g", 1) >> "{m}";', 'Save "{m}.msh";', 'Print "{m}.png";',
    'OnelabRun("x", "touch {m}");', 'CreateDir "{m}.d";', 'Delete File "{m}";',
    'Include "/etc/hostname";', 'Include "../outside.geo";', 'Merge "{m}.py";', 'Plugin(Remove).Run;',
    'S2N["SystemCall"] "touch {m}";',
]
# Exit ends the process that reads the script (with status 0): tried through the CLI only, never in
# the test process itself
CLI_ONLY = ["Exit;"]
GEO_FILES = sorted((ROOT / "meshes").glob("*.geo"))


@st.composite
def mutated_geos(draw, commands=tuple(GEO_COMMANDS)):
    """A shipped .geo with one of ``commands`` inserted after a statement (a line ending in ;)."""
    geo = draw(st.sampled_from(GEO_FILES))
    lines = geo.read_text(encoding="utf-8").splitlines()
    after = [i + 1 for i, line in enumerate(lines) if line.rstrip().endswith(";")]
    at = draw(st.sampled_from([0] + after))
    command = draw(st.sampled_from(commands))
    spacing = draw(st.sampled_from(["", "  ", "\t", "\n"]))
    return geo, lines, at, spacing + command


def _scene_with_geo(folder: Path, geo: Path, lines, at, command) -> tuple[Path, Path]:
    """bar.toml in ``folder`` meshing a copy of ``geo`` with ``command`` inserted (marker: folder/PWNED).
    The scene keeps no mesh parameters (every .geo meshes with its own defaults)."""
    marker = folder / "PWNED"
    text = "\n".join(lines[:at] + [command.format(m=marker)] + lines[at:]) + "\n"
    (folder / "mesh.geo").write_text(text, encoding="utf-8")
    raw = copy.deepcopy(tomllib.loads((ROOT / "tests" / "scenes" / "bar.toml").read_text(encoding="utf-8")))
    raw["mesh"] = {"file": "mesh.geo", "geometry": "axisymmetric"}
    scene = folder / "scene.toml"
    scene.write_text(tomli_w.dumps(raw), encoding="utf-8")
    return scene, marker


@settings(QUICK, max_examples=60)
@given(case=mutated_geos())
def test_mesh_scripts_that_run_commands_are_refused(tmp_path_factory, case):
    """In-process (the phase before the output folder): SceneError naming mesh.file, the command not run."""
    from mpi4py import MPI

    from fenics_plast.runner import read_mesh
    folder = tmp_path_factory.mktemp("geo")
    scene, marker = _scene_with_geo(folder, *case)
    with pytest.raises(SceneError) as err:
        read_mesh(load_problem(scene), MPI.COMM_WORLD)
    assert str(err.value).startswith(f"{scene}: mesh.file: "), err.value
    assert "refused" in str(err.value) and "--trust-mesh-script" in str(err.value), err.value
    assert sorted(p.name for p in folder.iterdir()) == ["mesh.geo", "scene.toml"] and not marker.exists()


@settings(QUICK, max_examples=6)
@given(case=mutated_geos(commands=tuple(GEO_COMMANDS + CLI_ONLY)))
def test_mesh_scripts_refused_by_the_cli(tmp_path_factory, case):
    """End to end: ``fenics-plast run`` exits 2 naming mesh.file, no traceback, nothing written."""
    folder = tmp_path_factory.mktemp("geo_cli")
    scene, marker = _scene_with_geo(folder, *case)
    out = folder / "out"
    p = subprocess.run([sys.executable, "-m", "fenics_plast.cli", "run", str(scene), "--out", str(out)],
                       capture_output=True, text=True, cwd=folder, env=dict(os.environ, FENICS_PLAST_PROGRESS="off"),
                       timeout=300)
    assert p.returncode == 2, p.stdout + p.stderr
    assert p.stderr.startswith(f"error: {scene}: mesh.file: ") and "Traceback" not in p.stderr, p.stderr
    assert not out.exists() and not marker.exists()
    assert sorted(x.name for x in folder.iterdir()) == ["mesh.geo", "scene.toml"]


def test_exit_in_a_mesh_script_refused_by_the_cli(tmp_path):
    """Exit would end the run with status 0 and no message: refused like the others."""
    lines = (ROOT / "meshes" / "round_bar.geo").read_text(encoding="utf-8").splitlines()
    scene, marker = _scene_with_geo(tmp_path, GEO_FILES[0], lines, len(lines), "Exit;")
    p = subprocess.run([sys.executable, "-m", "fenics_plast.cli", "run", str(scene), "--out", str(tmp_path / "out")],
                       capture_output=True, text=True, cwd=tmp_path, env=dict(os.environ, FENICS_PLAST_PROGRESS="off"),
                       timeout=300)
    assert p.returncode == 2 and p.stderr.startswith(f"error: {scene}: mesh.file: ") and "Exit" in p.stderr, p.stderr
    assert sorted(x.name for x in tmp_path.iterdir()) == ["mesh.geo", "scene.toml"]


@pytest.mark.parametrize("name", ["../../x", "a/b", "..", "/tmp/fenics_plast_fuzz_x"])
@pytest.mark.parametrize("section", ["plots", "outputs", "scene"])
def test_cli_names_with_path_separators(tmp_path, section, name):
    """A plot, output or scene name that would put a file outside --out: exit 2 naming the key, no
    file written anywhere (the work folder is a sub-folder of tmp_path: ../../x would land in it)."""
    work = tmp_path / "a" / "b"
    work.mkdir(parents=True)
    raw = copy.deepcopy(tomllib.loads((ROOT / "tests" / "scenes" / "bar.toml").read_text(encoding="utf-8")))
    raw["mesh"]["file"] = str(ROOT / "meshes" / "round_bar.geo")
    if section == "scene":
        raw["scene"]["name"] = name
    elif section == "plots":
        raw["output"]["plots"] = True
        raw["plots"] = {name: {"x": "time", "y": ["force_kN"]}}
    else:
        raw["outputs"][name] = {"quantity": "thickness", "group": "outer", "opposite": "axis"}
    scene = work / "scene.toml"
    scene.write_text(tomli_w.dumps(raw), encoding="utf-8")
    out = work / "out"
    args = [sys.executable, "-m", "fenics_plast.cli", "run", str(scene)] + (["--out", str(out)] if section != "scene"
                                                                              else [])
    p = subprocess.run(args, capture_output=True, text=True, cwd=work, env=dict(os.environ, FENICS_PLAST_PROGRESS="off"),
                       timeout=300)
    assert p.returncode == 2, p.stdout + p.stderr
    key = "scene.name" if section == "scene" else f"{section}."
    assert p.stderr.startswith(f"error: {scene}: {key}") and "Traceback" not in p.stderr, p.stderr
    files = sorted(str(f.relative_to(tmp_path)) for f in tmp_path.rglob("*"))
    assert files == ["a", "a/b", "a/b/scene.toml"], files
    assert not Path("/tmp/fenics_plast_fuzz_x").exists()
