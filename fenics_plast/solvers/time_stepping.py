"""The explicit solver's time stepping: the step size (dt_safety x the stable step, re-estimated every
``reestimate_every`` steps and cut to land on the history rows, or fixed), the chunks of steps the serial
fused route takes in one compiled call, and the checks between them (the step floor, a fold ahead, a
non-finite step, the kinetic energy), the rows, progress lines and checkpoints. The solver takes one step
(:meth:`~fenics_plast.solvers.explicit.ExplicitDynamics.step`) or a chunk
(:meth:`~fenics_plast.solvers.explicit.ExplicitDynamics.advance`); this module decides which and when. Times
in s, energies in N mm.
"""
from __future__ import annotations

import math
import time

import numpy as np

from fenics_plast.errors import Arg, Message, RunError
from fenics_plast.schema import key
from fenics_plast.solvers.collapse import collapse_error, fold_error, unstable_message


def drive(solver, end_time, dt_safety, steps, rows, on_row, progress, max_steps, bar, checkpoint_every,
          on_checkpoint, resume, dt_floor, mass_scaling_dt, on_check=None):
    """Integrate ``solver`` (an :class:`~fenics_plast.solvers.explicit.ExplicitDynamics`) to ``end_time`` [s]
    (the arguments and what it returns and raises: :meth:`~fenics_plast.solvers.explicit.ExplicitDynamics.run`,
    which declares their defaults)."""
    for name, value in (("dt_safety", dt_safety), ("dt_floor", dt_floor), ("mass_scaling_dt", mass_scaling_dt)):
        if not key(f"analysis.{name}").in_range(value):      # the ranges are the schema's
            raise RunError(f"{name} must satisfy {key(f'analysis.{name}').range_text(name)}, got {value}")
    dt_stable0 = solver.stable_dt() if resume is None else resume["dt_stable0"]
    if steps is not None:
        dt_fixed = end_time / int(steps)
        if dt_fixed > dt_stable0:
            raise RunError(Message(
                f"time step end_time/steps = {dt_fixed:.4g} s ({int(steps)} steps) exceeds the stable "
                f"limit {dt_stable0:.4g} s ({solver.cell_steps.limit_text(dt_stable0)}); use at least "
                f"{math.ceil(end_time / dt_stable0)} steps or drop ", Arg("steps")))
    if solver.KE0 is None:
        solver.initialize()
    row_times = np.linspace(0.0, end_time, max(int(rows), 2))
    eps_t = 1e-12 * end_time
    # a run that goes on from t > 0 (a second call) skips the row times behind it
    next_row = max(1, int(np.searchsorted(row_times, solver.t + eps_t, side="right")))
    if on_row is not None and resume is None and solver.t == 0.0:
        on_row(solver, 0.0)
    dt_stable = dt_stable0
    dt_min, dt_max = np.inf, 0.0
    prog_times = np.linspace(0.0, end_time, progress + 1)[1:] if progress else []
    next_prog = int(np.searchsorted(prog_times, solver.t + eps_t, side="right")) if progress else 0
    if resume is not None:
        next_row, next_prog, dt_stable = resume["next_row"], resume["next_prog"], resume["dt_stable"]
        dt_min, dt_max = resume["dt_min"], resume["dt_max"]
    last_checkpoint = steps0 = solver.step_count
    t_wall0 = time.perf_counter()

    def stats(dt_stable_final):
        wall = time.perf_counter() - t_wall0
        return dict(steps=solver.step_count, dt_min=dt_min, dt_max=dt_max, dt_stable_initial=dt_stable0,
                    dt_stable_final=dt_stable_final, wall_s=wall,
                    time_per_step_s=wall / max(solver.step_count - steps0, 1))
    # with contact against tools whose gap is Python code (gap_np), the serial run goes step by step
    chunked = solver.fused and solver.comm.size == 1 and solver.contact.chunkable
    while solver.t < end_time - eps_t and (max_steps is None or solver.step_count < max_steps):
        if steps is not None:
            dt = min(dt_fixed, end_time - solver.t)
        else:
            if solver.step_count % solver.reestimate_every == 0:
                if mass_scaling_dt > 0.0:
                    solver.scale_mass(mass_scaling_dt)
                dt_stable = solver.stable_dt()
                if dt_stable < dt_floor * dt_stable0:
                    e = collapse_error(solver, dt_stable, dt_stable0, dt_floor, mass_scaling_dt)
                    e.stats = stats(dt_stable)
                    e.loop = dict(next_row=next_row, next_prog=next_prog, dt_stable=dt_stable,
                                  dt_stable0=dt_stable0, dt_min=dt_min, dt_max=dt_max)
                    raise e
            # equal steps to the next row time, none above dt_safety x dt_stable: k = the steps
            # left to it, dt = what is left / k (the same dt at each step of the interval while
            # dt_stable holds). Not a long step and a sliver before each row: central differences
            # with periodically varying steps are unstable below the stable step (parametric
            # resonance of the highest modes; an elastic bar with a row every 2.5 steps blew up)
            remaining = row_times[next_row] - solver.t
            k_row = max(1, math.ceil(remaining / (dt_safety * dt_stable) - 1e-9))
            dt = remaining / k_row
        # serial fused route: the steps up to the next check, with this dt, in one compiled call;
        # the last step before a row time is taken alone (it lands on the row time exactly)
        n_chunk = 1
        if chunked:
            if steps is None:
                to_row = k_row - 1
            else:
                to_row = int((min(row_times[next_row], end_time) - solver.t) / dt - 1.5)
            n_chunk = min(solver.reestimate_every - solver.step_count % solver.reestimate_every, to_row)
            if max_steps is not None:
                n_chunk = min(n_chunk, max_steps - solver.step_count)
        try:
            if n_chunk > 1:
                solver.advance(n_chunk, dt)
            else:
                solver.step(dt)
        except (np.linalg.LinAlgError, FloatingPointError, ZeroDivisionError) as e:
            # (rank-local: no collective in the message)
            raise RunError(unstable_message(solver, dt, f"step failed: {e}", dt_stable, local=True)) from None
        dt_min, dt_max = min(dt_min, dt), max(dt_max, dt)
        if solver.guard.pending_fold is not None:
            # the next step would fold a cell (every rank knows): stop at the last finite state
            e = fold_error(solver, solver.guard.pending_fold, dt_stable0, dt_floor, mass_scaling_dt,
                           step_key=Message(Arg("dt_safety"), f", now {dt_safety:g}") if steps is None else
                           Message("more ", Arg("steps"), f" than {int(steps)}"))
            solver.guard.pending_fold = None
            e.stats = stats(e.dt_stable)
            e.loop = dict(next_row=next_row, next_prog=next_prog, dt_stable=dt_stable,
                          dt_stable0=dt_stable0, dt_min=dt_min, dt_max=dt_max)
            raise e
        if solver.guard.step_failure is not None:
            # a non-finite stress or force (every rank knows): the step was not taken
            raise RunError(unstable_message(solver, dt, solver.guard.step_failure, dt_stable))
        if solver.step_count % solver.reestimate_every == 0:
            if bar is not None:
                bar.update(solver.t * 1e6, step=solver.step_count, dt_ns=dt * 1e9)
            ke = solver.kinetic_energy()
            if not math.isfinite(ke) or ke > solver.ke_limit():
                why = f"kinetic energy {ke:.4g} N mm vs initial {solver.KE0:.4g} N mm"
                fail = solver.comm.allgather(solver.guard.step_failure)
                fail = [f for f in fail if f]
                if fail:
                    why += f"; {fail[0]}"
                raise RunError(unstable_message(solver, dt, why, dt_stable))
            if steps is not None:
                if mass_scaling_dt > 0.0:
                    solver.scale_mass(mass_scaling_dt)
                dt_stable = solver.stable_dt()
                if dt_fixed > dt_stable:       # the mesh has crushed below the fixed step's size
                    raise RunError(Message(
                        f"the fixed time step end_time/steps = {dt_fixed:.4g} s exceeds the stable limit "
                        f"{dt_stable:.4g} s of the deformed mesh at t = {solver.t * 1e6:.4g} us (step "
                        f"{solver.step_count}, {solver.cell_steps.limit_text(dt_stable)}): raise ", Arg("steps"),
                        " or drop it (adaptive step)"))
        while next_row < len(row_times) and solver.t >= row_times[next_row] - eps_t:
            if solver.erosion_ratio > 0.0:
                solver.log_erosion()
            if on_row is not None:
                on_row(solver, solver.t)
            next_row += 1
        while next_prog < len(prog_times) and solver.t >= prog_times[next_prog] - eps_t:
            e = solver.energies()
            if not math.isfinite(e["kinetic"]) or e["kinetic"] > solver.ke_limit():
                raise RunError(unstable_message(solver, dt, f"kinetic energy {e['kinetic']:.4g}"))
            solver.log(f"  t = {solver.t * 1e6:8.3f} us  step {solver.step_count:6d}  dt = {dt:.3e} s  "
                       f"KE = {e['kinetic'] / 1e3:9.3f} J  W_int = {e['internal_work'] / 1e3:9.3f} J  "
                       f"max eqps = {solver.max_eqps():.3f}  energy error = {e['balance_error']:.2e}")
            next_prog += 1
        if on_checkpoint is not None and checkpoint_every > 0 and \
                solver.step_count - last_checkpoint >= checkpoint_every:
            on_checkpoint(solver, dict(next_row=next_row, next_prog=next_prog, dt_stable=dt_stable,
                                       dt_stable0=dt_stable0, dt_min=dt_min, dt_max=dt_max))
            last_checkpoint = solver.step_count
        if on_check is not None and solver.step_count % solver.reestimate_every == 0 and on_check(solver):
            out = stats(solver.stable_dt())         # stopped by the caller (a remesh): where to go on from
            out["loop"] = dict(next_row=next_row, next_prog=next_prog, dt_stable=dt_stable, dt_stable0=dt_stable0,
                               dt_min=dt_min, dt_max=dt_max)
            return out
    return stats(solver.stable_dt())
