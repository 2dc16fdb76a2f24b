"""Each default of a scene key is declared once: in the schema (fenics_plast/schema.py).

The guard reads the package's sources (``ast``, nothing is imported): a parameter of any function
or method named like a scene key that has a default (``law``, ``friction``, ``dt_safety``,
``rtol``, ``model``, ``element``, ...) may default to None (absent) or to the schema's own value,
written ``default("<section>.<key>")`` with the key of that name; any other default (a literal, a
module constant, an expression) is a second declaration and fails, and so does a literal in
``.get("<key>", ...)`` / ``getattr(x, "<key>", ...)`` or rebinding such a parameter from None to a
literal in the body. A parameter that only shares a key's name is listed in :data:`NOT_SCENE_KEYS`
with the reason. Then the public signatures are checked against the schema's values (the explicit
solver's friction law once defaulted to "coulomb" while the schema and the static solver said
"quasi-coulomb"), and the sets of choices the solvers and materials accept against the schema's.
"""
from __future__ import annotations

import ast
import inspect
from pathlib import Path

import pytest

from fenics_plast import schema
from fenics_plast.schema import OPTIONAL, REQUIRED, SCHEMA, choices, default, key

PACKAGE = Path(__file__).resolve().parent.parent / "fenics_plast"

#: (module path in the package, function, parameter): why a default there is not a scene key's
NOT_SCENE_KEYS = {
    ("checkpoint.py", "Checkpointer.__init__", "every"):
        "the checkpoint interval the runner has resolved (0: never save), not output.every (fields)",
    ("progress.py", "Progress.__init__", "unit"):
        "the unit shown on a progress bar, not outputs.<name>.unit (a force unit)",
    ("errors.py", "Arg.__init__", "unit"):
        "the solver's unit of an argument's value named in a message, not outputs.<name>.unit",
}


def _keys_with_defaults() -> dict[str, list[str]]:
    """{key name: [dotted paths]} of the schema keys that have a default (neither REQUIRED nor
    OPTIONAL; a default that depends on the analysis type counts)."""
    out: dict[str, list[str]] = {}

    def walk(table, prefix):
        for name, k in table.keys.items():
            if k.analysis_default is not None or (k.default is not REQUIRED and k.default is not OPTIONAL):
                out.setdefault(name, []).append(prefix + name)
        for sub, t in table.subtables.items():
            walk(t, f"{prefix}{sub}.")

    for section, table in SCHEMA.items():
        walk(table, f"{section}.*." if table.collection else f"{section}.")
    return out


KEYS = _keys_with_defaults()


def _is_schema_default(node, name: str) -> bool:
    """``default("<path>"...)`` (or ``schema.default(...)``) of a declared key whose name is ``name``."""
    if not isinstance(node, ast.Call) or not node.args or not isinstance(node.args[0], ast.Constant):
        return False
    f = node.func
    if not (isinstance(f, ast.Name) and f.id == "default" or isinstance(f, ast.Attribute) and f.attr == "default"):
        return False
    path = node.args[0].value
    try:
        key(path)
    except KeyError:
        return False
    return path.rsplit(".", 1)[-1] == name


def _allowed(node, name: str) -> bool:
    return node is None or (isinstance(node, ast.Constant) and node.value is None) or _is_schema_default(node, name)


def _yields_literal(node) -> bool:
    """Whether the expression can evaluate to a literal written in it (``x if x is not None else 0.8``,
    ``x or "coulomb"``, ``float(0.8)``); a literal used as a key (``d.get("scene")``) does not count."""
    if isinstance(node, ast.Constant):
        return node.value is not None
    if isinstance(node, ast.IfExp):
        return _yields_literal(node.body) or _yields_literal(node.orelse)
    if isinstance(node, ast.BoolOp):
        return any(map(_yields_literal, node.values))
    if isinstance(node, (ast.Tuple, ast.List)):
        return any(map(_yields_literal, node.elts))
    if isinstance(node, ast.UnaryOp):
        return _yields_literal(node.operand)
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ("float", "int", "str",
                                                                                          "bool", "tuple"):
        return any(map(_yields_literal, node.args))
    return False


