"""Remeshing benchmark, billet upsetting (issue 35): demos/billet_upsetting.toml with remeshing and without.

    python benchmarks/bench_remesh_billet.py [--out results/bench_remesh_billet] [--reuse]

Four runs through the CLI, about 4 minutes in all on one core of the 2-core development machine:

* ``plain_20x30``, ``plain_40x60``: the demo without its ``[remeshing]`` table (a copy of the scene, its
  mesh file named by its absolute path, written into ``<out>``), on its 20 x 30 mesh and on 40 x 60;
* ``remeshed_0.5``, ``remeshed_0.25``: the demo as shipped (remeshing size 0.5 mm, 0.25 near corners) and
  at half the sizes.

Printed: per run the die force at 40 and 60 % height reduction (6 and 9 mm of die travel), remeshes and
time; each remeshed run's force against each plain run's up to 40 % (the largest relative difference,
where, and the mean), the two plain runs against each other (the discretisation's own spread), the
two remeshed sizes against each other at 60 %, and the largest force drop across a remesh. A
benchmark: it asserts nothing.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from bench_remesh_static import run_scene

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "demos" / "billet_upsetting.toml"
TRAVEL_40 = 6.0         # mm of die travel at 40 % height reduction (half height 15 mm)


def plain_scene(out: Path) -> Path:
    """A copy of the demo without its [remeshing] table, in ``out``."""
    text = SCENE.read_text()
    mesh = (SCENE.parent / "../docs/tutorial/billet.geo").resolve()
    assert 'file = "../docs/tutorial/billet.geo"' in text, "the demo's mesh file line has changed"
    text = text.replace('file = "../docs/tutorial/billet.geo"', f'file = "{mesh}"')
    start = text.index("\n[remeshing]")
    end = text.index("\n[", start + 1)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "billet_upsetting_plain.toml"
    path.write_text(text[:start] + text[end:])
    return path


def run(scene: Path, out: Path, reuse: bool, sets=()) -> tuple[dict, dict]:
    """(summary.json, history columns) of ``scene`` with ``sets`` in ``out``, without plots."""
    return run_scene(scene, out, reuse, ("output.plots=false", *sets))


def against(h: dict, ref: dict, upto: float) -> tuple[float, float, float]:
    """(largest relative force difference of ``h`` against ``ref`` from 0.3 mm up to ``upto`` mm of travel,
    the travel where it is [mm], the mean absolute difference)."""
    t = h["die_travel_mm"]
    on = (t >= 0.3) & (t <= min(upto, ref["die_travel_mm"][-1]))
    f_ref = np.interp(t[on], ref["die_travel_mm"], ref["die_force_kN"])
    d = (h["die_force_kN"][on] - f_ref) / f_ref
    k = int(np.argmax(np.abs(d)))
    return float(d[k]), float(t[on][k]), float(np.abs(d).mean())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "results" / "bench_remesh_billet"))
    ap.add_argument("--reuse", action="store_true")
    args = ap.parse_args(argv)
    out = Path(args.out)
    plain = plain_scene(out)
    runs = {
        "plain_20x30": run(plain, out / "plain_20x30", args.reuse),
        "plain_40x60": run(plain, out / "plain_40x60", args.reuse,
                           ("mesh.parameters.cells_radial=40", "mesh.parameters.cells_axial=60")),
        "remeshed_0.5": run(SCENE, out / "remeshed_0.5", args.reuse),
        "remeshed_0.25": run(SCENE, out / "remeshed_0.25", args.reuse,
                             ("remeshing.size=0.25", "remeshing.refine_size=0.125")),
    }
    for name, (s, h) in runs.items():
        at40 = np.interp(TRAVEL_40, h["die_travel_mm"], h["die_force_kN"])
        drops = [(b - a) / a for r in s.get("remesh_records", []) for k, (a, b) in r["jump"].items()
                 if k == "die_force" and a]
        print(f"{name}: die force {at40:.2f} kN at 40 %, {h['die_force_kN'][-1]:.2f} kN at "
              f"{h['die_travel_mm'][-1] / 0.15:.0f} %; {s.get('remeshes', 0)} remeshes, solve {s['solve_time_s']:.0f} s"
              + (f"; force change across a remesh {100 * min(drops):+.2f} % at most" if drops else ""))
    for name in ("remeshed_0.5", "remeshed_0.25", "plain_40x60"):
        for ref in ("plain_20x30", "plain_40x60"):
            if ref == name:
                continue
            d, where, mean = against(runs[name][1], runs[ref][1], TRAVEL_40)
            print(f"{name} against {ref} up to 40 %: largest {100 * d:+.2f} % (at {where:.2f} mm), mean {100 * mean:.2f} %")
    f05, f025 = (runs[n][1]["die_force_kN"][-1] for n in ("remeshed_0.5", "remeshed_0.25"))
    print(f"remeshed 0.5 against 0.25 mm at the end: {100 * (f05 - f025) / f025:+.2f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())
