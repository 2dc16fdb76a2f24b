"""Remeshing benchmark, a whole static run (issue 35): demos/backward_extrusion.toml at two remeshing
sizes, h and h/2.

    python benchmarks/bench_remesh_static.py [--out results/bench_remesh_static] [--reuse]
        [--sizes 0.5:0.2 0.25:0.1] [--figure docs/figures/backward_extrusion_force.png] [--set KEY=VALUE]

Each size ``size:refine_size`` [mm] is one run of the demo through the CLI (``--set remeshing.size=..
--set remeshing.refine_size=..``) into ``<out>/h<size>``; ``--reuse`` reads a run already there. Printed
per run: punch travel reached [mm], increments, remeshes, the final cell count, the run's solve time and
the share of it spent remeshing, split into outline and Gmsh (mesh), transfer, the solver's rebuild and
the re-equilibration, the re-equilibrations' Newton iterations (median, max), the volume change, its
elastic part and the rest (summary.json's ``volume_change*``), the largest force jump across a remesh.
Then each size's force-travel curve against the next size's (h against h/2), from 2 mm of travel on
(the largest relative difference, the coarser run's points against the finer run's curve), and the
figure. A benchmark: it asserts nothing. One run at h takes about 4 minutes on one core of the 2-core development machine.
"""
from __future__ import annotations

import argparse
import csv
import json
import statistics
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "demos" / "backward_extrusion.toml"


def run_scene(scene: Path, out: Path, reuse: bool, sets=()) -> tuple[dict, dict]:
    """(summary.json, history columns) of ``scene`` run through the CLI into ``out`` with the KEY=VALUE
    settings ``sets``; ``reuse``: read a run already there."""
    if not (reuse and (out / "summary.json").is_file()):
        cmd = [str(ROOT / ".venv" / "bin" / "fenics-plast"), "run", str(scene), "--out", str(out)]
        cmd += [a for kv in sets for a in ("--set", kv)]
        print(" ".join(cmd), flush=True)
        subprocess.run(cmd, check=False, stdout=subprocess.DEVNULL)
    summary = json.loads((out / "summary.json").read_text())
    with open(out / "history.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    history = {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}
    return summary, history


def run(out: Path, size: float, refine: float, reuse: bool, sets=()) -> tuple[dict, dict]:
    """:func:`run_scene` of the demo at ``size`` / ``refine`` [mm] in ``out`` (``sets``: further settings)."""
    return run_scene(SCENE, out, reuse, (f"remeshing.size={size}", f"remeshing.refine_size={refine}", *sets))


def report(name: str, s: dict, h: dict) -> None:
    recs = s.get("remesh_records", [])
    parts = {k: sum(r[k] for r in recs) for k in ("mesh_s", "transfer_s", "rebuild_s", "equilibrium_s")}
    total = s.get("solve_time_s", float("nan"))
    its = [r["equilibrium_iterations"] for r in recs if "equilibrium_iterations" in r] or [0]
    jumps = [abs(b - a) / abs(a) for r in recs for k, (a, b) in r["jump"].items() if k == "punch_force" and a]
    print(f"{name}: travel {h['punch_travel_mm'][-1]:.2f} mm, converged {s.get('converged')}, "
          f"{s.get('increments')} increments, {s.get('remeshes')} remeshes, {s.get('cells')} cells at the end")
    print(f"  solve {total:.1f} s, remeshing {s.get('remesh_time_s', 0.0):.1f} s "
          f"({100 * s.get('remesh_time_s', 0.0) / total:.1f} %): "
          + ", ".join(f"{k[:-2]} {v:.1f} s" for k, v in parts.items()))
    print(f"  re-equilibration: Newton iterations median {statistics.median(its):.0f}, max {max(its)}; "
          f"largest punch force jump {100 * max(jumps, default=0.0):.2f} %")
    print(f"  volume change {100 * s.get('volume_change', float('nan')):.3f} %, elastic "
          f"{100 * s.get('volume_change_elastic', float('nan')):.3f} %, unexplained "
          f"{100 * s.get('volume_change_unexplained', float('nan')):.3f} %")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "results" / "bench_remesh_static"))
    ap.add_argument("--sizes", nargs="+", default=["0.5:0.2", "0.25:0.1"])
    ap.add_argument("--reuse", action="store_true")
    ap.add_argument("--figure", default=None)
    ap.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE",
                    help="a setting for every run (e.g. analysis.max_increment=0.005)")
    args = ap.parse_args(argv)
    runs = []
    for spec in args.sizes:
        size, refine = (float(v) for v in spec.split(":"))
        s, h = run(Path(args.out) / f"h{size:g}", size, refine, args.reuse, args.sets)
        report(f"size {size:g} mm (refine {refine:g} mm)", s, h)
        runs.append((f"h = {size:g} mm, {refine:g} mm at corners", h))
    for (name, h), (finer_name, fine) in zip(runs[:-1], runs[1:]):      # each size against the next, h/2
        on = h["punch_travel_mm"] >= 2.0
        on &= h["punch_travel_mm"] <= fine["punch_travel_mm"][-1]
        f_fine = np.interp(h["punch_travel_mm"][on], fine["punch_travel_mm"], fine["punch_force_kN"])
        d = np.abs(h["punch_force_kN"][on] - f_fine) / np.abs(f_fine)
        print(f"{name} against {finer_name}, from 2 mm to {h['punch_travel_mm'][on][-1]:.2f} mm: largest "
              f"force difference {100 * d.max():.2f} % (at {h['punch_travel_mm'][on][np.argmax(d)]:.2f} mm), "
              f"mean {100 * d.mean():.2f} %")
    if args.figure:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(6, 4))
        for name, h in runs:
            ax.plot(h["punch_travel_mm"], h["punch_force_kN"], label=name)
        ax.set_xlabel("punch travel [mm]")
        ax.set_ylabel("punch force [kN]")
        ax.set_title("Backward extrusion, remeshed: punch force")
        ax.grid(alpha=0.3)
        ax.legend()
        fig.tight_layout()
        fig.savefig(args.figure, dpi=120)
        print(f"figure: {args.figure}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
