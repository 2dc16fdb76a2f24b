"""Friction calibration chart of the 6:3:2 ring compression test (demos/ring_compression.toml).

Runs the scene at its full resolution for mu = 0, 0.05, 0.1, 0.2 (Coulomb friction on the die,
the same mu on the top face and on the free faces that fold over onto it) and draws the change of
the inner diameter (%) against the height reduction (%) -> docs/figures/ring_calibration.png, with

* the closed form of the frictionless ring (rigid-plastic, every radius times sqrt(h0/h));
* a slab estimate of the same rings (:func:`slab_curve`: thin-ring analysis with a neutral radius,
  no barrelling, in the manner of Hawkyard & Johnson 1967), dashed.

Male & Cockcroft's measured charts (1964-65) are compared in shape and trend only (the digitised
curves were not available to us), in docs/guide/results.md.

The height reduction is measured on the ring (its top face, behind the die by the penalty
penetration, 0.0016 mm), the inner diameter is the smallest one (extent "min" of the inner face).
The scene's outputs give radii and heights in mm; the percentages are computed here (the output
machinery has no "change relative to the start" quantity). Results and a table go to
results/ring_calibration/ (calibration.csv; a Markdown table is printed).

    .venv/bin/python scripts/figures/ring_calibration.py [--refine N] [--mu 0 0.05 ...]
                                                        [--no-run] [--set key=value ...]
"""
from __future__ import annotations

import argparse
import csv
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numba
import numpy as np

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "demos" / "ring_compression.toml"
OUT = ROOT / "results" / "ring_calibration"
FIGURE = ROOT / "docs" / "figures" / "ring_calibration.png"
PAIRS = ("die", "die_inner", "die_outer")
FRICTIONS = (0.0, 0.05, 0.1, 0.2)
RI, RO, H = 15.0, 30.0, 20.0           # the scene's ring [mm] (full height)


# ----------------------------------------------------------------------------------------------
# slab estimate: thin ring, uniform through the thickness, Coulomb friction capped at k = Y/sqrt(3)
#
# Radial velocity u = -(eps_z_dot / 2) (r - Rn^2 / r) (incompressible, u = 0 at the neutral radius
# Rn); with eps_z_dot = -1 and a = Rn^2 / r^2 the Levy-Mises stresses (yield stress Y = 1) are
#   sigma_r - sigma_theta = 2a / (3 q),  sigma_r - sigma_z = (3 + a) / (3 q),  q = sqrt(1 + a^2 / 3),
# the pressure p = -sigma_z, and radial equilibrium of a slab of height h with friction on both faces
#   d sigma_r / dr = -(sigma_r - sigma_theta) / r + s 2 tau / h,   tau = min(mu p, 1/sqrt(3)),
# s = +1 where the metal flows outwards (r > Rn), -1 inwards. sigma_r = 0 on both free faces fixes
# Rn; the rings then evolve by dr = (r - Rn^2 / r) d(eps) / 2, dh = -h d(eps).


@numba.njit(cache=True)
def _dsig(r, sig, rn, mu, h, side):
    a = rn * rn / (r * r)
    q = math.sqrt(1.0 + a * a / 3.0)
    p = (3.0 + a) / (3.0 * q) - sig
    tau = min(mu * max(p, 0.0), 1.0 / math.sqrt(3.0))
    return -2.0 * a / (3.0 * q) / r + side * 2.0 * tau / h


@numba.njit(cache=True)
def _sigma(r0, r1, rn, mu, h, side, steps):
    """sigma_r at r1 from sigma_r(r0) = 0 (RK4)."""
    dr = (r1 - r0) / steps
    s, r = 0.0, r0
    for _ in range(steps):
        k1 = _dsig(r, s, rn, mu, h, side)
        k2 = _dsig(r + dr / 2, s + dr / 2 * k1, rn, mu, h, side)
        k3 = _dsig(r + dr / 2, s + dr / 2 * k2, rn, mu, h, side)
        k4 = _dsig(r + dr, s + dr * k3, rn, mu, h, side)
        s += dr / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        r += dr
    return s


