"""3-D Taylor impact benchmark: the shipped quarter bar against CalculiX, step-loop time, µs per
cell-step and memory per cell on hexahedra, and 1 vs 2 MPI ranks at >= 100,000 hexahedra.

First, demos/taylor_bar_3d.toml as shipped (972 hexahedra: 6 cells from the axis to the surface and
36 along the bar, the resolution of CalculiX's quarter model of 972 C3D8R cells, which took 94 s for
the same 80 µs on this machine kind), run --scene-runs times by ``fenics-plast run`` (serial; medians
of the wall time and the step loop, min-max), with its radius and length against the axisymmetric
Richardson limit. Then the synthetic cases below.

    python benchmarks/bench_taylor_3d.py                 # 1000 hexes (200 steps), then 1 vs 2 ranks
                                                         # at 102,400 hexes (100 steps each)
    python benchmarks/bench_taylor_3d.py --only 5 40 200     # one case: n_r n_z steps (this process)
    mpirun -n 2 python benchmarks/bench_taylor_3d.py --only 16 400 20

The case is tests/explicit_3d_cases.py: a quarter of a round copper bar (R 3.2 mm, L 32.4 mm) of
n_r x n_r x n_z hexahedra (a box mapped onto the quarter disc), Q1/P0, isochoric model, hitting a
rigid wall at 227 m/s, fused internal force, element stable step. Printed per case (rank 0; times
the maximum over ranks): cells, steps, set-up time, step-loop time (a fixed number of steps from
the impact, after the compiled code is loaded; wall clock and the CPU time of the busiest rank),
µs per cell-step (loop time / (steps x cells): wall-clock per cell of the whole body), memory per cell (resident-set growth from before the mesh
to after the first force evaluation, summed over the ranks, per cell; on small meshes dominated by
what does not grow with the mesh: compiled forms and kernels loaded). Serial runs take the steps
between two checks (10) in one compiled call; under MPI each step is a call with a ghost update.
This is a benchmark: it asserts nothing.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests"))


def rss_bytes():
    """Resident set size of this process [bytes] (Linux /proc)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def case(n_r, n_z, steps):
    """Run one case on MPI.COMM_WORLD; returns the figures (rank 0) as a dict."""
    from mpi4py import MPI
    from explicit_3d_cases import taylor_3d
    comm = MPI.COMM_WORLD
    m0 = rss_bytes()
    t0 = time.perf_counter()
    s = taylor_3d(comm, n_r, n_z)
    s.initialize()                       # first force; loads (or compiles) the step loop
    setup = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    mem = comm.allreduce(rss_bytes() - m0, op=MPI.SUM)
    comm.Barrier()
    t0, c0 = time.perf_counter(), time.process_time()
    stats = s.run(1e-3, rows=2, progress=0, max_steps=steps)
    cpu = comm.allreduce(time.process_time() - c0, op=MPI.MAX)
    comm.Barrier()
    loop = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    e = s.energies()
    cells = s.cells_global
    return dict(ranks=comm.size, cells=cells, steps=stats["steps"], setup_s=setup, loop_s=loop, loop_cpu_s=cpu,
                us_per_cell_step=1e6 * loop / (stats["steps"] * cells), memory_per_cell_kB=mem / cells / 1e3,
                dt_ns=stats["dt_max"] * 1e9, max_eqps=s.max_eqps(), balance_error=e["balance_error"])


def show(r):
    print(f"  {r['ranks']} rank(s): {r['cells']:7d} hexes, {r['steps']:4d} steps, set-up {r['setup_s']:6.2f} s, "
          f"step loop {r['loop_s']:7.3f} s (CPU {r['loop_cpu_s']:.3f} s), {r['us_per_cell_step']:6.3f} us per cell-step, "
          f"memory {r['memory_per_cell_kB']:5.2f} kB per cell (dt {r['dt_ns']:.3g} ns, max eqps "
          f"{r['max_eqps']:.3f}, energy error {r['balance_error']:.1e})", flush=True)


def spawn(ranks, n_r, n_z, steps):
    """Run this script with --only on ``ranks`` ranks; the case's figures."""
    cmd = [sys.executable, __file__, "--only", str(n_r), str(n_z), str(steps), "--json"]
    if ranks > 1:
        cmd = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-n", str(ranks)] + cmd
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_", "OPAL_"))}
    p = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=REPO)
    if p.returncode:
        raise RuntimeError(p.stdout[-2000:] + p.stderr[-2000:])
    return json.loads([ln for ln in p.stdout.splitlines() if ln.startswith("{")][-1])


