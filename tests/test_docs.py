"""The user guide (docs/) and the README hold only what the package does (issue 39).

* Every scene snippet of the guide is included from a shipped file (a MyST ``literalinclude``), never
  written out in a code fence: the file is a shipped scene (`make demo` runs every demos/*.toml,
  tests/test_tutorial.py the tutorial's), validated here as `run` validates it; each include's start
  and end markers match one line of the file only, and the part between them is TOML on its own (so a
  snippet cannot drift from a scene that works, show another part of it, or cut a table in two).
* Every ``fenics-plast`` command the guide and the README show parses with the command line's own parser,
  and its scene, with its ``--set`` overrides (and each value of a study's ``--vary``), passes the
  validation ``run`` does before it writes anything.
* Every kind a scene can name (quantity, hardening law, tool shape, boundary and thermal-boundary type,
  contact law) is named on its page of the guide, read from the schema, so a new kind without a word
  in the guide fails here.
* The README stays under 200 lines and its links lead to files that exist.
* The guide builds with Sphinx, warnings as errors (``make docs`` is the same build), where Sphinx and
  MyST are installed (scripts/install.sh installs them).
"""
from __future__ import annotations

import importlib.util
import re
import shlex
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from fenics_plast import cli, schema
from fenics_plast.problem import load_problem
from fenics_plast.study.plan import parse_vary

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
README = ROOT / "README.md"
#: the guide's pages: the Markdown files Sphinx reads (docs/conf.py excludes the studies' own pages)
PAGES = sorted(DOCS.glob("*.md")) + sorted((DOCS / "guide").glob("*.md"))
#: fence languages a page may write out itself (a scene or a mesh script is included, not written)
WRITTEN_FENCES = {"bash", "text", "python"}
FENCE = re.compile(r"^```([^\n]*)\n(.*?)^```", re.S | re.M)
#: how a command line of the guide starts the program (in the clone, or installed)
PROGRAM = ("fenics-plast", ".venv/bin/fenics-plast")
#: the README's line limit (issue 39: read in five minutes)
README_LINES = 200


def fences(path: Path):
    """(info string, body) of each fenced block of a Markdown file."""
    return [(m.group(1).strip(), m.group(2)) for m in FENCE.finditer(path.read_text(encoding="utf-8"))]


def literal_includes():
    """(page, included file, options) of every ``literalinclude`` of the guide."""
    out = []
    for page in PAGES:
        for info, body in fences(page):
            if info.startswith("{literalinclude}"):
                target = (page.parent / info.split(None, 1)[1].strip()).resolve()
                options = dict(re.findall(r"^:([\w-]+):\s*(.*?)\s*$", body, flags=re.M))
                out.append((page, target, options))
    return out


def included_text(target: Path, options: dict) -> str:
    """The part of ``target`` a literalinclude shows (Sphinx's start-after / end-before, each of which must
    match one line of the file only)."""
    text = target.read_text(encoding="utf-8")
    for option in ("start-after", "end-before"):
        if option in options:                        # Sphinx takes the first match: there must be one only
            assert text.count(options[option]) == 1, f"{target}: the {option} marker {options[option]!r} is " \
                                                     f"on {text.count(options[option])} lines, not one"
    if "start-after" in options:
        marker = options["start-after"]
        text = text.split(marker, 1)[1].split("\n", 1)[1]
    if "end-before" in options:
        marker = options["end-before"]
        assert marker in text, f"{target}: the end marker {marker!r} comes before the start marker"
        text = text[:text.index(marker)].rsplit("\n", 1)[0]
    return text


def test_the_guide_writes_out_no_scene_or_mesh_script():
    """A scene snippet is a literalinclude of a shipped file, never a ```toml fence of the page's own."""
    for page in PAGES:
        for info, _ in fences(page):
            if info.startswith("{"):
                continue
            assert info in WRITTEN_FENCES, (f"{page.relative_to(ROOT)}: a ```{info or '(plain)'} block: include "
                                            "the scene or mesh from a shipped file ({literalinclude})")


