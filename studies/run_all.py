"""Run the shipped parameter studies and refresh their pages in the docs.

    .venv/bin/python studies/run_all.py              # every study (about 15 min on 2 cores)
    .venv/bin/python studies/run_all.py taylor_dt    # only the named ones
    .venv/bin/python studies/run_all.py --list       # names and commands
    .venv/bin/python studies/run_all.py --docs-only  # re-render docs/STUDIES.md from docs/studies/

Each study is one ``fenics-plast study`` command (listed in :data:`STUDIES`, printed in the docs)
writing into results/studies/<name>/; its study.md, study.csv and study.png are copied to
docs/studies/<name>/ and docs/STUDIES.md is rendered from studies/STUDIES.md.in, where a line
``{{study:NAME}}`` stands for that study's table. ``--reuse`` passes ``--reuse`` to every study
(finished runs are not run again: resumes an interrupted set, keeps the old wall times).
"""
from __future__ import annotations

import argparse
import datetime
import os
import platform
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
OUT = Path("results") / "studies"
DOCS = Path("docs") / "studies"
TEMPLATE = Path("studies") / "STUDIES.md.in"
PAGE = Path("docs") / "STUDIES.md"

TAYLOR = "demos/taylor_bar.toml"
ACCURATE = "demos/taylor_bar_accurate.toml"
TAYLOR_3D = "demos/taylor_bar_3d.toml"
PUNCH = "demos/punch_stretching.toml"

#: name -> (scene file, study arguments). The order is the order they run in.
STUDIES: dict[str, tuple[str, list[str]]] = {
    "taylor_mesh": (TAYLOR, ["--vary", "mesh.refine=1,2,4"]),
    "taylor_dt": (TAYLOR, ["--vary", "analysis.dt_safety=0.3,0.5,0.8,1.0"]),
    "taylor_model": (TAYLOR, ["--vary", "materials.copper.model=isochoric,seed", "--vary", "mesh.refine=1,2"]),
    "taylor_velocity": (TAYLOR, ["--vary", "initial_velocity.bar.value=" + ",".join(
        f"[0.0,-{v:.1f}]" for v in (100, 150, 227, 300, 400)), "--vary", "analysis.mass_scaling_dt=0,0.005,0.02",
        "--set", "analysis.erosion_ratio=0.1"]),
    "taylor_graded": (ACCURATE, ["--vary", "mesh.parameters.axial_size_ratio=1,4,16", "--vary",
                                 "mesh.parameters.radial_size_ratio=1,4", "--vary", "analysis.stable_step=size,element"]),
    "taylor_accurate": (ACCURATE, ["--vary", "mesh.refine=1,2,4", "--vary", "analysis.dt_safety=0.8,1.0"]),
    "taylor_3d": (TAYLOR_3D, ["--set", "mesh.parameters.cells_axial=18", "--set", "mesh.parameters.axial_size_ratio=16",
                              "--set", "mesh.parameters.radial_size_ratio=4", "--vary", "mesh.refine=1,2"]),
    "punch_mesh": (PUNCH, ["--vary", "mesh.refine=1,2,3,4"]),
    "punch_increment": (PUNCH, ["--vary", "analysis.max_increment=0.05,0.025,0.0125,0.00625"]),
    "punch_penalty": (PUNCH, ["--vary", "contact.*.penalty=2070,20700,207000"]),
    "punch_friction_law": (PUNCH, ["--set", "contact.*.friction=0.15", "--vary", "contact.*.law=quasi-coulomb,coulomb"]),
    "punch_model": (PUNCH, ["--vary", "materials.aluminium.model=isochoric,seed"]),
}


def command(name: str) -> list[str]:
    scene, args = STUDIES[name]
    return ["fenics-plast", "study", scene, *args, "--out", str(OUT / name)]


def run(name: str, reuse: bool) -> int:
    cmd = command(name)
    print(f"== {name}: {' '.join(shlex.quote(c) for c in cmd)}", flush=True)
    argv = [sys.executable, "-m", "fenics_plast.cli", *cmd[1:]] + (["--reuse"] if reuse else [])
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    rc = subprocess.call(argv, cwd=REPO, env=env)
    src = REPO / OUT / name
    if (src / "study.md").is_file():
        dst = REPO / DOCS / name
        dst.mkdir(parents=True, exist_ok=True)
        for f in ("study.md", "study.csv", "study.png"):
            shutil.copy2(src / f, dst / f)
        print(f"   -> {DOCS / name}/", flush=True)
    return rc


def _embed(name: str) -> str:
    """The study's study.md without its title, headings one level down (under the page's own), image path from docs/."""
    path = REPO / DOCS / name / "study.md"
    if not path.is_file():
        return f"*(study `{name}` not run yet: `.venv/bin/python studies/run_all.py {name}`)*\n"
    lines = path.read_text(encoding="utf-8").splitlines()
    out = []
    for ln in lines[1:]:
        if ln.startswith("#"):
            ln = "#" + ln
        ln = ln.replace("](study.png)", f"](studies/{name}/study.png)")
        out.append(ln)
    return "\n".join(out).strip() + "\n"


def render_docs() -> Path:
    text = (REPO / TEMPLATE).read_text(encoding="utf-8")
    text = re.sub(r"^\{\{study:(\w+)\}\}$", lambda m: _embed(m.group(1)), text, flags=re.M)
    stamp = (f"<!-- Generated from {TEMPLATE} by studies/run_all.py on "
             f"{datetime.date.today().isoformat()} ({platform.node()}, {os.cpu_count()} cores): edit the "
             f"template, not this file. -->\n")
    (REPO / PAGE).write_text(stamp + text, encoding="utf-8")
    return PAGE


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("names", nargs="*", help=f"studies to run (default all: {', '.join(STUDIES)})")
    p.add_argument("--list", action="store_true", help="print the studies' commands and exit")
    p.add_argument("--reuse", action="store_true", help="pass --reuse to every study")
    p.add_argument("--docs-only", action="store_true", help="only re-render docs/STUDIES.md")
    a = p.parse_args(argv)
    unknown = [n for n in a.names if n not in STUDIES]
    if unknown:
        p.error(f"unknown studies {unknown}; known: {', '.join(STUDIES)}")
    if a.list:
        for n in STUDIES:
            print(f"{n}: {' '.join(shlex.quote(c) for c in command(n))}")
        return 0
    failed = []
    if not a.docs_only:
        for n in a.names or list(STUDIES):
            if run(n, a.reuse) != 0:
                failed.append(n)
    print(f"docs: {render_docs()}")
    if failed:
        print(f"studies with no successful run: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
