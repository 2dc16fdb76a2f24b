"""Helper for tests/test_explicit.py: a shortened Taylor bar run whose results are written to an
.npz file (scalars plus the displacement field gathered on rank 0 and sorted by node position),
so that serial and ``mpirun -n 2`` runs can be compared.

    python tests/mpi_explicit_taylor.py OUT.npz [END_TIME_US] [MODEL]
"""
import sys
from pathlib import Path

import numpy as np
from mpi4py import MPI

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from fenics_plast.scene import load_scene  # noqa: E402
from fenics_plast.scenes.taylor_bar import simulate  # noqa: E402


def main():
    out = sys.argv[1]
    end_us = float(sys.argv[2]) if len(sys.argv) > 2 else 5.0
    model = sys.argv[3] if len(sys.argv) > 3 else "isochoric"
    comm = MPI.COMM_WORLD
    scene = load_scene(REPO / "demos" / "taylor_bar.toml",
                       [f"loading.end_time_us={end_us}", f"material.model={model}", "output.history_points=3"])
    res, s = simulate(scene, None, comm=comm, log=lambda m: None)
    e = s.energies()
    n_nodes = s.V.dofmap.index_map.size_local
    X = s._X[:n_nodes]
    u = s.u.x.array.reshape(-1, 2)[:n_nodes]
    Xs = comm.gather(X, root=0)
    us = comm.gather(u, root=0)
    if comm.rank == 0:
        X = np.concatenate(Xs)
        u = np.concatenate(us)
        order = np.lexsort((np.round(X[:, 0], 9), np.round(X[:, 1], 9)))
        np.savez(out, X=X[order], u=u[order], final_length_mm=res["final_length_mm"],
                 final_radius_mm=res["final_radius_mm"], max_eqps=res["max_eqps"], steps=res["steps"],
                 kinetic=e["kinetic"], internal_work=e["internal_work"], elastic=e["elastic"],
                 balance_error=e["balance_error"], ranks=comm.size)


if __name__ == "__main__":
    main()
