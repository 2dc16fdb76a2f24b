"""Runs a validated :class:`fenics_plast.problem.Problem`: mesh -> forms -> solver -> results.

One runner for every problem; it knows no scene by name. It holds the CLI's three entry points and
dispatches on ``analysis.type``; the work is done by:

1. :mod:`fenics_plast.scene_mesh` (:func:`read_mesh`, re-exported here for the CLI): mesh the scene's
   Gmsh file and check that every group the scene names exists, with the right dimension (2-D: regions
   are surfaces, groups curves; 3-D: regions are volumes, groups surfaces), and what its values ask of
   the nodes;
2. :mod:`fenics_plast.build`: the material(s), boundary conditions and loads, tools, contact pairs and
   initial velocity, from the scene, for either analysis (every unit conversion of the scene's values);
3. :mod:`fenics_plast.runner_static` / :mod:`fenics_plast.runner_explicit`: the solver of
   ``analysis.type`` with what the build gives (only what the scene names is assembled: no contact
   pairs, no contact forms; explicit: no Newton), then the steps (static) or the time integration
   (explicit), recording the declared outputs (:mod:`fenics_plast.quantities`) into history.csv,
   fields into fields.xdmf, profiles at step ends (:mod:`fenics_plast.results`);
4. the results for summary.json (final values, maxima, study keys, run statistics).

Steps 1 and 2 run before the CLI creates the output folder (:func:`read_mesh`, :func:`prepare`): what
they refuse (a mesh parameter out of range, a mesh too large for the memory, a value of x, y, z that
is not finite at a node, a symmetry group that is not straight, a fixed time step above the stable
limit, ...) is a SceneError, exit 2 with the key named and no file written.

Times: static t is the pseudo-time (the load factor of the solver); explicit t is in seconds
inside the package and in µs in scene files, tables and expressions, history.csv (``time_us``).
"""
from __future__ import annotations

from mpi4py import MPI

from fenics_plast.errors import SceneError
from fenics_plast.expressions import ExpressionError
from fenics_plast.scene_mesh import read_mesh

__all__ = ["read_mesh", "prepare", "run"]


def prepare(problem, comm, mesh_data):
    """The run's set-up from the checked mesh (``mesh_data``: :func:`read_mesh`'s): the solver with its
    conditions, loads, contact pairs and initial state, built before anything is written, so that every
    rule the set-up enforces (a symmetry group that is not straight, a reaction without a condition, a
    wall with the body on both sides, a fixed time step above the stable limit, ...) refuses the scene
    with SceneError (exit 2) and no file. Returns what :func:`run` takes as ``mesh_data``; progress lines
    of the set-up go to stdout (rank 0). Collective."""
    import sys
    import time
    t0 = time.perf_counter()

    def log(msg):
        if comm.rank == 0:
            print(msg, flush=True)
    try:
        if problem.explicit:
            from fenics_plast.runner_explicit import build_explicit, checked_steps, many_steps_warning
            built = build_explicit(problem, comm, mesh_data, log=log)
            built.history_rows = checked_steps(problem, built.solver)
            warning = many_steps_warning(problem, built.solver)
            if warning and comm.rank == 0:
                print(warning, file=sys.stderr, flush=True)
        else:
            from fenics_plast.runner_static import build_static
            built = build_static(problem, comm, mesh_data, log=log)
    except ExpressionError as e:
        raise SceneError(f"{problem.path}: {e}") from None
    built.setup_s = time.perf_counter() - t0
    return built


def run(problem, output, mesh_data=None) -> dict:
    """CLI entry point: runs the problem, returns the results for summary.json. ``mesh_data``: the
    result of :func:`read_mesh` when the caller has read (and checked) the mesh already, or of
    :func:`prepare` (the solver built), or the exception :func:`prepare` raised (raised here, where
    the CLI reports a failed run)."""
    if isinstance(mesh_data, BaseException):
        raise mesh_data
    comm = output.comm if output.comm is not None else MPI.COMM_WORLD
    from fenics_plast.results import start_plot_worker, stop_plot_worker
    start_plot_worker(problem, output)
    try:
        if problem.explicit:
            from fenics_plast.runner_explicit import run_explicit
            results = run_explicit(problem, output, comm, mesh_data)
        else:
            from fenics_plast.runner_static import run_static
            results = run_static(problem, output, comm, mesh_data)
    finally:
        stop_plot_worker(output)
    if results is not None:
        results["peak_memory_mb"] = peak_memory_mb(comm)
    return results


def peak_memory_mb(comm) -> float:
    """The largest peak resident memory of one process of the run so far [MiB] (collective)."""
    import resource
    return comm.allreduce(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, op=MPI.MAX)


