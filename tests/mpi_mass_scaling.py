"""Helper for tests/test_explicit_stability.py: a short Taylor bar run with selective mass scaling
whose results go to an .npz file (scalars, and per node, gathered on rank 0 and sorted by position:
the displacement and the nodal mass), so that serial and ``mpirun -n 2`` runs can be compared.

    python tests/mpi_mass_scaling.py OUT.npz END_TIME_US MASS_SCALING_DT_US [ROUTE]
"""
import sys
from pathlib import Path

import numpy as np
from mpi4py import MPI

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from fenics_plast.problem import load_problem  # noqa: E402
from fenics_plast.runner_explicit import build_explicit  # noqa: E402


def main():
    out, end_us, target_us = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
    route = sys.argv[4] if len(sys.argv) > 4 else "fused"
    comm = MPI.COMM_WORLD
    problem = load_problem(REPO / "demos" / "taylor_bar.toml",
                           [f"analysis.end_time={end_us}", f"analysis.mass_scaling_dt={target_us}",
                            f"analysis.internal_force={route}", "output.history_points=3"])
    s = build_explicit(problem, comm).solver
    ana = problem.analysis
    stats = s.run(ana.end_time, dt_safety=ana.dt_safety, rows=3, progress=0, mass_scaling_dt=ana.mass_scaling_dt)
    m = s.cell_steps.mass_scaling_stats()
    e = s.energies()
    n = s.V.dofmap.index_map.size_local
    X, u, mass = s.reference_positions[:n], s.u.x.array.reshape(-1, 2)[:n], s.mass[0::2][:n]
    Xs, us, ms = comm.gather(X, root=0), comm.gather(u, root=0), comm.gather(mass, root=0)
    if comm.rank == 0:
        X, u, mass = np.concatenate(Xs), np.concatenate(us), np.concatenate(ms)
        order = np.lexsort((np.round(X[:, 0], 9), np.round(X[:, 1], 9)))
        np.savez(out, X=X[order], u=u[order], mass=mass[order], steps=stats["steps"], added_mass=m["added_mass"],
                 cells=m["cells"], energy=m["energy"], kinetic_added=m["kinetic"], kinetic=e["kinetic"],
                 balance_error=e["balance_error"], ranks=comm.size)


if __name__ == "__main__":
    main()