class _Scan(ast.NodeVisitor):
    def __init__(self, module: str):
        self.module, self.scope, self.found = module, [], []

    def report(self, node, what):
        self.found.append(f"{self.module}:{node.lineno} {'.'.join(self.scope) or '<module>'}: {what}")

    def visit_ClassDef(self, node):
        self.scope.append(node.name)
        self.generic_visit(node)
        self.scope.pop()

    def visit_FunctionDef(self, node):
        self.scope.append(node.name)
        a = node.args
        pos = a.posonlyargs + a.args
        pairs = list(zip(pos[len(pos) - len(a.defaults):], a.defaults)) + list(zip(a.kwonlyargs, a.kw_defaults))
        optional = set()
        for arg, d in pairs:
            if d is None or arg.arg not in KEYS:
                continue
            if (self.module, ".".join(self.scope), arg.arg) in NOT_SCENE_KEYS:
                continue
            if not _allowed(d, arg.arg):
                path = KEYS[arg.arg][0]
                hint = ", analysis=..." if key(path).analysis_default is not None else ""
                self.report(node, f"{arg.arg}={ast.unparse(d)} (declared in the schema: "
                                  f"{', '.join(KEYS[arg.arg])}; write default(\"{path}\"{hint}))")
            elif isinstance(d, ast.Constant):
                optional.add(arg.arg)
        for stmt in ast.walk(node):         # `law = law or "coulomb"`, `if law is None: law = "coulomb"`
            if isinstance(stmt, ast.Assign) and _yields_literal(stmt.value):
                for t in stmt.targets:
                    if isinstance(t, ast.Name) and t.id in optional and not any(
                            _is_schema_default(n, t.id) for n in ast.walk(stmt.value)):
                        self.report(stmt, f"{t.id} = {ast.unparse(stmt.value)} (a default of its own)")
        self.generic_visit(node)
        self.scope.pop()

    visit_AsyncFunctionDef = visit_FunctionDef

    def visit_Call(self, node):
        f = node.func
        checked = None
        if isinstance(f, ast.Attribute) and f.attr == "get" and len(node.args) == 2:
            checked = node.args
        elif isinstance(f, ast.Name) and f.id == "getattr" and len(node.args) == 3:
            checked = node.args[1:]
        if checked and isinstance(checked[0], ast.Constant) and checked[0].value in KEYS \
                and not _allowed(checked[1], checked[0].value):
            self.report(node, f"{ast.unparse(node)} (declared in the schema: {', '.join(KEYS[checked[0].value])})")
        self.generic_visit(node)


def violations(sources: dict[str, str]) -> list[str]:
    """The second declarations of scene-key defaults in ``sources`` ({module path: source text})."""
    found = []
    for module, text in sorted(sources.items()):
        scan = _Scan(module)
        scan.visit(ast.parse(text))
        found += scan.found
    return found


def package_sources() -> dict[str, str]:
    return {p.relative_to(PACKAGE).as_posix(): p.read_text(encoding="utf-8")
            for p in sorted(PACKAGE.rglob("*.py")) if p.relative_to(PACKAGE).as_posix() != "schema.py"}


def test_no_module_declares_a_scene_key_default():
    found = violations(package_sources())
    assert not found, "defaults of scene keys outside fenics_plast/schema.py:\n" + "\n".join(found)