@numba.njit(cache=True)
def _mismatch(rn, ri, ro, mu, h, steps):
    if rn <= ri:
        return _sigma(ri, ro, rn, mu, h, 1.0, steps)
    return _sigma(ri, rn, rn, mu, h, -1.0, steps) - _sigma(ro, rn, rn, mu, h, 1.0, steps)


@numba.njit(cache=True)
def _neutral(ri, ro, mu, h, steps):
    """The neutral radius: the root of the stress mismatch in [0, ro] (bisection)."""
    if mu == 0.0:
        return 0.0
    lo, hi = 0.0, ro
    flo = _mismatch(lo, ri, ro, mu, h, steps)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        fm = _mismatch(mid, ri, ro, mu, h, steps)
        if (fm > 0.0) == (flo > 0.0):
            lo, flo = mid, fm
        else:
            hi = mid
    return 0.5 * (lo + hi)


@numba.njit(cache=True)
def _evolve(mu, ri, ro, h, final_ratio, n, steps):
    h0, ri0 = h, ri
    de = math.log(1.0 / final_ratio) / n
    out = np.zeros((n + 1, 2))
    for k in range(n):
        rn = _neutral(ri, ro, mu, h, steps)                     # midpoint rule in eps
        rim = ri + 0.25 * (ri - rn * rn / ri) * de
        rom = ro + 0.25 * (ro - rn * rn / ro) * de
        rn = _neutral(rim, rom, mu, h * math.exp(-0.5 * de), steps)
        ri += 0.5 * (rim - rn * rn / rim) * de
        ro += 0.5 * (rom - rn * rn / rom) * de
        h *= math.exp(-de)
        out[k + 1, 0] = 1.0 - h / h0
        out[k + 1, 1] = ri / ri0 - 1.0
    return out


def slab_curve(mu, ri=RI, ro=RO, h=H, final_ratio=0.5, n=200, steps=200):
    """(height reduction, inner diameter change), fractions, of the slab estimate, n steps of eps."""
    return _evolve(float(mu), ri, ro, h, final_ratio, n, steps)


# ----------------------------------------------------------------------------------------------
# FE runs


def run_one(mu, refine, extra, run=True):
    out = OUT / f"mu_{mu:g}"
    if run:
        cmd = [str(ROOT / ".venv" / "bin" / "fenics-plast"), "run", str(SCENE), "--out", str(out)]
        for s in [f"contact.{p}.friction={mu!r}" for p in PAIRS] + [f"mesh.refine={refine}", *extra]:
            cmd += ["--set", s]
        print("==", " ".join(cmd), flush=True)
        p = subprocess.run(cmd, cwd=ROOT, env=dict(os.environ, FENICS_PLAST_PROGRESS="off"),
                           capture_output=True, text=True)
        if p.returncode != 0:
            print(p.stdout[-2000:] + p.stderr[-2000:])
            raise SystemExit(f"run mu = {mu:g} failed (exit {p.returncode})")
    summary = json.loads((out / "summary.json").read_text())
    hist = np.genfromtxt(out / "history.csv", delimiter=",", names=True)
    return summary, hist


def curves(hist):
    """(height reduction, inner diameter change, outer diameter change), fractions."""
    red = 1.0 - hist["half_height_mm"] / hist["half_height_mm"][0]
    return red, hist["inner_radius_mm"] / hist["inner_radius_mm"][0] - 1.0, \
        hist["outer_radius_mm"] / hist["outer_radius_mm"][0] - 1.0


