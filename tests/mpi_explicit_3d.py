"""Helper for tests/test_explicit_3d.py: a short 3-D Taylor impact (tests/explicit_3d_cases.py)
whose displacements, gathered on rank 0 and sorted by node position, and energies are written to
an .npz file, so that serial and ``mpirun -n 2`` runs can be compared.

    python tests/mpi_explicit_3d.py OUT.npz [END_TIME_US]
"""
import sys
from pathlib import Path

import numpy as np
from mpi4py import MPI

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests"))

from explicit_3d_cases import taylor_3d  # noqa: E402


def main():
    out = sys.argv[1]
    end_us = float(sys.argv[2]) if len(sys.argv) > 2 else 2.0
    comm = MPI.COMM_WORLD
    s = taylor_3d(comm)
    stats = s.run(end_us * 1e-6, rows=3, progress=0)
    e = s.energies()
    n_nodes = s.V.dofmap.index_map.size_local
    X, u = s.reference_positions[:n_nodes], s.u.x.array.reshape(-1, 3)[:n_nodes]
    Xs, us = comm.gather(X, root=0), comm.gather(u, root=0)
    eqps = s.max_eqps()
    if comm.rank == 0:
        X, u = np.concatenate(Xs), np.concatenate(us)
        order = np.lexsort(tuple(np.round(X[:, k], 9) for k in range(3)))
        np.savez(out, X=X[order], u=u[order], steps=stats["steps"], kinetic=e["kinetic"],
                 internal_work=e["internal_work"], elastic=e["elastic"], balance_error=e["balance_error"],
                 max_eqps=eqps, ranks=comm.size)


if __name__ == "__main__":
    main()
