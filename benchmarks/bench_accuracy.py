"""Accuracy on demand against known answers (issue 38): for each case (a shipped scene, one of its
results, a reference) and each tolerance, ``run --accuracy RESULT=TOL``; is the reported error bar
around the reference, and is the achieved error within the tolerance? And what does the ladder cost
against the final run alone?

    python benchmarks/bench_accuracy.py [--out results/bench_accuracy] [--tolerances 5,2,1,0.5]
                                        [--cases taylor,punch,cylinder] [--time-budget 600]

The references:

* the Taylor bar (demos/taylor_bar.toml): the converged radius 7.2259 mm and length 21.42 mm of Foulk
  et al. (2021), given to 5 and 4 digits: half a unit of their last digit is their precision;
* the punch (demos/punch_stretching.toml): converged in the increments as well as the mesh, since both
  results depend on the increments more than on the mesh (the scene's 40 increments leave the force
  0.17 % low and the thinnest point's strain 1.5 % too large at refine 4; a study of refine 4, 6, 8 at those increments
  misses it). Five runs: refine 4 at 4, 8 and 16 times the scene's increments (Richardson over the
  increments counted), refine 2 and 3 at 16 times (the mesh's correction, Richardson or the finest);
  the precision is the spread between the extrapolation at the observed order and at first order,
  plus the mesh's correction;
* the thick cylinder (demos/thick_cylinder.toml): the bore's reaction from a study of mesh.refine =
  4, 6, 8 at 160 increments (Hill's rigid-plastic closed form in the current radii is within 1e-4 of it:
  it leaves out the elastic strains). Its ladder meets 0.5 % already, so it is also asked for 0.05 and
  0.02 %.

Each case's requests share one folder (results/bench_accuracy/<case>), so the ladder runs once and each
tighter tolerance reuses it; the references are studies in results/bench_accuracy/reference_<case>,
reused when run again. "brackets": |value - reference| <= error bar + the reference's precision;
"within": |value - reference| <= the tolerance. The cost ratio (ladder + final runs) / final run is
printed for each request and, for the issue's check, of one request per scene for every key result at
1 % (the way a user asks). Process seconds, one run at a time on this machine. A benchmark: it asserts
nothing.
"""
from __future__ import annotations

import argparse
import json
import math
from dataclasses import dataclass
from pathlib import Path

from fenics_plast.accuracy import parse_tolerance, run_accuracy
from fenics_plast.study import parse_vary, run_study

ROOT = Path(__file__).resolve().parent.parent


@dataclass
class Case:
    scene: str
    results: list[str]
    reference: str          # "published" | "study" | "mesh_and_time"
    published: dict | None = None
    precision: dict | None = None
    study_sets: tuple = ()
    extra: tuple = ()       # tolerances (percent) beyond --tolerances, where those are all met by the ladder


CASES = {
    "taylor": Case("demos/taylor_bar.toml", ["radius_mm", "length_mm"], "published",
                   published={"radius_mm": 7.2259, "length_mm": 21.42},
                   precision={"radius_mm": 0.00005, "length_mm": 0.005}),
    "punch": Case("demos/punch_stretching.toml", ["max_punch_force_kN", "min_thickness_strain"], "mesh_and_time"),
    "cylinder": Case("demos/thick_cylinder.toml", ["inner_rx_N"], "study",
                     study_sets=("analysis.increments=160", "analysis.max_increment=0.00625"), extra=(0.05, 0.02)),
}


def mesh_and_time_reference(case: Case, out: Path) -> tuple[dict, dict, str]:
    """The punch's reference converged in the increments and the mesh (see the module docstring)."""
    from fenics_plast.accuracy import mesh_estimate
    from fenics_plast.accuracy.axes import scene_axes
    from fenics_plast.problem import load_problem
    from fenics_plast.study.execute import Run, execute
    time = scene_axes(load_problem(ROOT / case.scene))["time"]      # the scene's increments, refined by a factor
    runs = {}
    for refine, factor in ((4, 4), (4, 8), (4, 16), (3, 16), (2, 16)):
        name = f"refine-{refine}_time-{factor}"
        run = Run(name=name, label=name, settings={})
        execute(run, ROOT / case.scene, ["output.xdmf=false", "output.plots=false", f"mesh.refine={refine}",
                                         *time.overrides(factor)], out / name, reuse=True, root=out)
        runs[name] = run
    values, precision = {}, {}
    in_time = [runs[f"refine-4_time-{f}"] for f in (4, 8, 16)]
    in_mesh = [runs[f"refine-{r}_time-16"] for r in (2, 3, 4)]
    for key in case.results:
        h = [1.0 / r.value("increments") for r in in_time]
        f = [r.value(key) for r in in_time]
        observed = mesh_estimate(h, f, order_cap=8.0)
        first = mesh_estimate(h, f, order_cap=1.0)
        mesh = mesh_estimate([1 / 2, 1 / 3, 1 / 4], [r.value(key) for r in in_mesh], order_cap=8.0)
        correction = (mesh.value - in_mesh[-1].value(key)) if mesh.kind == "monotone" else 0.0
        values[key] = observed.value + correction
        precision[key] = abs(observed.value - first.value) + abs(correction) + (
            mesh.bar if mesh.kind != "monotone" else 0.0)
    return values, precision, ("refine 4 extrapolated over 4, 8, 16 times the increments, plus the mesh's "
                               "correction at 16 times")


