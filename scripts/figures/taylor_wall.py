"""Taylor bar against a rigid contact wall against the sliding support (demos/taylor_bar_wall.toml).

Runs three scenes at their full resolution (6 x 36 cells, 80 us):

* ``sliding``: demos/taylor_bar.toml, the wall as a sliding support (u_z = 0 on the impact face);
* ``wall_mu0``: demos/taylor_bar_wall.toml, penalty contact with a rigid plane, frictionless;
* ``wall_mu0.1``: the same with Coulomb friction mu = 0.1,

and draws docs/figures/taylor_wall.png from their CSV files (final_shape.csv, history.csv): the
final shapes overlaid, the foot enlarged (the face's outer edge lifts off the wall, the support
holds it), the radius history and the length over the last 40 us. Prints a Markdown table (radius, length, max eqps,
plastic dissipation, initial kinetic energy, energy balance error at the end and at worst, steps,
wall time); results go to results/taylor_wall/<run>/.

    .venv/bin/python scripts/figures/taylor_wall.py [--no-run] [--set key=value ...] [--figure PNG]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "results" / "taylor_wall"
FIGURE = ROOT / "docs" / "figures" / "taylor_wall.png"
#: run name -> (scene file, overrides, label, colour)
RUNS = {
    "sliding": ("demos/taylor_bar.toml", [], "sliding support (u_z = 0)", "k"),
    "wall_mu0": ("demos/taylor_bar_wall.toml", [], "contact wall, mu = 0", "C3"),
    "wall_mu0.1": ("demos/taylor_bar_wall.toml", ["contact.face.friction=0.1"], "contact wall, mu = 0.1", "C0"),
}


def run_one(name, extra, run=True):
    scene, sets, _, _ = RUNS[name]
    out = OUT / name
    if run:
        cmd = [str(ROOT / ".venv" / "bin" / "fenics-plast"), "run", str(ROOT / scene), "--out", str(out)]
        for s in sets + ["output.xdmf=false", *extra]:
            cmd += ["--set", s]
        print("==", " ".join(cmd), flush=True)
        p = subprocess.run(cmd, cwd=ROOT, env=dict(os.environ, FENICS_PLAST_PROGRESS="off"),
                           capture_output=True, text=True)
        if p.returncode != 0:
            print(p.stdout[-2000:] + p.stderr[-2000:])
            raise SystemExit(f"run {name} failed (exit {p.returncode})")
    summary = json.loads((out / "summary.json").read_text())
    hist = np.genfromtxt(out / "history.csv", delimiter=",", names=True)
    cells = np.loadtxt(out / "final_shape.csv", delimiter=",", skiprows=1, ndmin=2)
    return summary, hist, cells


def draw_cells(ax, cells, colour, label, lw):
    """The deformed cells (corners in cyclic order, columns x1, y1, ..., x4, y4) and their mirror."""
    xs = cells[:, [0, 2, 4, 6, 0]].T
    ys = cells[:, [1, 3, 5, 7, 1]].T
    ax.plot(xs, ys, color=colour, lw=lw)
    ax.plot(-xs, ys, color=colour, lw=lw)
    ax.plot([], [], color=colour, lw=1.5, label=label)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-run", action="store_true", help="redraw from results/taylor_wall/")
    ap.add_argument("--set", action="append", default=[], help="extra override for every run, key=value")
    ap.add_argument("--figure", type=Path, default=FIGURE, help="PNG to write")
    a = ap.parse_args(argv)
    OUT.mkdir(parents=True, exist_ok=True)
    runs = {name: run_one(name, a.set, run=not a.no_run) for name in RUNS}

    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11.0, 7.6)); FigureCanvasAgg(fig)
    gs = fig.add_gridspec(2, 3, width_ratios=[1.0, 1.25, 1.25])
    ax_shape = fig.add_subplot(gs[:, 0])
    ax_foot, ax_r = fig.add_subplot(gs[0, 1:]), fig.add_subplot(gs[1, 1])
    ax_l = fig.add_subplot(gs[1, 2])
    for name, (s, h, cells) in runs.items():
        _, _, label, colour = RUNS[name]
        draw_cells(ax_shape, cells, colour, label, 0.35)
        draw_cells(ax_foot, cells, colour, label, 0.6)
        ax_r.plot(h["time_us"], h["radius_mm"], color=colour, label=label)
        ax_l.plot(h["time_us"], h["length_mm"], color=colour, label=label)
    for ax in (ax_shape, ax_foot):
        ax.axhline(0.0, color="0.5", lw=2.0, zorder=0)
        ax.set_aspect("equal"); ax.set_xlabel("r [mm]"); ax.set_ylabel("z [mm]")
    ax_shape.set_xlim(-8.0, 8.0); ax_shape.set_ylim(-0.5, 22.5)
    ax_shape.set_title("Final shapes (80 us)", fontsize=10); ax_shape.legend(fontsize=7, loc="upper right")
    ax_foot.set_xlim(2.5, 7.6); ax_foot.set_ylim(-0.1, 2.0)
    ax_foot.set_title("The foot: the wall lets the outer edge lift off, the support holds it", fontsize=10)
    ax_r.set_ylabel("impact-face radius [mm]"); ax_l.set_ylabel("length [mm]")
    ax_l.set_xlim(40.0, 81.0); ax_l.set_ylim(21.0, 25.0)        # the last 40 us (all three coincide before)
    ax_l.set_title("length, from 40 us", fontsize=9)
    for ax in (ax_r, ax_l):
        ax.set_xlabel("time [us]"); ax.grid(True, alpha=0.3); ax.legend(fontsize=7)
    fig.suptitle("Copper Taylor bar, 227 m/s: rigid contact wall (penalty) against a sliding support")
    fig.tight_layout(); a.figure.parent.mkdir(parents=True, exist_ok=True); fig.savefig(a.figure, dpi=110)

    print("| run | radius [mm] | length [mm] | max eqps | plastic dissipation [J] | initial KE [J] | "
          "contact work [J] | energy error end / max | steps | wall [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name, (s, h, _) in runs.items():
        print(f"| {RUNS[name][2]} | {s['radius_mm']:.4f} | {s['length_mm']:.4f} | {s['max_eqps']:.3f} | "
              f"{s['plastic_dissipation_J']:.2f} | {h['kinetic_energy_J'][0]:.2f} | "
              f"{s.get('contact_work_J', 0.0):.2f} | "
              f"{100 * s['energy_balance_error']:.2f} % / {100 * s['max_energy_balance_error']:.2f} % | "
              f"{s['steps']} | {s['wall_time_s']:.1f} |")
    ref = runs["sliding"][0]
    for name in ("wall_mu0", "wall_mu0.1"):
        s = runs[name][0]
        print(f"{name} against the sliding support: radius {100 * (s['radius_mm'] / ref['radius_mm'] - 1):+.2f} %, "
              f"length {100 * (s['length_mm'] / ref['length_mm'] - 1):+.2f} %, plastic dissipation "
              f"{100 * (s['plastic_dissipation_J'] / ref['plastic_dissipation_J'] - 1):+.2f} %")
    print(f"figure {a.figure}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
