"""Taylor bar benchmark: compile time, step-loop wall time, time per step and per cell-step.

    python benchmarks/bench_taylor.py                       # default scene, full 80 us, + both scenes as shipped
    python benchmarks/bench_taylor.py --scene-runs 0        # the step loop and its breakdown only
    python benchmarks/bench_taylor.py --refine 10           # 21,600 cells, first --max-steps steps
    mpirun -n 2 python benchmarks/bench_taylor.py --refine 10
    python benchmarks/bench_taylor.py --refine 10 --compare-mpi   # runs itself on 1 and 2 ranks

Figures printed (rank 0; times are the maximum over ranks):
* setup: mesh + forms + expressions (includes JIT compilation when the cache is cold; run with
  --cold to compile into a fresh cache),
* loop: wall time of the step loop only (no compilation), steps, time per step and per cell-step,
* a breakdown of one step measured at the final state (each part timed over --repeats calls):
  Fu Expression eval, material update (numba), tau scatter, dilatation assembly, internal-force
  assembly, and the rest (vector updates, stable-step estimate, bookkeeping).
The loop is measured --loops times (a fresh solver each time; median, min and max printed).
A refined run defaults to --max-steps 400 (the full 80 us at refine 10 is ~10^5 steps).

Then, in a plain serial invocation (refine 1, no option that changes the scene), the two Taylor
scenes as shipped, each run --scene-runs times by ``fenics-plast run`` (medians, min-max):
* demos/taylor_bar.toml: its summary's step_loop_time_s (the loop with its history rows and
  fields; issue 13's target: 1 s) and wall_time_s;
* demos/taylor_bar_accurate.toml: wall_time_s (target: 60 s), and its radius and length against
  the references it declares, the Richardson limit of the uniform-mesh study (target: 0.5 %).
This is a benchmark: it asserts nothing.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
SCENES = {"default": REPO / "demos" / "taylor_bar.toml", "accurate": REPO / "demos" / "taylor_bar_accurate.toml"}


def parse():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--refine", type=int, default=1)
    p.add_argument("--model", default=None, help="isochoric | seed (default: the scene's)")
    p.add_argument("--element", default=None, help="q1p0 | q1 (default: the scene's)")
    p.add_argument("--internal-force", default=None, help="fused | ufl (default: the scene's)")
    p.add_argument("--end-us", type=float, default=None, help="simulated time (default: the scene's 80 us)")
    p.add_argument("--max-steps", type=int, default=None, help="stop after this many steps (refine > 1: 400)")
    p.add_argument("--repeats", type=int, default=50, help="calls per part in the breakdown")
    p.add_argument("--loops", type=int, default=3, help="step-loop measurements (median printed)")
    p.add_argument("--scene-runs", type=int, default=3,
                   help="CLI runs of each shipped scene (plain serial invocation only; 0: none)")
    p.add_argument("--cold", action="store_true", help="compile into an empty JIT cache")
    p.add_argument("--compare-mpi", action="store_true", help="run on 1 and 2 ranks and print the speedup")
    p.add_argument("--json", default=None, help="write the figures to this file (rank 0)")
    return p.parse_args()


def bench(args):
    from mpi4py import MPI
    from dolfinx.fem import petsc as fem_petsc
    from petsc4py import PETSc

    from fenics_plast.problem import load_problem
    from fenics_plast.quantities import Quantities
    from fenics_plast.runner_explicit import build_explicit

    comm = MPI.COMM_WORLD
    ov = ["output.history_points=2", f"mesh.refine={args.refine}"]
    if args.model:
        ov.append(f"materials.copper.model={args.model}")
    if args.element:
        ov.append(f"mesh.element={args.element}")
    if args.internal_force:
        ov.append(f"analysis.internal_force={args.internal_force}")
    if args.end_us:
        ov.append(f"analysis.end_time={args.end_us}")
    problem = load_problem(REPO / "demos" / "taylor_bar.toml", ov)
    ana = problem.analysis
    max_steps = args.max_steps if args.max_steps is not None else (None if args.refine == 1 else 400)

    def tmax(x):
        return comm.allreduce(x, op=MPI.MAX)

    loops = []
    for k in range(max(args.loops, 1)):
        comm.barrier()
        t0 = time.perf_counter()
        b = build_explicit(problem, comm)
        s = b.solver
        s.initialize()
        # first material call compiles numba (cached on disk afterwards): part of the setup
        if k == 0:
            setup = tmax(time.perf_counter() - t0)

        comm.barrier()
        stats = s.run(ana.end_time, dt_safety=ana.dt_safety, steps=ana.time_steps, rows=2, progress=0,
                      max_steps=max_steps)
        loops.append(tmax(stats["wall_s"]))
    loop = statistics.median(loops)
    steps = stats["steps"]
    shape = Quantities(problem.outputs, b.body, b.facet_tags, b.groups).row(s.t * 1e6)   # the scene's outputs
    length, radius = shape["length_mm"], shape["radius_mm"]

    results = dict(length_mm=length, radius_mm=radius, max_eqps=s.max_eqps(),
                   energy_balance_error=s.energies()["balance_error"])

    # breakdown at the final state (each part repeated; the material state is restored afterwards)
    q = s.qmap
    R = args.repeats
    saved = q.binv.copy(), q.eqps.copy()

    def timed(f):
        comm.barrier()
        t = time.perf_counter()
        for _ in range(R):
            f()
        return tmax((time.perf_counter() - t) / R)

    if s.fused:
        parts = {"fused pass (kinematics + material + force)": timed(s.internal_force)}
    else:
        def assemble_f():
            b = s._f
            with b.localForm() as bl:
                bl.set(0.0)
            fem_petsc.assemble_vector(b, s._L_int)
            b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)

        parts = {
            "Fu eval": timed(q.evaluate_Fu),
            "material update": timed(lambda: s.material.update_into(q.Fu, q.binv, q.eqps, q.tau_values,
                                                                    q.binv_trial, q.eqps_trial, None)),
            "tau scatter + finite check": timed(lambda: (q.tau_values.sum(),
                                                         q._write(q.tau, q.tau_values, 9, q._qdofs, q.trivial_tau))),
            "theta assembly": timed(s._update_theta) if s.theta is not None else 0.0,
            "f_int assembly": timed(assemble_f),
        }
    q.binv[:], q.eqps[:] = saved
    per_step = loop / max(steps, 1)
    parts["rest (vectors, dt, bookkeeping)"] = max(per_step - sum(parts.values()), 0.0)
    cells = s.cells_global
    fig = dict(ranks=comm.size, refine=args.refine, cells=cells, dofs=s.dofs_global, qps=cells * q.nq,
               model=s.material.model, element=s.element, steps=steps, simulated_us=s.t * 1e6,
               setup_s=setup, loop_s=loop, loop_runs_s=loops, time_per_step_ms=per_step * 1e3,
               time_per_cell_step_us=per_step / cells * 1e6,
               breakdown_ms={k: v * 1e3 for k, v in parts.items()}, internal_force=s.internal_force_route,
               **results)
    if comm.rank == 0:
        print(f"Taylor bar benchmark: {cells} cells ({fig['dofs']} dofs, {fig['qps']} qps), "
              f"{s.element}, {s.material.model}, internal force {s.internal_force_route}, {comm.size} rank(s)")
        print(f"  setup (mesh, forms, expressions, JIT{' cold' if args.cold else ''}): {setup:8.3f} s")
        print(f"  step loop (no compilation): {loop:8.3f} s for {steps} steps, {fig['simulated_us']:.2f} us simulated"
              + (f" (median of {len(loops)}: {min(loops):.3f}-{max(loops):.3f} s)" if len(loops) > 1 else ""))
        print(f"  per step: {per_step * 1e3:.4f} ms   per cell-step: {fig['time_per_cell_step_us']:.4f} us")
        print("  breakdown of one step (ms, share):")
        for k, v in parts.items():
            print(f"    {k:44s} {v * 1e3:8.4f}  {100 * v / per_step:5.1f} %")
        print(f"  final length {length:.3f} mm, impact radius {radius:.3f} mm, max eqps {fig['max_eqps']:.3f}, "
              f"energy error {fig['energy_balance_error']:.2e}")
        if args.json:
            Path(args.json).write_text(json.dumps(fig, indent=2))
    return fig


def _median_spread(values):
    return f"{statistics.median(values):7.2f} s (median of {len(values)}: {min(values):.2f}-{max(values):.2f} s)"


def shipped_scenes(runs):
    """Both Taylor scenes as shipped, each run ``runs`` times by ``fenics-plast run``: the default
    scene's step loop and the accurate scene's wall time and errors against its references."""
    figs = {}
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_", "OPAL_"))}
    env["FENICS_PLAST_PROGRESS"] = "off"
    print(f"Taylor scenes as shipped (fenics-plast run, serial, {runs} run(s) each; wall times vary by "
          f"+-30 % on a shared machine):")
    for name, scene in SCENES.items():
        summaries = []
        for _ in range(runs):
            with tempfile.TemporaryDirectory() as d:
                p = subprocess.run([sys.executable, "-m", "fenics_plast.cli", "run", str(scene), "--out", d],
                                   cwd=REPO, env=env, capture_output=True, text=True)
                if p.returncode != 0:
                    print(f"  {scene.name}: run failed (exit {p.returncode}): {p.stderr.strip()[-500:]}")
                    break
                summaries.append(json.loads((Path(d) / "summary.json").read_text()))
        if not summaries:
            continue
        s = summaries[-1]
        fig = dict(cells=s["cells"], steps=s["steps"],
                   wall_time_s=[x["wall_time_s"] for x in summaries],
                   step_loop_time_s=[x["step_loop_time_s"] for x in summaries],
                   errors={k: (s[k] - r["value"]) / abs(r["value"]) for k, r in s.get("references", {}).items()
                           if k in ("radius_mm", "length_mm")})
        figs[name] = fig
        print(f"  {scene.relative_to(REPO)}: {fig['cells']} cells, {fig['steps']} steps")
        print(f"    step loop   {_median_spread(fig['step_loop_time_s'])}")
        print(f"    wall time   {_median_spread(fig['wall_time_s'])}")
        for k, e in fig["errors"].items():
            print(f"    {k:11s} {s[k]:.4f} ({100 * e:+.3f} % against {s['references'][k]['value']:g}: "
                  f"{s['references'][k]['source']})")
    return figs


def compare_mpi(args):
    figs = {}
    for n in (1, 2):
        with tempfile.TemporaryDirectory() as d:
            js = Path(d) / "fig.json"
            cmd = [sys.executable, __file__, "--refine", str(args.refine), "--json", str(js),
                   "--repeats", str(args.repeats), "--loops", "1", "--scene-runs", "0"]
            for k in ("model", "element", "internal_force"):
                if getattr(args, k):
                    cmd += [f"--{k.replace('_', '-')}", getattr(args, k)]
            if args.end_us:
                cmd += ["--end-us", str(args.end_us)]
            if args.max_steps is not None:
                cmd += ["--max-steps", str(args.max_steps)]
            if n > 1:
                cmd = ["/usr/bin/mpirun", "--allow-run-as-root", "-n", str(n)] + cmd
            env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_", "OPAL_"))}
            subprocess.run(cmd, check=True, env=env)
            figs[n] = json.loads(js.read_text())
    sp = figs[1]["time_per_step_ms"] / figs[2]["time_per_step_ms"]
    print(f"speedup 1 -> 2 ranks at {figs[1]['cells']} cells: {sp:.2f}x "
          f"({figs[1]['time_per_step_ms']:.3f} -> {figs[2]['time_per_step_ms']:.3f} ms per step)")


def main():
    args = parse()
    if args.cold:
        os.environ["XDG_CACHE_HOME"] = tempfile.mkdtemp(prefix="fenics_plast_jit_")
    if args.compare_mpi:
        compare_mpi(args)
        return
    fig = bench(args)
    from mpi4py import MPI
    plain = (MPI.COMM_WORLD.size == 1 and args.refine == 1 and not any(
        (args.model, args.element, args.internal_force, args.end_us, args.max_steps is not None, args.cold)))
    if plain and args.scene_runs > 0:
        fig["scenes"] = shipped_scenes(args.scene_runs)
        if args.json:
            Path(args.json).write_text(json.dumps(fig, indent=2))


if __name__ == "__main__":
    main()