def at(x, y, x0):
    """y at x0, linear; extrapolated from the last two rows when the run ends just short of x0."""
    if x0 <= x[-1]:
        return float(np.interp(x0, x, y))
    return float(y[-1] + (y[-1] - y[-2]) / (x[-1] - x[-2]) * (x0 - x[-1]))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mu", type=float, nargs="+", default=list(FRICTIONS), help="friction coefficients")
    ap.add_argument("--refine", type=int, default=1, help="mesh.refine of the runs")
    ap.add_argument("--no-run", action="store_true", help="redraw from results/ring_calibration/")
    ap.add_argument("--set", action="append", default=[], help="extra scene override key=value")
    ap.add_argument("--figure", type=Path, default=FIGURE, help="PNG to write")
    a = ap.parse_args(argv)
    OUT.mkdir(parents=True, exist_ok=True)
    runs = {mu: run_one(mu, a.refine, a.set, run=not a.no_run) for mu in a.mu}
    slab = {mu: slab_curve(mu) for mu in a.mu}

    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.6, 4.8)); FigureCanvasAgg(fig); ax = fig.add_subplot()
    r = np.linspace(0.0, 0.5, 101)
    for k, (mu, (s, h)) in enumerate(runs.items()):
        red, di, _ = curves(h)
        ax.plot(100 * red, 100 * di, "-", color=f"C{k}", lw=2.0, label=f"FE, mu = {mu:g}")
        if mu > 0:                      # the slab estimate at mu = 0 is the closed form
            ax.plot(100 * slab[mu][:, 0], 100 * slab[mu][:, 1], "--", color=f"C{k}", lw=1.0)
    ax.plot(100 * r, 100 * (1.0 / np.sqrt(1.0 - r) - 1.0), ":", color="k", lw=1.5,
            label="closed form, mu = 0: sqrt(h0/h) - 1")
    ax.plot([], [], "--", color="0.3", lw=1.0, label="slab estimate (same colours)")
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.set_xlabel("height reduction [%]"); ax.set_ylabel("change of inner diameter [%]")
    ax.set_title("Ring compression 6:3:2, Coulomb friction at the dies"); ax.grid(True, alpha=0.3)
    ax.set_xlim(0, 52); ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout(); a.figure.parent.mkdir(parents=True, exist_ok=True); fig.savefig(a.figure, dpi=120)

    keys = ["mu", "reduction_final_pct", "inner_change_50_pct", "inner_mid_change_50_pct", "outer_change_50_pct",
            "slab_inner_change_50_pct", "die_force_final_kN", "max_eqps", "max_penetration_mm", "increments",
            "newton_iterations", "cutbacks", "wall_time_s", "cells"]
    rows = []
    for mu, (s, h) in runs.items():
        red, di, do = curves(h)
        mid = h["inner_radius_mid_mm"] / h["inner_radius_mid_mm"][0] - 1.0
        rows.append(dict(mu=mu, reduction_final_pct=100 * red[-1], inner_change_50_pct=100 * at(red, di, 0.5),
                         inner_mid_change_50_pct=100 * at(red, mid, 0.5), outer_change_50_pct=100 * at(red, do, 0.5),
                         slab_inner_change_50_pct=100 * slab[mu][-1, 1], die_force_final_kN=s["die_force_kN"],
                         max_eqps=s["max_eqps"], max_penetration_mm=s["max_penetration_mm"],
                         increments=s["increments"], newton_iterations=s["newton_iterations"],
                         cutbacks=s["cutbacks"], wall_time_s=s["wall_time_s"], cells=s["cells"]))
    with open(OUT / "calibration.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys); w.writeheader(); w.writerows(rows)
    print("| mu | inner diameter at 50 % (FE) | slab estimate | outer diameter | die force [kN] | wall [s] |")
    print("|---|---|---|---|---|---|")
    for row in rows:
        print(f"| {row['mu']:g} | {row['inner_change_50_pct']:+.1f} % | {row['slab_inner_change_50_pct']:+.1f} % | "
              f"{row['outer_change_50_pct']:+.1f} % | {-row['die_force_final_kN']:.0f} | {row['wall_time_s']:.0f} |")
    print(f"closed form (mu = 0, rigid-plastic): {100 * (math.sqrt(2.0) - 1.0):+.2f} % at 50 %")
    print(f"figure {a.figure}; table {OUT / 'calibration.csv'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
