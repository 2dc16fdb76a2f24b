"""Helper of tests/test_checkpoint.py: runs ``fenics-plast run`` in-process (serial, or every rank of
an ``mpirun``) and keeps the final displacement field, which the CLI does not write.

    python tests/checkpoint_driver.py JOBS.json

JOBS.json: a list of ``{"argv": [...fenics-plast arguments...], "npz": "PATH"}``, run in order in
one process; each job writes (rank 0) PATH with the exit status ``rc`` and the displacement at the
end of the run, gathered over the ranks and sorted by node position: ``X`` (n, 2) reference
coordinates [mm] rounded to 1e-9 mm, ``u`` (n, 2) [mm].
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
from mpi4py import MPI

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from fenics_plast import cli  # noqa: E402
from fenics_plast.solvers.explicit import ExplicitDynamics  # noqa: E402
from fenics_plast.solvers.static import StaticSolver  # noqa: E402


def _displacement(solver):
    """(X, u) of the owned nodes: reference coordinates (n, 2) and displacement (n, 2) [mm]."""
    if isinstance(solver, ExplicitDynamics):
        n = solver.V.dofmap.index_map.size_local
        return solver._X[:n], solver.u.x.array.reshape(-1, 2)[:n]
    u = solver.displacement_function()
    V = u.function_space
    n = V.dofmap.index_map.size_local
    return V.tabulate_dof_coordinates()[:n, :2], u.x.array.reshape(-1, 2)[:n]


def run_job(argv, npz, comm=MPI.COMM_WORLD):
    """``fenics-plast`` with ``argv`` in this process; the final displacement goes to ``npz`` (rank 0).
    Returns the exit status."""
    made = []
    originals = {}
    for cls in (ExplicitDynamics, StaticSolver):
        originals[cls] = cls.__init__

        def init(self, *a, _orig=originals[cls], **k):
            _orig(self, *a, **k)
            made.append(self)
        cls.__init__ = init
    try:
        rc = cli.main([str(a) for a in argv])
    finally:
        for cls, f in originals.items():
            cls.__init__ = f
    X, u = _displacement(made[-1]) if made else (np.zeros((0, 2)), np.zeros((0, 2)))
    Xs, us = comm.gather(X, root=0), comm.gather(u, root=0)
    if comm.rank == 0:
        X = np.round(np.concatenate(Xs), 9)
        u = np.concatenate(us)
        order = np.lexsort((X[:, 0], X[:, 1]))
        np.savez(npz, rc=rc, X=X[order], u=u[order], ranks=comm.size)
    return rc


def main():
    jobs = json.loads(Path(sys.argv[1]).read_text())
    for job in jobs:
        run_job(job["argv"], job["npz"])


if __name__ == "__main__":
    main()
