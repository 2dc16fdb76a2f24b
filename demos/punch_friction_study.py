"""Friction study of the hemispherical punch-stretching scene (seed figs. 4 and 5).

Runs demos/punch_stretching.toml through the CLI for mu = 0, 0.15, 0.3 on both contact pairs
(contact.punch.friction and contact.die.friction; Quasi-Coulomb, add --coulomb to also run
mu = 0.15 with the full Coulomb law) and overlays
* the three punch force - displacement curves  -> results/punch_friction_study/punch_force.png
* the three thickness-strain distributions (final state and 20 mm) -> thickness_strain.png
plus a table study.csv (one row per run). A run that stops early (mu = 0.3 may neck) is plotted
up to where it stopped.

    .venv/bin/python demos/punch_friction_study.py [--np 2] [--coulomb] [--set key=value ...]
"""
from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "results" / "punch_friction_study"
FRICTIONS = (0.0, 0.15, 0.3)
# mu = 0.3 necks in a ring just before 40 mm: run it further (the seed went to 58 mm) so that the
# force maximum is passed and reported; the others go to the scene's default travel (40 mm)
TRAVEL_MM = {0.3: 48.0}


def run_one(mu, law, nprocs, extra):
    out = OUT / f"mu_{mu:g}_{law}"
    fp = str(ROOT / ".venv" / "bin" / "fenics-plast")
    cmd = [fp, "run", str(ROOT / "demos" / "punch_stretching.toml"), "--out", str(out)]
    for pair in ("punch", "die"):
        cmd += ["--set", f"contact.{pair}.friction={mu}", "--set", f"contact.{pair}.law={law}"]
    if mu in TRAVEL_MM and not any(s.startswith(("tools.punch.path", "steps.")) for s in extra):
        # the punch path (t from 0 to 1) to the longer travel; the first step still ends at 20 mm
        travel = TRAVEL_MM[mu]
        cmd += ["--set", f"tools.punch.path.y=[0.0, {travel}]", "--set", f"steps.to_20mm.end={20.0 / travel}"]
    for s in extra:
        cmd += ["--set", s]
    if nprocs > 1:
        cmd = ["/usr/bin/mpirun", "--allow-run-as-root", "-n", str(nprocs)] + cmd
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    print("==", " ".join(cmd), flush=True)
    p = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    summary = json.loads((out / "summary.json").read_text())
    if p.returncode != 0:
        print(f"   run stopped (exit {p.returncode}): {summary.get('error', '')}", flush=True)
    hist = np.genfromtxt(out / "history.csv", delimiter=",", names=True)
    th = np.genfromtxt(out / "thickness_strain.csv", delimiter=",", names=True)
    return summary, hist, th


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--np", type=int, default=1, help="MPI ranks per run")
    ap.add_argument("--coulomb", action="store_true", help="also run mu = 0.15 with the Coulomb law")
    ap.add_argument("--set", action="append", default=[], help="extra scene override key=value")
    a = ap.parse_args(argv)
    OUT.mkdir(parents=True, exist_ok=True)
    runs = [(mu, "quasi-coulomb") for mu in FRICTIONS]
    if a.coulomb:
        runs.append((0.15, "coulomb"))
    res = {key: run_one(*key, a.np, a.set) for key in runs}
    for (mu, law), (s, h, th) in res.items():      # the run's settings and the travel at the force maximum
        s.update(friction=mu, contact_law=law,
                 punch_displacement_at_max_mm=float(h["punch_displacement_mm"][np.argmax(h["punch_force_kN"])]))

    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.4, 4.4)); FigureCanvasAgg(fig); ax = fig.add_subplot()
    for (mu, law), (s, h, th) in res.items():
        lab = f"mu = {mu:g}" + (" (Coulomb)" if law == "coulomb" else "")
        ax.plot(h["punch_displacement_mm"], h["punch_force_kN"], "--" if law == "coulomb" else "-", label=lab)
        ax.plot([s["punch_displacement_at_max_mm"]], [s["max_punch_force_kN"]], "k.")
    ax.set_xlabel("punch displacement [mm]"); ax.set_ylabel("punch force [kN]")
    ax.set_title("Hemispherical punch stretching: punch force"); ax.grid(True, alpha=0.3); ax.legend()
    fig.tight_layout(); fig.savefig(OUT / "punch_force.png", dpi=120)

    fig = Figure(figsize=(6.4, 4.4)); FigureCanvasAgg(fig); ax = fig.add_subplot()
    for k, ((mu, law), (s, h, th)) in enumerate(res.items()):
        color = f"C{k}"
        for tv in np.unique(th["time"]):          # profiles at the ends of the steps (pseudo-time t)
            sel = th["time"] == tv
            travel = np.interp(tv, h["time"], h["punch_displacement_mm"])
            ax.plot(th["s0_mm"][sel], th["value"][sel], "-" if tv == th["time"].max() else ":",
                    color=color, label=f"mu = {mu:g}{' (C)' if law == 'coulomb' else ''}, {travel:.3g} mm")
    ax.set_xlabel("initial radius r0 [mm]"); ax.set_ylabel("thickness strain ln(t/t0)")
    ax.set_title("Thickness strain along the blank"); ax.grid(True, alpha=0.3); ax.legend(fontsize=7)
    fig.tight_layout(); fig.savefig(OUT / "thickness_strain.png", dpi=120)

    keys = ["friction", "contact_law", "converged", "increments", "newton_iterations", "wall_time_s",
            "max_punch_force_kN", "punch_displacement_at_max_mm", "punch_displacement_mm",
            "max_penetration_mm", "max_eqps", "min_thickness_strain", "s0_of_min_thickness_strain_mm",
            "thickness_strain_at_start"]
    with open(OUT / "study.csv", "w", newline="") as f:
        w = csv.writer(f); w.writerow(keys)
        for (s, h, th) in res.values():
            w.writerow([s.get(k) for k in keys])
    for (s, h, th) in res.values():
        print(", ".join(f"{k} {s.get(k):.4g}" if isinstance(s.get(k), float) else f"{k} {s.get(k)}" for k in keys))
    print(f"plots and study.csv in {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
