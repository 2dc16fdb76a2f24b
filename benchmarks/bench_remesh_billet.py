"""Remeshing benchmark, billet upsetting (issue 35): demos/billet_upsetting.toml with remeshing and without,
at three mesh sizes.

    python benchmarks/bench_remesh_billet.py [--out results/bench_remesh_billet] [--reuse] [--levels 0.5 0.25]

Per level h (mm) two runs through the CLI, from the same structured mesh of (10 / h) x (15 / h) cells:

* ``plain_<h>``: the demo without its ``[remeshing]`` table (a copy of the scene, its mesh file named by its
  absolute path, written into ``<out>``);
* ``remeshed_<h>``: the demo with ``remeshing.size = h`` and ``remeshing.refine_size = h / 2``.

Levels 0.5 (the demo as shipped), 0.25 and 0.125 mm; one run each on one core of the 2-core development
machine: about 1, 3 and 13 minutes.

Printed: per run the die force at 40 and 60 % height reduction (6 and 9 mm of die travel), remeshes, solve
time and the force change across each run's first remesh (its re-equilibration at fixed die position);
per level the remeshed run against the plain one up to 40 % (the largest relative difference, where, the
mean); each plain run against the finest plain run (the discretisation's own spread: the nodes of the side
folding onto the die one by one); each remeshed level against the next finer one at 60 %. A benchmark:
it asserts nothing.
"""
from __future__ import annotations

import argparse
import sys
import tomllib
from pathlib import Path

import numpy as np

from bench_remesh_static import run_scene

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "demos" / "billet_upsetting.toml"
_BILLET = tomllib.loads(SCENE.read_text())["mesh"]["parameters"]
RADIUS, HALF_HEIGHT = _BILLET["radius"], _BILLET["height"] / 2    # mm: the demo's billet (its upper half)
TRAVEL_40 = 0.4 * HALF_HEIGHT        # mm of die travel at 40 % height reduction
LEVELS = (0.5, 0.25, 0.125)          # mm: cell size of the structured mesh and of the new meshes


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


def cells(h: float) -> tuple[str, str]:
    """The settings of the structured (RADIUS / h) x (HALF_HEIGHT / h) mesh: (10 / h) x (15 / h)."""
    return (f"mesh.parameters.cells_radial={round(RADIUS / h)}",
            f"mesh.parameters.cells_axial={round(HALF_HEIGHT / h)}")


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
    ap.add_argument("--levels", type=float, nargs="+", default=list(LEVELS), help="cell sizes [mm]")
    args = ap.parse_args(argv)
    out = Path(args.out)
    plain = plain_scene(out)
    levels = sorted(args.levels, reverse=True)
    runs = {}
    for h in levels:
        quiet = ("output.plots=false",)
        runs[f"plain_{h:g}"] = run_scene(plain, out / f"plain_{h:g}", args.reuse, (*quiet, *cells(h)))
        remeshing = (f"remeshing.size={h:g}", f"remeshing.refine_size={h / 2:g}")
        runs[f"remeshed_{h:g}"] = run_scene(SCENE, out / f"remeshed_{h:g}", args.reuse, (*quiet, *cells(h), *remeshing))
    for name, (s, hist) in runs.items():
        at40 = np.interp(TRAVEL_40, hist["die_travel_mm"], hist["die_force_kN"])
        first = next(((r["jump"]["die_travel"][0], (b - a) / a) for r in s.get("remesh_records", [])
                      for k, (a, b) in r["jump"].items() if k == "die_force" and a), None)
        print(f"{name}: die force {at40:.2f} kN at 40 %, {hist['die_force_kN'][-1]:.2f} kN at "
              f"{100 * hist['die_travel_mm'][-1] / HALF_HEIGHT:.0f} %; {s.get('remeshes', 0)} remeshes, "
              f"solve {s['solve_time_s']:.0f} s"
              + (f"; first remesh at {first[0]:.2f} mm: force {100 * first[1]:+.2f} %" if first else ""))
    finest = f"plain_{levels[-1]:g}"
    for h in levels:
        d, where, mean = against(runs[f"remeshed_{h:g}"][1], runs[f"plain_{h:g}"][1], TRAVEL_40)
        print(f"level {h:g} mm, remeshed against plain up to 40 %: largest {100 * d:+.2f} % (at {where:.2f} mm), "
              f"mean {100 * mean:.2f} %")
        if f"plain_{h:g}" != finest:
            d, where, mean = against(runs[f"plain_{h:g}"][1], runs[finest][1], TRAVEL_40)
            print(f"  plain {h:g} against {finest} up to 40 %: largest {100 * d:+.2f} % (at {where:.2f} mm), "
                  f"mean {100 * mean:.2f} %")
    for coarse, fine in zip(levels[:-1], levels[1:]):
        f1, f2 = (runs[f"remeshed_{h:g}"][1]["die_force_kN"][-1] for h in (coarse, fine))
        print(f"remeshed {coarse:g} against {fine:g} mm at the end: {100 * (f1 - f2) / f2:+.2f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())
