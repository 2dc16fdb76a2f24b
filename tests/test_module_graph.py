"""The package's import graph: no circle, and no private name used across modules (issue 22).

Read from the sources (ast), without importing anything. A module imports another when it has
``import fenics_plast.x``, ``from fenics_plast.x import y`` or a relative form of either, at any
depth (function-level imports count: a circle through a lazy import is still a circle). A private
name is one with a leading underscore (not a dunder): another module may neither import it nor
read it as ``module._name``.
"""
from __future__ import annotations

import ast
from pathlib import Path

import fenics_plast

PACKAGE = Path(fenics_plast.__file__).parent


def module_files() -> dict[str, Path]:
    out = {}
    for f in sorted(PACKAGE.rglob("*.py")):
        parts = ("fenics_plast",) + f.relative_to(PACKAGE).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = f
    return out


MODULES = module_files()


def owner(dotted: str) -> str | None:
    """The package module that ``dotted`` (a module or a name in one) lives in."""
    while dotted and dotted not in MODULES:
        dotted = dotted.rpartition(".")[0]
    return dotted or None


def imports_of(name: str, path: Path):
    """(imported module, private names taken from it) for each import in a module."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    tree = ast.parse(path.read_text(), str(path))
    aliases = {}                                  # local name -> package module, for module._name reads
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if not target.startswith("fenics_plast"):
                continue
            for a in node.names:
                full = f"{target}.{a.name}"
                if full in MODULES:                # from package import module
                    found.append((full, []))
                    aliases[a.asname or a.name] = full
                else:
                    private = [a.name] if a.name.startswith("_") and not a.name.startswith("__") else []
                    found.append((owner(target), private))
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("fenics_plast"):
                    found.append((owner(a.name), []))
                    if a.asname:
                        aliases[a.asname] = owner(a.name)
    for node in ast.walk(tree):
        if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in aliases
                and node.attr.startswith("_") and not node.attr.startswith("__")):
            found.append((aliases[node.value.id], [node.attr]))
    return [(m, p) for m, p in found if m and m != name]


GRAPH = {name: imports_of(name, path) for name, path in MODULES.items()}


def test_no_private_name_is_used_across_modules():
    crossings = [f"{name} uses {target}.{p}" for name, found in GRAPH.items() for target, private in found
                 for p in private]
    assert not crossings, "\n".join(crossings)


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on_stack, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out


def test_the_cycle_finder_finds_a_cycle():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_circle():
    # a package's __init__ re-exporting its modules is not a circle with them: leave those edges out
    edges = {name: {m for m, _ in found if not (MODULES[name].name == "__init__.py" and m.startswith(name + "."))}
             for name, found in GRAPH.items()}
    assert cycles(edges) == []