#: CalculiX 2.20, quarter Taylor bar of 972 C3D8R cells, 80 us, this machine kind (issue 14)
CALCULIX_WALL_S = 94.0


def shipped_scene(runs):
    """Run demos/taylor_bar_3d.toml ``runs`` times (serial, no fields or figures); print medians."""
    import statistics
    import tempfile
    walls, loops, s = [], [], None
    for _ in range(runs):
        with tempfile.TemporaryDirectory() as out:
            cmd = [sys.executable, "-m", "fenics_plast.cli", "run", str(REPO / "demos" / "taylor_bar_3d.toml"),
                   "--out", out, "--set", "output.xdmf=false", "--set", "output.plots=false"]
            p = subprocess.run(cmd, capture_output=True, text=True, cwd=REPO,
                               env=dict(os.environ, FENICS_PLAST_PROGRESS="off"))
            if p.returncode:
                raise RuntimeError(p.stdout[-2000:] + p.stderr[-2000:])
            s = json.loads((Path(out) / "summary.json").read_text())
        walls.append(s["wall_time_s"])
        loops.append(s["step_loop_time_s"])
    wall, loop = statistics.median(walls), statistics.median(loops)
    print(f"demos/taylor_bar_3d.toml as shipped: {s['cells']} hexes, {s['steps']} steps, serial, {runs} run(s)")
    print(f"  wall time  {wall:6.2f} s (median; {min(walls):.2f}-{max(walls):.2f} s), step loop {loop:.2f} s, "
          f"{1e6 * loop / (s['steps'] * s['cells']):.2f} us per cell-step")
    print(f"  CalculiX, 972 C3D8R cells, same 80 us: {CALCULIX_WALL_S:.0f} s -> {CALCULIX_WALL_S / wall:.1f} x faster "
          f"(target 5 x)")
    for k, ref in (("radius_mm", 7.22863), ("length_mm", 21.4228)):
        print(f"  {k:10s} {s[k]:.4f} ({100 * (s[k] / ref - 1):+.2f} % against the axisymmetric Richardson limit "
              f"{ref}; graded meshes: docs/STUDIES.md, taylor_3d)")
    print(f"  max_eqps   {s['max_eqps']:.3f}; energy balance error {s['energy_balance_error']:.1e}", flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene-runs", type=int, default=3, help="runs of the shipped scene (0: skip)")
    ap.add_argument("--only", nargs=3, type=int, metavar=("N_R", "N_Z", "STEPS"), help="one case, this process")
    ap.add_argument("--json", action="store_true", help="(with --only) print the figures as JSON")
    ap.add_argument("--small", nargs=3, type=int, default=(5, 40, 200), metavar=("N_R", "N_Z", "STEPS"))
    ap.add_argument("--large", nargs=3, type=int, default=(16, 400, 100), metavar=("N_R", "N_Z", "STEPS"))
    args = ap.parse_args()
    if args.only:
        r = case(*args.only)
        from mpi4py import MPI
        if MPI.COMM_WORLD.rank == 0:
            if args.json:
                print(json.dumps(r), flush=True)
            else:
                show(r)
        return
    if args.scene_runs:
        shipped_scene(args.scene_runs)
    print("3-D Taylor impact, quarter bar, Q1/P0 hexahedra (fused force, element stable step)")
    print(f"small case {args.small[0]} x {args.small[0]} x {args.small[1]}:")
    show(spawn(1, *args.small))
    print(f"large case {args.large[0]} x {args.large[0]} x {args.large[1]}, 1 vs 2 ranks:")
    one = spawn(1, *args.large)
    show(one)
    two = spawn(2, *args.large)
    show(two)
    print(f"  2-rank speed-up of the step loop: {one['loop_s'] / two['loop_s']:.2f} (wall clock), "
          f"{one['loop_cpu_s'] / two['loop_cpu_s']:.2f} (CPU time of the busiest rank, which counts MPI's busy "
          f"waiting for a rank that other processes hold up: about a lower bound of the speed-up on two free "
          f"cores; the wall-clock figure means little when other processes share the cores)")


if __name__ == "__main__":
    main()
