"""Meshed tools against analytic ones: the punch stretching scene (mu = 0) with its punch and die shoulder
as Gmsh curves (demos/punch_stretching_meshed.toml, meshes/punch_tools.geo) at 16 and 64 line elements per
quarter circle, against the analytic circles (demos/punch_stretching.toml) -> docs/figures/meshed_punch.png:
the punch force against the punch travel, and the meshed runs' difference from the analytic curve [%].
``--3d`` adds the 3-D quarter (demos/punch_stretching_3d_meshed.toml against demos/punch_stretching_3d.toml,
about a minute per run). Runs go to results/meshed_punch/.

    .venv/bin/python scripts/figures/meshed_punch.py [--3d] [--no-run]
"""
from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "results" / "meshed_punch"
FIGURE = ROOT / "docs" / "figures" / "meshed_punch.png"
NO_FILES = ["--set", "output.xdmf=false", "--set", "output.plots=false"]


def run(scene: Path, out: Path) -> None:
    cmd = [sys.executable, "-m", "fenics_plast.cli", "run", str(scene), "--out", str(out), "--overwrite", *NO_FILES]
    subprocess.run(cmd, check=True, cwd=ROOT)


def meshed_scene(segments: int) -> Path:
    """The 2-D meshed scene with ``segments`` line elements per quarter circle (files in OUT)."""
    OUT.mkdir(parents=True, exist_ok=True)
    geo = (ROOT / "meshes" / "punch_tools.geo").read_text().replace("segments = {64,", f"segments = {{{segments},")
    (OUT / f"punch_tools_{segments}.geo").write_text(geo)
    text = (ROOT / "demos" / "punch_stretching_meshed.toml").read_text()
    text = text.replace('"../meshes/circular_blank.geo"', f'"{ROOT / "meshes" / "circular_blank.geo"}"')
    text = text.replace("../meshes/punch_tools.geo", f"punch_tools_{segments}.geo")
    scene = OUT / f"meshed_{segments}.toml"
    scene.write_text(text)
    return scene


def curve(out: Path):
    h = np.genfromtxt(out / "history.csv", delimiter=",", names=True)
    return h["punch_displacement_mm"], h["punch_force_kN"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--3d", dest="three_d", action="store_true", help="also the 3-D quarter punch")
    ap.add_argument("--no-run", action="store_true", help="draw from the runs already in results/meshed_punch")
    a = ap.parse_args()
    cases = [("2-D analytic", ROOT / "demos" / "punch_stretching.toml", None),
             ("2-D meshed, 16 per quarter circle", None, 16), ("2-D meshed, 64 per quarter circle", None, 64)]
    if a.three_d:
        cases += [("3-D analytic", ROOT / "demos" / "punch_stretching_3d.toml", None),
                  ("3-D meshed, 2 mm triangles", ROOT / "demos" / "punch_stretching_3d_meshed.toml", None)]
    curves = {}
    for label, scene, segments in cases:
        out = OUT / label.replace(" ", "_").replace(",", "")
        if not a.no_run:
            run(scene if scene is not None else meshed_scene(segments), out)
        curves[label] = curve(out)
    from matplotlib.figure import Figure
    fig = Figure(figsize=(10.0, 4.2))
    ax, err = fig.subplots(1, 2)
    for label, (s, f) in curves.items():
        ax.plot(s, f, "--" if "analytic" in label else "-", label=label)
    ax.set_xlabel("punch travel [mm]")
    ax.set_ylabel("punch force [kN]")
    ax.set_title("Punch stretching, μ = 0: meshed and analytic tools", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    travel = np.linspace(5.0, 40.0, 141)
    for label, (s, f) in curves.items():
        if "meshed" in label:
            ref = curves[label[:3] + " analytic"]
            err.plot(travel, 100 * (np.interp(travel, s, f) / np.interp(travel, *ref) - 1), label=label)
    err.axhline(0.0, color="k", lw=0.8)
    err.set_xlabel("punch travel [mm]")
    err.set_ylabel("punch force, meshed against analytic [%]")
    err.set_title("Difference from the analytic tools' curve", fontsize=10)
    err.grid(True, alpha=0.3)
    err.legend(fontsize=8)
    fig.tight_layout()
    FIGURE.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(FIGURE, dpi=120)
    print(f"wrote {FIGURE}")
    for label, (s, f) in curves.items():
        print(f"{label:40s} " + "  ".join(f"{d:.0f} mm {np.interp(d, s, f):7.3f} kN" for d in (20, 30, 40)))


if __name__ == "__main__":
    main()
