"""docs/figures/springback.png from a run of demos/springback.toml (its history.csv and
thickness_strain.csv).

Left: punch force against punch travel, loading to 40 mm and retraction, with an inset on the
elastic unloading branch (the blank follows the punch down until contact is lost). Right: the
thickness strain ln(t/t0) along the blank at 40 mm (t = 1) and after unloading (t = 2), and their
difference (the elastic recovery, right axis).

    .venv/bin/fenics-plast run demos/springback.toml          # -> results/springback/
    .venv/bin/python scripts/figures/springback.py [RUN_DIR] [--out docs/figures/springback.png]
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


def read(run: Path):
    h = np.genfromtxt(run / "history.csv", delimiter=",", names=True)
    th = np.genfromtxt(run / "thickness_strain.csv", delimiter=",", names=True)
    summary = json.loads((run / "summary.json").read_text())
    return h, th, summary


def at(h, t):
    return h[int(np.argmin(abs(h["time"] - t)))]


def draw(run: Path, out: Path):
    h, th, summary = read(run)
    loaded, end = at(h, 1.0), at(h, 2.0)
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11.0, 4.3), constrained_layout=True)

    up, down = h["time"] <= 1.0, h["time"] >= 1.0
    ax.plot(h["punch_displacement_mm"][up], h["punch_force_kN"][up], "-", color="C0", label="loading")
    ax.plot(h["punch_displacement_mm"][down], h["punch_force_kN"][down], ".-", color="C3", label="retraction")
    ax.set_xlabel("punch travel [mm]")
    ax.set_ylabel("punch force [kN]")
    ax.set_title("Punch force: loading to 40 mm and retraction")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left")
    ins = ax.inset_axes([0.10, 0.33, 0.33, 0.40])
    release = down & (h["punch_displacement_mm"] >= 38.5)
    ins.plot(h["punch_displacement_mm"][release], h["punch_force_kN"][release], ".-", color="C3")
    ins.axvline(end["dome_height_mm"], color="C2", lw=0.8, ls=":")
    ins.text(end["dome_height_mm"] - 0.03, 0.95 * loaded["punch_force_kN"], "dome height\nafter unloading",
             fontsize=7, color="C2", ha="right", va="top")
    ins.set_xlim(38.5, 40.1)
    ins.set_title(f"retraction: springback {loaded['dome_height_mm'] - end['dome_height_mm']:.3f} mm",
                  fontsize=8)
    ins.tick_params(labelsize=7)
    ins.grid(alpha=0.3)

    before, after = th[th["time"] == 1.0], th[th["time"] == 2.0]
    bx.plot(before["s0_mm"], before["value"], "-", color="C0", label="at 40 mm (t = 1)")
    bx.plot(after["s0_mm"], after["value"], "--", color="C3", label="after unloading (t = 2)")
    bx.set_xlabel("initial radius r0 [mm]")
    bx.set_ylabel("thickness strain ln(t/t0)")
    bx.set_title("Thickness strain before and after unloading")
    bx.grid(alpha=0.3)
    cx = bx.twinx()
    cx.plot(before["s0_mm"], 1e3 * (after["value"] - before["value"]), ":", color="0.35",
            label="difference x 1000 (right axis)")
    cx.set_ylabel("after - before  [x 1e-3]")
    lines = bx.get_lines() + cx.get_lines()
    bx.legend(lines, [ln.get_label() for ln in lines], loc="lower right", fontsize=8)
    fig.suptitle(f"Springback, hemispherical punch, mu = 0.15 ({summary['cells']} cells)", fontsize=10)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", nargs="?", default=str(ROOT / "results" / "springback"),
                    help="output folder of a demos/springback.toml run")
    ap.add_argument("--out", default=str(ROOT / "docs" / "figures" / "springback.png"))
    a = ap.parse_args(argv)
    print(draw(Path(a.run), Path(a.out)))


if __name__ == "__main__":
    main()