def references(name: str, case: Case, out: Path) -> tuple[dict, dict, str]:
    """({result: reference}, {result: precision}, source text)."""
    if case.reference == "published":
        return case.published, case.precision, "Foulk et al. (2021), converged"
    if case.reference == "mesh_and_time":
        return mesh_and_time_reference(case, out / f"reference_{name}_time")
    study = run_study(ROOT / case.scene, [parse_vary("mesh.refine=4,6,8")], out / f"reference_{name}",
                      sets=list(case.study_sets), results=case.results, reuse=True, log=lambda m: None)
    ref = study.refs[0]
    values = {k: ref.values[k] for k in case.results}
    # the reference's own uncertainty: its distance from the finest run (0 when it is that run)
    finest = ref.run.summary
    precision = {k: abs(values[k] - finest[k]) for k in case.results}
    return values, precision, "; ".join(f"{k}: {ref.kind[k]}" for k in case.results)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(ROOT / "results" / "bench_accuracy"))
    ap.add_argument("--tolerances", default="5,2,1,0.5", help="percent")
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--time-budget", type=float, default=600.0,
                    help="each request's --time-budget [s] (a final run predicted longer is refused)")
    args = ap.parse_args()
    out = Path(args.out)
    tolerances = [float(t) for t in args.tolerances.split(",")]
    rows, ratios = [], []
    for name in args.cases.split(","):
        case = CASES[name]
        ref, precision, source = references(name, case, out)
        print(f"\n## {name}: {case.scene}; references: " + ", ".join(f"{k} {v:.6g} (± {precision[k]:.2g})"
                                                                  for k, v in ref.items())
              + f" ({source})", flush=True)
        folder = out / name
        for key in case.results:
            for tol in [*tolerances, *case.extra]:
                o = run_accuracy(ROOT / case.scene, [parse_tolerance(f"{key}={tol:g}%")], folder,
                                 time_budget=args.time_budget, log=lambda m: None)
                rows.append(_row(name, key, tol, o, ref[key], precision[key]))
                print(_line(rows[-1]), flush=True)
        o = run_accuracy(ROOT / case.scene, [parse_tolerance(f"{k}=1%") for k in case.results], folder,
                         time_budget=args.time_budget, log=lambda m: None)
        ratios.append((name, o.final, o.ladder_s, o.final_s, o.cost_ratio, o.status))
        print(f"{name}, every result at 1 %: final run {o.final}, ladder {o.ladder_s:.1f} s, final "
              f"{o.final_s:.1f} s, (ladder + final) / final = {o.cost_ratio:.2f}, {o.status}", flush=True)
    done = [r for r in rows if r["status"] != "refused"]
    print("\n| case | result | tolerance | status | final run | value ± bar | error vs reference | brackets | "
          "within | (ladder + final) / final |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(_line(r))
    n = len(done)
    print(f"\n{n} of {len(rows)} requests reported a value with its bar (the others refused); the bar "
          f"brackets the reference in "
          f"{sum(r['brackets'] for r in done)} of {n}, the achieved error is within the tolerance in "
          f"{sum(r['within'] for r in done)} of {n}; refused or not met: "
          f"{sum(r['status'] != 'met' for r in rows)}")
    for name, final, ladder_s, final_s, ratio, status in ratios:
        print(f"cost at 1 % on every result, {name}: ladder {ladder_s:.1f} s + final {final_s:.1f} s "
              f"({final}): ratio {ratio:.2f} ({status})")
    (out / "bench_accuracy.json").write_text(json.dumps(dict(rows=rows, ratios=ratios), indent=1, default=str))


def _row(case: str, key: str, tol: float, o, ref: float, precision: float) -> dict:
    res = next((r for r in o.results if r.key == key), None)
    value = res.value if res is not None else None
    err = (value - ref) if value is not None else None
    return dict(case=case, key=key, tolerance=tol, status=o.status, final=o.final, value=value,
                bar=res.bar if res else None, error=err, relative_error=err / abs(ref) if err is not None else None,
                brackets=bool(err is not None and abs(err) <= res.bar + precision),
                within=bool(err is not None and abs(err) <= tol / 100 * abs(ref)),
                cost_ratio=o.cost_ratio, refusals=o.refusals)


def _line(r: dict) -> str:
    head = f"| {r['case']} | `{r['key']}` | {r['tolerance']:g} % | {r['status']} |"
    if r["status"] == "refused":
        return head + " – | – | – | – | – | – | " + "; ".join(w for w, _ in r["refusals"])
    ratio = r["cost_ratio"]
    return (head + f" {r['final']} | {r['value']:.6g} ± {r['bar']:.2g} | {r['relative_error'] * 100:+.3f} % | "
            f"{'yes' if r['brackets'] else 'NO'} | {'yes' if r['within'] else 'NO'} | "
            + (f"{ratio:.2f} |" if ratio is not None and math.isfinite(ratio) else "– |"))


if __name__ == "__main__":
    main()
