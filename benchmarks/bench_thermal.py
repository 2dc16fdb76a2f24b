"""Heat conduction's cost (issue 37): tests/scenes/heat_compression.toml (a cylinder upset 30 %, plastic
heating, here with a convecting top face) on a finer mesh, with [thermal] and without it (the same scene,
its thermal table, keys, boundaries and outputs taken out: the isothermal run); and the explicit
Johnson-Cook Taylor bar (demos/taylor_bar_jc.toml) adiabatic and with [thermal] at conductivity 0.

    python benchmarks/bench_thermal.py [--cells 32] [--increments 20] [--repeats 3] [--out results/bench_thermal]

Printed: per variant the median solve time of ``--repeats`` runs (summary.json's solve_time_s, the runs one
after the other in one process tree on the same machine), the thermal run's share spent in the heat steps
(assembly and solve, measured in the run: summary.json's ``heat_time_s``), the ratio thermal / isothermal,
and the mechanical results of both (press force, max eqps), which must agree to round-off: the flow stress
does not depend on the temperature yet, so the heat equation must not change the mechanics. A benchmark:
it asserts nothing.
"""
from __future__ import annotations

import argparse
import json
import re
import statistics
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "tests" / "scenes" / "heat_compression.toml"
FP = str(ROOT / ".venv" / "bin" / "fenics-plast")


def isothermal(text: str) -> str:
    """The scene without its heat conduction: the [thermal] table, the thermal material keys, the
    temperature and heat outputs."""
    text = re.sub(r"\[thermal\]\n[^\[]*", "", text)
    text = re.sub(r"\n(conductivity|specific_heat|taylor_quinney) = [^\n]*", "", text)
    text = re.sub(r"\nduration = [^\n]*", "", text)
    return re.sub(r"\[outputs\.(max_T|min_T|mean_T|heat)\]\n[^\[]*", "", text)


def run(scene: Path, out: Path, sets) -> dict:
    cmd = [FP, "run", str(scene), "--out", str(out), "--overwrite"] + [a for s in sets for a in ("--set", s)]
    subprocess.run(cmd, check=True, capture_output=True, text=True, cwd=ROOT)
    return json.loads((out / "summary.json").read_text())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cells", type=int, default=32)
    ap.add_argument("--increments", type=int, default=20)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "bench_thermal")
    a = ap.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    plain = a.out / "isothermal.toml"
    plain.write_text(isothermal(SCENE.read_text()).replace('"../../meshes/', f'"{ROOT}/meshes/'))
    common = [f"mesh.parameters.cells_radial={a.cells}", f"mesh.parameters.cells_axial={a.cells}",
              f"analysis.increments={a.increments}", "output.xdmf=false"]
    cooled = ["thermal_boundary.top.group=top", "thermal_boundary.top.type=convection",
              "thermal_boundary.top.film_coefficient=2000", "thermal_boundary.top.ambient_temperature=293"]
    results = {}
    for name, scene, sets in (("isothermal", plain, common), ("thermal", SCENE, common + cooled)):
        runs = [run(scene, a.out / name, sets) for _ in range(a.repeats)]
        results[name] = runs
        times = [r["solve_time_s"] for r in runs]
        line = f"{name:>10}: solve {statistics.median(times):.3f} s (median of {len(times)}: {times})"
        if name == "thermal":
            heat = statistics.median(r["heat_time_s"] for r in runs)
            line += f", heat steps {heat:.3f} s"
        print(line, flush=True)
    t_iso = statistics.median(r["solve_time_s"] for r in results["isothermal"])
    t_th = statistics.median(r["solve_time_s"] for r in results["thermal"])
    cells = results["thermal"][0]["cells"]
    print(f"thermal / isothermal: {t_th / t_iso:.3f} ({cells} cells, {a.increments} increments)")
    for key in ("max_eqps", "newton_iterations"):
        print(f"{key}: isothermal {results['isothermal'][0][key]!r}, thermal {results['thermal'][0][key]!r}")
    s = results["thermal"][0]
    print(f"thermal run: dT mean {s['mean_T_K'] - 293.0:.3f} K, max {s['max_T_K'] - 293.0:.3f} K, min "
          f"{s['min_T_K'] - 293.0:.3f} K, heat balance error {s['heat_balance_error']:.2e}")
    explicit(a.out, a.repeats)


def explicit(out: Path, repeats: int) -> None:
    """The Johnson-Cook Taylor bar (demos/taylor_bar_jc.toml): its adiabatic run against [thermal] at
    conductivity 0 (a heat step per history row): the step loop's time, the heat steps' and the results."""
    scene = ROOT / "demos" / "taylor_bar_jc.toml"
    quiet = ["output.plots=false", "output.xdmf=false"]
    field = quiet + ["thermal.initial_temperature=294", "materials.copper.conductivity=0",
                     "materials.copper.specific_heat=383"]
    runs = {name: [run(scene, out / f"taylor_{name}", sets) for _ in range(repeats)]
            for name, sets in (("adiabatic", quiet), ("field", field))}
    loop = {n: statistics.median(r["step_loop_time_s"] for r in rs) for n, rs in runs.items()}
    heat = statistics.median(r["heat_time_s"] for r in runs["field"])
    f, a = runs["field"][0], runs["adiabatic"][0]
    print(f"explicit Taylor bar: step loop adiabatic {loop['adiabatic']:.3f} s, with the field {loop['field']:.3f} s "
          f"(median of {repeats}), {f['heat_steps']} heat steps {heat:.3f} s; field / adiabatic: "
          + ", ".join(f"{k} {f[k] / a[k] - 1:+.2e}" for k in ("length_mm", "radius_mm", "max_temperature_K")))


if __name__ == "__main__":
    main()
