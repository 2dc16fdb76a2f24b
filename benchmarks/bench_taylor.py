"""Taylor bar benchmark: compile time, step-loop wall time, time per step and per cell-step.

    python benchmarks/bench_taylor.py                       # default scene, full 80 us
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
A refined run defaults to --max-steps 400 (the full 80 us at refine 10 is ~10^5 steps).
This is a benchmark: it asserts nothing.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))


def parse():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--refine", type=int, default=1)
    p.add_argument("--model", default=None, help="isochoric | seed (default: the scene's)")
    p.add_argument("--element", default=None, help="q1p0 | q1 (default: the scene's)")
    p.add_argument("--internal-force", default=None, help="fused | ufl (default: the scene's)")
    p.add_argument("--end-us", type=float, default=None, help="simulated time (default: the scene's 80 us)")
    p.add_argument("--max-steps", type=int, default=None, help="stop after this many steps (refine > 1: 400)")
    p.add_argument("--repeats", type=int, default=50, help="calls per part in the breakdown")
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

    comm.barrier()
    t0 = time.perf_counter()
    b = build_explicit(problem, comm)
    s = b.solver
    s.initialize()
    # first material call compiles numba (cached on disk afterwards): part of the setup
    setup = tmax(time.perf_counter() - t0)

    comm.barrier()
    stats = s.run(ana.end_time, dt_safety=ana.dt_safety, steps=ana.time_steps, rows=2, progress=0,
                  max_steps=max_steps)
    loop = tmax(stats["wall_s"])
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
        parts = {"fused pass (kinematics + material + force)": timed(s._internal_force)}
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
               setup_s=setup, loop_s=loop, time_per_step_ms=per_step * 1e3,
               time_per_cell_step_us=per_step / cells * 1e6,
               breakdown_ms={k: v * 1e3 for k, v in parts.items()}, internal_force=s.internal_force_route,
               **results)
    if comm.rank == 0:
        print(f"Taylor bar benchmark: {cells} cells ({fig['dofs']} dofs, {fig['qps']} qps), "
              f"{s.element}, {s.material.model}, internal force {s.internal_force_route}, {comm.size} rank(s)")
        print(f"  setup (mesh, forms, expressions, JIT{' cold' if args.cold else ''}): {setup:8.3f} s")
        print(f"  step loop (no compilation): {loop:8.3f} s for {steps} steps, {fig['simulated_us']:.2f} us simulated")
        print(f"  per step: {per_step * 1e3:.4f} ms   per cell-step: {fig['time_per_cell_step_us']:.4f} us")
        print("  breakdown of one step (ms, share):")
        for k, v in parts.items():
            print(f"    {k:44s} {v * 1e3:8.4f}  {100 * v / per_step:5.1f} %")
        print(f"  final length {length:.3f} mm, impact radius {radius:.3f} mm, max eqps {fig['max_eqps']:.3f}, "
              f"energy error {fig['energy_balance_error']:.2e}")
        if args.json:
            Path(args.json).write_text(json.dumps(fig, indent=2))
    return fig


def compare_mpi(args):
    figs = {}
    for n in (1, 2):
        with tempfile.TemporaryDirectory() as d:
            js = Path(d) / "fig.json"
            cmd = [sys.executable, __file__, "--refine", str(args.refine), "--json", str(js),
                   "--repeats", str(args.repeats)]
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
    else:
        bench(args)


if __name__ == "__main__":
    main()
