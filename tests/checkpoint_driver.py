"""Helper of tests/test_checkpoint.py: runs ``fenics-plast run`` in-process (serial, or every rank of
an ``mpirun``) and keeps the final displacement field, which the CLI does not write.

    python tests/checkpoint_driver.py JOBS.json

JOBS.json: a list of ``{"argv": [...fenics-plast arguments...], "npz": "PATH"}``, run in order in
one process; each job writes (rank 0) PATH with the exit status ``rc`` and the displacement at the
end of the run, gathered over the ranks and sorted by node position: ``X`` (n, 2) reference
coordinates [mm] rounded to 1e-9 mm, ``u`` (n, 2) [mm]. A job ``{"keys": "taylor"|"bar", "npz":
PATH}`` instead writes the checkpoint keys of the solver's dofs and quadrature points with their
coordinates (:func:`key_coordinates`), to check that they do not depend on the partition.
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
from fenics_plast import dolfinx_compat as dc  # noqa: E402
from fenics_plast.solvers.explicit import ExplicitDynamics  # noqa: E402
from fenics_plast.solvers.static import StaticSolver  # noqa: E402


def _displacement(solver):
    """(X, u) of the owned nodes: reference coordinates (n, 2) and displacement (n, 2) [mm]."""
    if isinstance(solver, ExplicitDynamics):
        n = solver.V.dofmap.index_map.size_local
        return solver.reference_positions[:n], solver.u.x.array.reshape(-1, 2)[:n]
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


def key_coordinates(kind, npz, comm=MPI.COMM_WORLD):
    """Owned dof keys (fenics_plast.checkpoint.dof_keys) of the Taylor bar's V or the necking bar's
    mixed W with each dof's coordinates (a DG0 dof: its cell's midpoint), and the quadrature-point
    keys with the points' coordinates, gathered and sorted by key into ``npz`` (rank 0)."""
    import ufl
    from dolfinx import fem

    from fenics_plast.checkpoint import dof_keys, qp_keys
    from fenics_plast.problem import load_problem
    from fenics_plast.runner_explicit import build_explicit
    from fenics_plast.runner_static import build_static
    if kind == "taylor":
        s = build_explicit(load_problem(REPO / "demos" / "taylor_bar.toml"), comm).solver
        space = s.V
    else:
        problem = load_problem(REPO / "demos" / "bar_tension.toml",
                               ["mesh.parameters.cells_radial=4", "mesh.parameters.cells_axial=12"])
        s = build_static(problem, comm).solver
        s.verbose = False
        space = s.W
    keys = dof_keys(space)
    X = np.full((keys.size, 2), np.nan)
    subs = ([space.sub(i).collapse() for i in range(space.num_sub_spaces)] if kind == "bar" else
            [(space, np.arange(keys.size))])
    for sub, parent in subs:
        bs = sub.dofmap.index_map_bs
        X[np.asarray(parent)] = np.repeat(sub.tabulate_dof_coordinates()[:, :2], bs, axis=0)
    dm = space.dofmap
    n = dm.index_map.size_local * dm.index_map_bs
    q = s.qmap
    qk = qp_keys(s.mesh, q.n_owned, q.nq)
    qx = dc.eval_expression(fem.Expression(ufl.SpatialCoordinate(s.mesh), q.points), s.mesh, q.cells).reshape(-1, 2)
    parts = comm.gather((keys[:n], X[:n], qk, qx), root=0)
    if comm.rank == 0:
        out = {}
        for i, name in enumerate(("dof", "qp")):
            k = np.concatenate([p[2 * i] for p in parts])
            x = np.concatenate([p[2 * i + 1] for p in parts])
            order = np.argsort(k)
            out[f"{name}_keys"], out[f"{name}_x"] = k[order], x[order]
        np.savez(npz, **out)


def main():
    jobs = json.loads(Path(sys.argv[1]).read_text())
    for job in jobs:
        if "keys" in job:
            key_coordinates(job["keys"], job["npz"])
        else:
            run_job(job["argv"], job["npz"])


if __name__ == "__main__":
    main()