def test_the_guard_catches_second_declarations():
    """The drift this guard was written for, and the ways around a literal it still sees."""
    drift = '''
class ExplicitDynamics:
    def add_contact(self, tool, facet_tags, tag, penalty, friction=0.0, law="coulomb", name=None):
        pass
'''
    found = violations({"explicit.py": drift})
    assert len(found) == 2 and "law='coulomb'" in found[1] and 'default("contact.*.law")' in found[1]
    assert len(violations({"a.py": "DT = 0.8\ndef run(t, dt_safety=DT):\n    pass\n"})) == 1
    assert len(violations({"a.py": "def run(t, dt_safety=default('analysis.dt_floor')):\n    pass\n"})) == 1
    assert len(violations({"a.py": "def f(law=None):\n    if law is None:\n        law = 'coulomb'\n"})) == 1
    assert len(violations({"a.py": "def f(rtol=None):\n    rtol = rtol if rtol is not None else float(1e-9)\n"})) == 1
    assert len(violations({"a.py": "def f(spec):\n    return spec.get('friction', 0.0)\n"})) == 1
    clean = ("def f(t, dt_safety=default('analysis.dt_safety'), law=schema.default('contact.*.law'), "
             "penalty=None, tangential_penalty=None):\n    law = law.lower()\n    return spec.get('law')\n")
    assert violations({"a.py": clean}) == []


def test_collisions_listed_are_still_there():
    """Every entry of NOT_SCENE_KEYS names a parameter that exists (no stale exemption)."""
    sources = package_sources()
    for module, function, param in NOT_SCENE_KEYS:
        tree = ast.parse(sources[module])
        names = set()
        for cls in [n for n in tree.body if isinstance(n, ast.ClassDef)] + [tree]:
            for fn in cls.body:
                if isinstance(fn, ast.FunctionDef):
                    qual = fn.name if cls is tree else f"{cls.name}.{fn.name}"
                    names |= {(qual, a.arg) for a in fn.args.args + fn.args.kwonlyargs}
        assert (function, param) in names, (module, function, param)


def _signatures():
    """(callable, {parameter: scene key}) of the public constructors and methods that take scene keys."""
    from fenics_plast.contact import PenaltyContact
    from fenics_plast.kinematics import Kinematics
    from fenics_plast.material import Material
    from fenics_plast.meshing import mesh_from_file
    from fenics_plast.solvers.explicit import ExplicitDynamics
    from fenics_plast.solvers.static import StaticSolver
    from fenics_plast.tools import Profile, RevolvedProfile
    contact = {"friction": "contact.*.friction", "law": "contact.*.law"}
    return [
        (ExplicitDynamics.add_contact, contact),
        (PenaltyContact.__init__, contact),
        (PenaltyContact.add_pair, contact),
        (ExplicitDynamics.__init__, {"element": "mesh.element", "internal_force": "analysis.internal_force",
                                     "stable_step": "analysis.stable_step",
                                     "erosion_ratio": "analysis.erosion_ratio"}),
        (ExplicitDynamics.run, {"dt_safety": "analysis.dt_safety", "dt_floor": "analysis.dt_floor",
                                "mass_scaling_dt": "analysis.mass_scaling_dt",
                                "checkpoint_every": ("output.checkpoint_every", "explicit")}),
        (StaticSolver.__init__, {k: "analysis." + k for k in ("rtol", "atol", "max_iterations", "linesearch",
                                                              "linear_solver", "linear_rtol",
                                                              "linear_max_iterations")} | {"element": "mesh.element"}),
        (StaticSolver.run, {"increments": "analysis.increments", "min_increment": "analysis.min_increment",
                            "max_increment": "analysis.max_increment",
                            "checkpoint_every": ("output.checkpoint_every", "static")}),
        (Material.__init__, {"model": "materials.*.model"}),
        (Kinematics.__init__, {"geometry": "mesh.geometry"}),
        (mesh_from_file, {"refine": "mesh.refine"}),
        (Profile.__init__, {"body_side": "tools.*.body_side"}),
        (RevolvedProfile.__init__, {"body_side": "tools.*.body_side"}),
    ]


