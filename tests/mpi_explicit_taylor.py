"""Helper for tests/test_explicit.py: a shortened Taylor bar run whose results are written to an
.npz file (scalars plus the displacement field gathered on rank 0 and sorted by node position),
so that serial and ``mpirun -n 2`` runs can be compared.

    python tests/mpi_explicit_taylor.py OUT.npz [END_TIME_US] [MODEL] [KEY=VALUE ...]

(KEY=VALUE: further scene overrides, as --set.)
"""
import sys
from pathlib import Path

import numpy as np
from mpi4py import MPI

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from fenics_plast.problem import load_problem  # noqa: E402
from fenics_plast.quantities import Quantities  # noqa: E402
from fenics_plast.runner_explicit import build_explicit  # noqa: E402


def main():
    out = sys.argv[1]
    end_us = float(sys.argv[2]) if len(sys.argv) > 2 else 5.0
    model = sys.argv[3] if len(sys.argv) > 3 else "isochoric"
    comm = MPI.COMM_WORLD
    problem = load_problem(REPO / "demos" / "taylor_bar.toml",
                           [f"analysis.end_time={end_us}", f"materials.copper.model={model}",
                            "output.history_points=3", *sys.argv[4:]])
    b = build_explicit(problem, comm)
    s, ana = b.solver, problem.analysis
    stats = s.run(ana.end_time, dt_safety=ana.dt_safety, steps=ana.time_steps,
                  rows=problem.output.history_points, progress=0, mass_scaling_dt=ana.mass_scaling_dt)
    eroded = s.cell_steps.erosion_stats()["cells"]
    res = Quantities(problem.outputs, b.body, b.facet_tags, b.groups).row(end_us)
    e = s.energies()
    n_nodes = s.V.dofmap.index_map.size_local
    X = s.reference_positions[:n_nodes]
    u = s.u.x.array.reshape(-1, 2)[:n_nodes]
    Xs = comm.gather(X, root=0)
    us = comm.gather(u, root=0)
    if comm.rank == 0:
        X = np.concatenate(Xs)
        u = np.concatenate(us)
        order = np.lexsort((np.round(X[:, 0], 9), np.round(X[:, 1], 9)))
        np.savez(out, X=X[order], u=u[order], length_mm=res["length_mm"], radius_mm=res["radius_mm"],
                 max_eqps=res["max_eqps"], steps=stats["steps"], kinetic=e["kinetic"],
                 internal_work=e["internal_work"], elastic=e["elastic"], balance_error=e["balance_error"],
                 wall=e["wall"], eroded_cells=eroded, ranks=comm.size)


if __name__ == "__main__":
    main()
