"""Remeshing benchmark, the transfer part (issue 35): the state of an old mesh onto a new one.

    python benchmarks/bench_remesh_transfer.py [--cells 1000 10000 40000] [--runs 3]
    mpirun -n 2 python benchmarks/bench_remesh_transfer.py

Old mesh: about N distorted structured quadrilaterals of a 2 x 1 mm rectangle
(tests/mpi_remesh_transfer.py's ``structured``); new mesh: Gmsh's unstructured quadrilaterals of the
rectangle at the size that gives about N cells (``unstructured``, not timed). Printed per N: the
median over --runs of the set-up (:class:`fenics_plast.remeshing.transfer.StateTransfer`: gathering
the old mesh, boundary edges, bucket grid), the quadrature state (b_e^-1, eqps, T at 4 points per
cell; of it, locating the new points), a P0 field and a CG1 vector field, their total, and the L2
error of eqps against the analytic field. A benchmark: it asserts nothing.
"""
from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))
import mpi_remesh_transfer as fx  # noqa: E402
from fenics_plast import dolfinx_compat as dc  # noqa: E402
from fenics_plast.remeshing import transfer as tr  # noqa: E402


def timed(comm, f):
    """(result, wall time [s]) of f(), all ranks started together, the slowest rank's time."""
    comm.Barrier()
    t0 = time.perf_counter()
    out = f()
    return out, comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells", type=int, nargs="+", default=[1000, 10000, 40000])
    ap.add_argument("--runs", type=int, default=3)
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    import dolfinx.fem as fem
    if comm.rank == 0:
        print(f"bench_remesh_transfer: {comm.size} rank(s), median of {args.runs} runs [s]")
        print(f"{'old cells':>10} {'new cells':>10} {'set-up':>8} {'state':>8} {'(locate)':>8} {'P0':>8} "
              f"{'CG1':>8} {'total':>8} {'L2 err eqps':>12}")
    for n_cells in args.cells:
        n = max(2, round(math.sqrt(n_cells / 2)))
        old, new = fx.structured(comm, n), fx.unstructured(comm, fx.H / n)
        old_state = fx.state_at(tr.quadrature_points(old, 2))
        centres = tr.cell_corners(old).mean(axis=1)
        p0 = fx.eqps(centres[:, 0], centres[:, 1])
        v_old, v_new = fem.Function(dc.vector_space(old)), fem.Function(dc.vector_space(new))
        x = v_old.function_space.tabulate_dof_coordinates()
        v_old.x.array[:] = fx.velocity(x[:, 0], x[:, 1]).reshape(-1)
        points = tr.quadrature_points(new, 2)
        times = {k: [] for k in ("setup", "state", "locate", "p0", "cg1")}
        for _ in range(args.runs):
            transfer, t = timed(comm, lambda: tr.StateTransfer(old))
            times["setup"].append(t)
            (state, _), t = timed(comm, lambda: transfer.quadrature_state(old_state, new))
            times["state"].append(t)
            times["locate"].append(timed(comm, lambda: tr.locate(transfer.body, points))[1])
            times["p0"].append(timed(comm, lambda: transfer.cell_values(p0, new))[1])
            times["cg1"].append(timed(comm, lambda: transfer.nodal_function(v_old, v_new))[1])
        med = {k: statistics.median(v) for k, v in times.items()}
        e = state["eqps"] - fx.eqps(points[:, 0], points[:, 1])
        l2 = math.sqrt(comm.allreduce(float(e ** 2 @ tr.quadrature_volumes(new, 2).reshape(-1))))
        cells = [comm.allreduce(m.topology.index_map(2).size_local) for m in (old, new)]
        if comm.rank == 0:
            total = med["setup"] + med["state"] + med["p0"] + med["cg1"]
            print(f"{cells[0]:>10d} {cells[1]:>10d} {med['setup']:>8.3f} {med['state']:>8.3f} {med['locate']:>8.3f} "
                  f"{med['p0']:>8.3f} {med['cg1']:>8.3f} {total:>8.3f} {l2:>12.3e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