def test_every_included_snippet_is_part_of_a_scene_that_validates():
    includes = literal_includes()
    assert len(includes) >= 8, "the tutorial's four and the topic pages' snippets"
    scenes = set()
    for page, target, options in includes:
        assert target.is_file(), f"{page.relative_to(ROOT)}: includes {target}, which does not exist"
        part = included_text(target, options)
        assert part.strip(), f"{page.relative_to(ROOT)}: the included part of {target.name} is empty"
        if options.get("language") == "toml":
            tomllib.loads(part)                      # whole tables: the markers cut no table or value in two
            scenes.add(target)
    for scene in scenes:
        load_problem(scene)                          # what `run` checks before it writes anything
    assert DOCS / "tutorial" / "billet.toml" in scenes


def commands(path: Path):
    """Every ``fenics-plast`` command line of the bash blocks of a page, as argument lists (without the
    program, an ``mpirun -n N`` prefix or a trailing comment); lines with placeholders (SCENE, DIR) left out."""
    out = []
    for info, body in fences(path):
        if info != "bash":
            continue
        for line in body.splitlines():
            line = line.split(" #", 1)[0].strip()
            words = shlex.split(line) if "fenics-plast" in line else []
            if not words or re.search(r"\b[A-Z]{3,}\b", line):
                continue
            if words[0] == "mpirun":                 # mpirun -n N [--allow-run-as-root] PROGRAM ...
                words = words[next(k for k, w in enumerate(words) if w.endswith("fenics-plast")):]
            if words[0] in PROGRAM:
                out.append(words[1:])
    return out


def test_every_command_shown_parses_and_its_scene_validates():
    shown = [(page, c) for page in PAGES + [README] for c in commands(page)]
    assert len(shown) >= 6
    parser = cli.build_parser()
    for page, argv in shown:
        args = parser.parse_args(argv)               # SystemExit on an option the command does not know
        scene = getattr(args, "scene", None)
        if scene is not None:
            assert (ROOT / scene).is_file(), f"{page.name}: `fenics-plast {' '.join(argv)}`: no {scene}"
            load_problem(ROOT / scene, overrides=args.set or ())
            for vary in map(parse_vary, getattr(args, "vary", None) or ()):   # each value a study would run
                for value in vary.values:
                    load_problem(ROOT / scene, overrides=[*(args.set or ()), f"{vary.key}={value}"])


def test_every_kind_a_scene_names_is_in_the_guide():
    guide = DOCS / "guide"
    named_on = {"outputs.*.quantity": "outputs.md", "materials.*.hardening.law": "materials.md",
                "tools.*.shape": "tools-contact.md", "contact.*.law": "tools-contact.md",
                "boundary.*.type": "boundary-conditions.md", "thermal_boundary.*.type": "thermal.md",
                "mesh.geometry": "meshes.md", "plots.*.type": "outputs.md"}
    for key, page in named_on.items():
        text = (guide / page).read_text(encoding="utf-8")
        missing = [c for c in schema.choices(key) if f"`{c}`" not in text and f'"{c}"' not in text]
        assert not missing, f"docs/guide/{page} does not name the {key} kinds {missing}"


def test_the_readme_is_short_and_its_links_lead_somewhere():
    text = README.read_text(encoding="utf-8")
    assert len(text.splitlines()) < README_LINES
    links = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text)
    assert len(links) >= 20
    for link in links:
        assert (ROOT / link).exists(), f"README links to {link}, which does not exist"


@pytest.mark.skipif(importlib.util.find_spec("sphinx") is None or importlib.util.find_spec("myst_parser") is None,
                    reason="Sphinx and MyST (python3-sphinx, python3-myst-parser) not installed")
def test_the_guide_builds_with_warnings_as_errors(tmp_path):
    p = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-E", "-q", "-b", "html",
                        str(DOCS), str(tmp_path / "html")], capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    index = (tmp_path / "html" / "index.html").read_text(encoding="utf-8")
    for page in ("guide/tutorial.html", "SCENE_KEYS.html", "guide/api.html"):
        assert page in index
