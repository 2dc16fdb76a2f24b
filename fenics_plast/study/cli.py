"""The study's command line: ``fenics-plast study`` and ``python -m fenics_plast.study``.

* :func:`add_study_arguments`: the arguments (shared by both entry points);
* :func:`study_from_args`: run a study from parsed arguments, returning the exit status: 0 when
  at least one run succeeded, 1 when none did, 2 for bad arguments (nothing run);
* :func:`main`: ``python -m fenics_plast.study``.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .driver import run_study
from .plan import StudyError, parse_vary, study_command


def add_study_arguments(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """The ``study`` arguments (shared by ``fenics-plast study`` and ``python -m fenics_plast.study``)."""
    p.add_argument("scene", help="scene file (TOML)")
    p.add_argument("--vary", action="append", required=True, metavar="KEY=V1,V2,...",
                   help="a scene key and its values (repeatable: the study runs every combination), "
                        "e.g. --vary mesh.refine=1,2,4 --vary materials.steel.model=seed,isochoric")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="an override applied to every run (repeatable)")
    p.add_argument("--out", help="output directory (default results/study_<scene name>)")
    p.add_argument("--results", help="comma-separated summary.json keys to compare (default: the key "
                                     "results the runs declare, summary.json key_results)")
    p.add_argument("--np", type=int, default=1, help="MPI ranks per run (mpirun -n NP); default 1")
    p.add_argument("--timeout", type=float, help="wall-clock limit per run [s]; a run past it is a failed row")
    p.add_argument("--reuse", action="store_true",
                   help="reuse runs already in OUT/runs with the same overrides (resume a study)")
    p.add_argument("--keep-outputs", action="store_true",
                   help="keep each run's fields.xdmf and plots (off by default: output.xdmf=false, "
                        "output.plots=false)")
    p.add_argument("--overwrite", action="store_true",
                   help="let --out name the results folder of another scene's study or of a run (replaced); a "
                        "non-empty folder that is not a results folder is refused all the same")
    p.add_argument("--trust-mesh-script", action="store_true",
                   help="passed to every run: let the scene's Gmsh .geo run any command it contains (see "
                        "`fenics-plast run --help`)")
    return p


def study_from_args(args) -> int:
    """Run a study from parsed arguments; returns the exit status (0, 1 or 2)."""
    try:
        varies = [parse_vary(t) for t in args.vary]
        if args.out:
            out = args.out
        else:
            from ..problem import SceneError, load_problem
            try:
                name = load_problem(args.scene, args.set).name
            except SceneError as e:
                raise StudyError(str(e)) from None
            out = str(Path("results") / f"study_{name}")
        results = [s.strip() for s in args.results.split(",") if s.strip()] if args.results else None
        trust = getattr(args, "trust_mesh_script", False)
        cmd = study_command(args.scene, varies, args.set, out, args.np, args.results, trust_mesh_script=trust)
        study = run_study(args.scene, varies, out, args.set, results=results, np_ranks=args.np,
                          timeout=args.timeout, reuse=args.reuse, keep_outputs=args.keep_outputs, command=cmd,
                          trust_mesh_script=trust, overwrite=getattr(args, "overwrite", False))
    except StudyError as e:
        print(f"error: {e}", file=sys.stderr, flush=True)
        return 2
    return 0 if any(r.ok for r in study.runs) else 1


def main(argv: list[str] | None = None) -> int:
    """``python -m fenics_plast.study ...``: returns the exit status."""
    p = argparse.ArgumentParser(prog="python -m fenics_plast.study",
                                description="Run combinations of scene-key overrides and tabulate cost and error.")
    add_study_arguments(p)
    return study_from_args(p.parse_args(argv))