def test_public_signatures_default_to_the_schema():
    """A Python caller gets what a scene that omits the key gets (friction law, tolerances, ...)."""
    for fn, params in _signatures():
        sig = inspect.signature(fn)
        for name, path in params.items():
            path, analysis = path if isinstance(path, tuple) else (path, None)
            assert sig.parameters[name].default == default(path, analysis), f"{fn.__qualname__}({name})"


def test_contact_pairs_take_friction_and_law_from_their_maker():
    """The pair classes have no defaults of their own: PenaltyContact.add_pair and
    ExplicitDynamics.add_contact hold them."""
    from fenics_plast.contact import ContactPair
    from fenics_plast.solvers.explicit_contact import ExplicitContactPair
    for cls in (ContactPair, ExplicitContactPair):
        sig = inspect.signature(cls.__init__)
        for name in ("friction", "law"):
            assert sig.parameters[name].default is inspect.Parameter.empty, f"{cls.__name__}({name})"


def test_choices_are_the_schemas():
    from fenics_plast import contact, kinematics
    from fenics_plast.material import MODELS
    from fenics_plast.solvers.explicit import ExplicitDynamics
    assert contact.LAWS == choices("contact.*.law")
    assert set(MODELS) == set(choices("materials.*.model"))
    assert ExplicitDynamics.INTERNAL_FORCE_ROUTES == choices("analysis.internal_force")
    assert ExplicitDynamics.STABLE_STEPS == choices("analysis.stable_step")
    assert kinematics.GEOMETRIES is schema.GEOMETRIES


def test_penalty_factor_is_the_schemas():
    from fenics_plast import contact, tools
    assert tools.PENALTY_FACTOR is schema.PENALTY_FACTOR and contact.PENALTY_FACTOR is schema.PENALTY_FACTOR
    assert f"absent = {schema.PENALTY_FACTOR:g} E / h" in key("contact.*.penalty").doc


def test_scaled_keys_default_to_zero_or_nothing():
    """default() hands out the declared default unscaled, as validation fills it in: right only while
    every key read in other units (µs, m/s, kg/m³) defaults to 0 or has no default."""
    def walk(table):
        for k in table.keys.values():
            if k.scale != 1.0:
                assert k.default in (REQUIRED, OPTIONAL, 0, 0.0), k
        for t in table.subtables.values():
            walk(t)
    for t in SCHEMA.values():
        walk(t)


def test_default_and_choices_of_a_dotted_key():
    assert default("contact.*.law") == "quasi-coulomb" and default("contact.*.friction") == 0.0
    assert default("analysis.dt_safety") == 0.8 and default("materials.*.hardening.taylor_quinney") == 0.9
    assert default("contact.*.penalty") is None                          # OPTIONAL: absent
    assert default("outputs.*.summary") == ("final",)                    # as validation fills it in
    assert default("output.checkpoint_every", "static") == 10
    assert default("output.checkpoint_every", analysis="explicit") == 2000
    assert choices("contact.*.law") == ("coulomb", "quasi-coulomb")
    for bad in ("contact.law", "contact.punch.law", "analysis.nope", "materials.*.hardening", "nope.x"):
        with pytest.raises(KeyError, match="no scene key"):
            key(bad)
    with pytest.raises(KeyError, match="required"):
        default("analysis.type")
    with pytest.raises(KeyError, match="analysis type"):
        default("output.checkpoint_every")
    with pytest.raises(KeyError, match="no list of choices"):
        choices("analysis.rtol")


def test_solver_ranges_are_the_schemas():
    """dt_safety's range is declared once; NaN lies in no bounded range."""
    k = key("analysis.dt_safety")
    assert k.in_range(1.0) and k.in_range(0.5) and not k.in_range(0.0) and not k.in_range(1.5)
    assert not k.in_range(float("nan")) and not key("analysis.dt_floor").in_range(float("nan"))
    assert k.range_text("dt_safety") == "0 < dt_safety <= 1"
