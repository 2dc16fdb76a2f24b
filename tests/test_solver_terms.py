"""The solvers speak of their own arguments; the driver words their messages in the scene's terms (issue 22).

(a) A scan of ``fenics_plast/solvers/`` (its sources read with ``ast``, nothing imported): no string
(message, docstring, f-string part) names a scene key (``analysis.``, ``contact.``, ``boundary.``,
``materials.``, ``mesh.``, ``tools.``, ``output.``, ``outputs.`` followed by a key) or the CLI's
``--set``. Comments are not strings, and the argument of a schema look-up (``default(...)``,
``choices(...)``, ``key(...)``: the defaults and ranges are the schema's, issue 22 item 5) is not a
message. (b) A solver's :class:`~fenics_plast.errors.Message` words its arguments as the solver's
and, through the driver's :data:`~fenics_plast.runner_explicit.SCENE_TERMS`, as the scene's keys
(``--set`` syntax, µs for times), and every argument a solver names has a scene word.
"""
from __future__ import annotations

import ast
import re
from pathlib import Path

from fenics_plast.errors import Arg, Message, RunError
from fenics_plast.runner_explicit import SCENE_TERMS, SceneTerms

SOLVERS = Path(__file__).resolve().parent.parent / "fenics_plast" / "solvers"

#: a dotted scene key (not an attribute or module path: no word or dot before it)
SCENE_KEY = re.compile(r"(?<![\w.])(analysis|contact|boundary|materials|mesh|tools|output|outputs)\.[A-Za-z_<*]")

#: the schema's look-ups, whose argument is a key, not a message
LOOKUPS = {"default", "choices", "key"}


def strings_of(tree):
    """(line, text) of every string constant of a module, outside the arguments of schema look-ups."""
    skip = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and getattr(node.func, "id", getattr(node.func, "attr", None)) in LOOKUPS:
            for a in node.args:
                skip.update(id(n) for n in ast.walk(a))
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in skip:
            yield node.lineno, node.value


def scene_words(path: Path) -> list[str]:
    tree = ast.parse(path.read_text(), str(path))
    found = []
    for line, text in strings_of(tree):
        for m in list(SCENE_KEY.finditer(text)) + list(re.finditer("--set", text)):
            at = line + text[:m.start()].count("\n")
            found.append(f"{path.name}:{at}: {m.group(0)!r} in {text[max(m.start() - 30, 0):m.end() + 30]!r}")
    return found


def test_solvers_name_no_scene_key():
    found = [f for p in sorted(SOLVERS.glob("*.py")) for f in scene_words(p)]
    assert found == [], "\n".join(found)


def test_the_scan_sees_scene_keys(tmp_path):
    """The scan finds a key in a message, a docstring and an f-string, and not in a comment, an
    attribute, a module path or a schema look-up."""
    src = tmp_path / "m.py"
    src.write_text('"""Set ``analysis.dt_floor``."""\n'
                   'x = default("analysis.dt_floor")  # analysis.dt_floor\n'
                   'y = mesh.topology, "fenics_plast.tools.Plane"\n'
                   'raise RunError(f"lower {v} or --set mesh.refine=2")\n')
    found = scene_words(src)
    assert len(found) == 3 and "m.py:1" in found[0] and "'--set'" in found[2], found


def test_messages_in_solver_and_scene_terms():
    m = Message("on (", Arg("mass_scaling_dt", 1e-7, "s", "value", ".4g"), "); e.g. ",
                Arg("mass_scaling_dt", 0.2 * 3.3e-8, "s", "set", digits=2), " (", Arg("mass_scaling_dt", unit="s",
                                                                                    form="unit"),
                "); ", Arg("stable_step", "element", form="set"), "; below ", Arg("dt_floor", 1e-3, form="value"),
                "; more ", Arg("steps"), " than 600")
    assert str(m) == ("on (mass_scaling_dt = 1e-07 s); e.g. mass_scaling_dt=6.6e-09 (s); stable_step=element; "
                      "below dt_floor = 0.001; more steps than 600")
    assert m.worded(SCENE_TERMS) == (
        "on (analysis.mass_scaling_dt = 0.1 us); e.g. --set analysis.mass_scaling_dt=0.0066 (us); --set "
        "analysis.stable_step=element; below analysis.dt_floor = 0.001; more analysis.time_steps than 600")
    e = RunError(m, results=dict(a=1))
    assert str(e) == str(m) and e.worded(SCENE_TERMS) == m.worded(SCENE_TERMS)
    assert e.reword(SCENE_TERMS) is e and str(e) == m.worded(SCENE_TERMS) and e.results == dict(a=1)
    assert RunError("plain").worded(SCENE_TERMS) == "plain"


def test_every_argument_named_has_a_scene_word():
    """Each Arg("...") in the solvers' sources is one the driver words (SceneTerms.KEYS)."""
    names = set()
    for p in SOLVERS.glob("*.py"):
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "Arg" and node.args:
                names.add(node.args[0].value)
    assert names and names <= set(SceneTerms.KEYS), names - set(SceneTerms.KEYS)
