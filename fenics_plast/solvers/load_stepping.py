"""The load stepping of the static solver: the increments from one load factor to another, their growth, the
cut-back of a failed increment, the retries of a failed solve (more MUMPS workspace; the other line search),
progress, callbacks and checkpoints. The solver solves one increment
(:meth:`~fenics_plast.solvers.static.StaticSolver.solve_increment`); this module decides which, as dolfiny's
demos drive its SNES problem. Load factors are dimensionless (0 to 1 over a run).
"""
from __future__ import annotations

import time


def drive(solver, increments, min_increment, max_increment, lam_end, callback, growth, fast_iterations,
          checkpoint_every, on_checkpoint, resume):
    """Drive the load factor lam of ``solver`` (a :class:`~fenics_plast.solvers.static.StaticSolver`) from its
    current value to lam_end, one :meth:`~fenics_plast.solvers.static.StaticSolver.solve_increment` at a time
    (the arguments: :meth:`~fenics_plast.solvers.static.StaticSolver.run`, which declares their defaults).

    callback(solver) is called after every converged increment; returning True stops the run.
    Raises RunError below min_increment (all converged increments are kept/written).
    Returns True when lam_end was reached, False when the callback stopped the run.
    ``on_checkpoint(solver, loop)`` is called after the callback of every ``checkpoint_every``-th
    converged increment (counted over the solver's life; 0: never), ``loop`` holding this loop's
    variables (JSON-able); ``resume=loop`` continues the run() call that saved it (after
    ``solver.restart.load_state``; ignored by a run() call to another lam_end).
    """
    if not solver.is_set_up:
        solver.setup()
    span = lam_end - solver.lam_converged
    dl = min(span / increments, max_increment)
    prev_step = None
    if resume is not None and resume.get("lam_end") == lam_end:
        dl, prev_step = resume["dl"], resume["prev_step"]
    # a new load step from a loaded state: its first increment takes the tangent predictor or the extrapolation
    # of the last increment, whichever starts with the smaller residual (StaticSolver._predict); the later ones
    # extrapolate the step's own increments
    tangent = prev_step is None and solver.lam_converged > 0.0
    if tangent and solver.increments and solver.options["predictor"] == "contact":
        prev_step = solver.increments[-1]["step"]
    if solver.progress is not None:
        solver.progress.update(solver.lam_converged, inc=len(solver.increments), newton=0,
                               newton_total=solver.total_iterations, cutbacks=len(solver.cutbacks))
    while solver.lam_converged < lam_end - 1e-12 * max(1.0, abs(lam_end)):
        dl = min(dl, max_increment, lam_end - solver.lam_converged)
        lam = solver.lam_converged + dl
        t0 = time.perf_counter()
        ok, its, why = solver.solve_increment(lam, prev_step, tangent)
        while not ok and solver.raise_mumps_workspace():   # same step with more MUMPS workspace
            ok, its, why = solver.solve_increment(lam, prev_step, tangent)
        if not ok:
            # the elastic/plastic switch makes the residual non-smooth: a damped line search
            # can stall where full Newton steps go through, and full steps can overshoot where
            # backtracking helps. Retry the same step once with the other kind.
            other = "bt" if solver.options["linesearch"] == "basic" else "basic"
            solver.log(f"  retry at load {lam:.6g} with line search {other} ({why})")
            solver.linesearch_retries.append(dict(load_factor=lam, step=dl, iterations=its, reason=why,
                                                  retry=other))
            solver.set_linesearch(other)
            try:
                ok, its, why = solver.solve_increment(lam, prev_step, tangent)
            finally:
                solver.set_linesearch(solver.options["linesearch"])
        dt = time.perf_counter() - t0
        norms = list(solver.norms)
        if ok:
            solver.commit()
            rec = dict(increment=len(solver.increments) + 1, load_factor=lam, step=dl,
                       iterations=its, norms=norms, time_s=dt)
            solver.increments.append(rec)
            solver.log(f"increment {rec['increment']:4d}  load {lam:.6g} (step {dl:.3g})  "
                       f"newton {its:2d}  |R| {norms[0]:.3e} -> {norms[-1]:.3e}  ({dt:.2f} s)")
            if solver.progress is not None:
                solver.progress.update(lam, inc=rec["increment"], newton=its,
                                       newton_total=solver.total_iterations, cutbacks=len(solver.cutbacks))
            prev_step, tangent = dl, False
            if callback is not None and callback(solver):
                return False
            if its <= fast_iterations:
                dl *= growth
            if on_checkpoint is not None and checkpoint_every > 0 and \
                    len(solver.increments) % checkpoint_every == 0:
                on_checkpoint(solver, dict(dl=dl, prev_step=prev_step, lam_end=lam_end))
        else:
            solver.log(f"  cut back at load {lam:.6g} (step {dl:.3g}): {why}, "
                       f"{its} iterations, |R| = {', '.join(f'{n:.2e}' for n in norms[-4:])}")
            solver.restore()
            solver.cutbacks.append(dict(load_factor=lam, step=dl, iterations=its, reason=why))
            dl *= 0.5
            if dl < min_increment * (1 - 1e-9):
                raise solver.failure(
                    f"static solver: no convergence at load factor {lam:.6g} even with the "
                    f"smallest step {2 * dl:.3g} (min_increment {min_increment:g}): {why}.")
    return True
