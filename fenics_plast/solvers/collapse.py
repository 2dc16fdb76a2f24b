"""Diagnosis of a collapsing explicit time step: the cell that sets it and why, and the error that stops the run.

:meth:`fenics_plast.solvers.explicit.ExplicitDynamics.run` calls :func:`collapse_error` when the
stable step falls below ``dt_floor`` x its initial value; the message names the cell (its
index in the mesh file, where it is now and in the reference mesh), its size, aspect ratio, volume
ratio J and corner angles (hexahedra: size V / A_max, aspect ratio and J, no angles), the collapse
ratio, and the remedies with the solver's arguments to set (a :class:`~fenics_plast.errors.Message`:
the driver words them as the scene's keys). It calls :func:`fold_error` when a step would
fold a cell (a quadrature point's Jacobian <= 0, found by the force pass before it writes anything):
the run stops at the last finite state, and the message names the cell, its shape there, the point
Jacobian the step would have reached, and the remedies (a fold is no collapse of the step: the floor
does not see it). :func:`unstable_message` words a run gone unstable otherwise (a non-finite stress, a
kinetic energy out of bounds). Lengths in mm, times in s (the times of the run in µs, where users write them; the
arguments' values in the solver's units, which the driver's wording may show in others).
"""
from __future__ import annotations

import numpy as np
from mpi4py import MPI

from fenics_plast.errors import Arg, Message, RunError
from fenics_plast.solvers import hex_step
from fenics_plast.solvers.quad_step import quad_min_size


class TimeStepCollapse(RunError):
    """The stable step fell below ``dt_floor`` x its initial value (``ExplicitDynamics.run``).

    ``results``: where and why (stopped_at_us, dt_collapse_ratio, collapse_cell...); ``stats``: the
    run statistics so far (as ``ExplicitDynamics.run`` returns them); ``loop``: the run-loop
    variables (a checkpoint at the stop). The solver's state is the one at the stop (finite)."""

    def __init__(self, message, results=None, stats=None, loop=None):
        super().__init__(message, results)
        self.stats, self.loop = stats, loop


class CellFold(TimeStepCollapse):
    """The next step would fold a cell (a quadrature point's Jacobian <= 0, or a displacement that is
    not finite): it was not taken, and the run stops at the last finite state (:func:`fold_error`).
    A :class:`TimeStepCollapse` for the runner: outputs, fields and a checkpoint at the stop."""


def critical_cell(solver) -> dict:
    """The cell that sets the element stable step (collective): dict with ``cell`` (its index in
    the mesh file's cell order), ``position`` and ``reference`` (vertex mean now and in the
    reference mesh [mm]), ``size`` (smallest edge or altitude [mm]), ``aspect`` (longest edge /
    size), ``volume_ratio`` J (current / reference volume: area times centroid radius in
    axisymmetry, area in plane strain; <= 0: inverted), ``factor`` (its mass-scaling density
    factor), ``dt`` (its stable step [s], ``CellSteps.cell_dt``), ``dt_size`` and
    ``dt_element`` (its size estimate and its element's step 2 / omega_max [s]) and ``max_angle``,
    ``min_angle`` (its largest and smallest interior corner angles [deg]; above 180: no longer
    convex). Hexahedra: ``size`` is V / A_max (volume over largest face area), ``aspect`` longest
    edge / size, ``volume_ratio`` V / V0, and the angles are None."""
    cs = solver.cell_steps
    dt_loc, i = cs.local_min_dt()
    best = solver.comm.allreduce((dt_loc, solver.comm.rank), op=MPI.MINLOC) if solver.comm.size > 1 \
        else (dt_loc, solver.comm.rank)
    info = None
    if solver.comm.rank == best[1] and i >= 0:
        dt_size = float(cs.size_dt()[i])
        dt_el = float(cs.element_dt(np.array([i]))[0])
        info = _cell_info(solver, i, dt_loc, dt_size, dt_el)
    return solver.comm.bcast(info, root=best[1]) if solver.comm.size > 1 else info


def _cell_info(solver, i, dt_loc, dt_size, dt_el):
    """:func:`critical_cell`'s dict for owned cell i (rank-local)."""
    if solver.cell_steps.three_d:
        return _hex_cell_info(solver, i, dt_loc, dt_size, dt_el)
    P, P0 = solver.cell_steps.corners(i)              # cyclic order
    size = float(quad_min_size(P[None])[0])
    edges = np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1)

    def volume(Q):
        x, y = Q[:, 0], Q[:, 1]
        xn, yn = np.roll(x, -1), np.roll(y, -1)
        cross = x * yn - xn * y
        # area 1/2 sum cross; axisymmetric: first moment int r dA = 1/6 sum (x + xn) cross (Pappus)
        return float(((x + xn) * cross).sum() / 6.0) if solver.kin.axisymmetric else float(0.5 * cross.sum())

    # interior corner angles [deg] (> 180: the cell is no longer convex), oriented as the reference
    orient = 1.0 if volume(P0) > 0 else -1.0
    ea, eb = np.roll(P, 1, axis=0) - P, np.roll(P, -1, axis=0) - P
    ang = np.degrees(np.arctan2(orient * (eb[:, 0] * ea[:, 1] - eb[:, 1] * ea[:, 0]),
                                (ea * eb).sum(axis=1))) % 360.0
    return dict(cell=int(solver.mesh.topology.original_cell_index[i]), position=P.mean(axis=0).tolist(),
                reference=P0.mean(axis=0).tolist(), size=size,
                aspect=float(edges.max() / max(size, 1e-300)),
                volume_ratio=volume(P) / volume(P0), factor=float(solver.cell_steps.cell_scale[i]), dt=dt_loc,
                dt_size=dt_size, dt_element=dt_el, max_angle=float(ang.max()), min_angle=float(ang.min()))


def _hex_cell_info(solver, i, dt, dt_size, dt_element):
    """:func:`critical_cell`'s dict for owned hexahedron i (no corner angles)."""
    P, P0 = solver.cell_steps.corners(i)                  # basix order
    size = float(hex_step.hex_size(P, np.arange(8)[None])[0])
    edges = hex_step.hex_edge_lengths(P[None])[0]
    return dict(cell=int(solver.mesh.topology.original_cell_index[i]), position=P.mean(axis=0).tolist(),
                reference=P0.mean(axis=0).tolist(), size=size, aspect=float(edges.max() / max(size, 1e-300)),
                volume_ratio=float(hex_step.hex_volume(P[None])[0] / hex_step.hex_volume(P0[None])[0]),
                factor=float(solver.cell_steps.cell_scale[i]), dt=dt, dt_size=dt_size, dt_element=dt_element,
                max_angle=None, min_angle=None)


def collapse_error(solver, dt_stable, dt_stable0, dt_floor, mass_scaling_dt) -> TimeStepCollapse:
    """The :class:`TimeStepCollapse` of a step below the floor (collective): its message names the
    cell, where it is, its shape and the remedies."""
    c = critical_cell(solver)
    ax = ("r", "z") if solver.kin.axisymmetric else ("x", "y", "z")[: len(c["position"])]
    ratio = dt_stable / dt_stable0
    pos = f"({', '.join(ax)}) = ({', '.join(f'{x:.4g}' for x in c['position'])}) mm"
    ref = f"({', '.join(f'{x:.4g}' for x in c['reference'])}) mm"
    hexa = c["max_angle"] is None
    element_step = Arg("stable_step", "element", form="set")
    remedies = []
    if solver.stable_step == "size" and c["dt_element"] > 10.0 * c["dt_size"] and hexa:
        remedies.append(Message(f"the cell's own elastic element step 2/omega_max is {c['dt_element']:.3g} s, "
                                f"{c['dt_element'] / c['dt_size']:.3g} x its size estimate: ", element_step,
                                " takes the element's step"))
    elif solver.stable_step == "size" and c["dt_element"] > 10.0 * c["dt_size"]:
        # the size estimate collapses on a corner near 180 degrees; the element does not
        remedies.append(Message(f"the cell's own elastic element step 2/omega_max is {c['dt_element']:.3g} s, "
                                f"{c['dt_element'] / c['dt_size']:.3g} x its size estimate h/c (the smallest "
                                f"altitude follows the thinnest spot of the wedge-like cell, next to its corner of "
                                f"{c['max_angle']:.1f} degrees; the element's frequency follows its whole shape): ",
                                element_step, " takes the element's step"))
    if mass_scaling_dt > 0.0:
        remedies.append(Message("selective mass scaling is on (", Arg("mass_scaling_dt", mass_scaling_dt, "s",
                                                                      "value", ".4g"),
                                ") and did not hold the step: a target above the floor (",
                                Arg("mass_scaling_dt", dt_floor * dt_stable0, "s", "amount", ".3g"),
                                ") adds ever more mass as the cell thins"))
    else:
        # the target suggested: 0.2 of the initial step, to 2 digits in the unit shown
        remedies.append(Message("selective mass scaling, e.g. ",
                                Arg("mass_scaling_dt", 0.2 * dt_stable0, "s", "set", digits=2),
                                " (", Arg("mass_scaling_dt", unit="s", form="unit"),
                                ", the target stable step, 0.2 of the initial one: mass is added to the cells below "
                                "it and reported in history.csv and summary.json; it cannot keep up with a cell that "
                                "thins to nothing)"))
    remedies.append(Message("a finer mesh (", Arg("mesh"), ") or one graded toward that cell"))
    listed = [remedies[0]]
    for r in remedies[1:]:
        listed += ["; ", r]
    msg = Message(f"time step collapsed at t = {solver.t * 1e6:.4g} us (step {solver.step_count}): the stable step "
                  f"{dt_stable:.4g} s is {ratio:.3g} of its initial value {dt_stable0:.4g} s, below ",
                  Arg("dt_floor", dt_floor, form="value"),
                  f". It is set by cell {c['cell']} (the mesh file's cell order) at {pos} (reference {ref}): "
                  + (f"size (volume / largest face area) {c['size']:.3g} mm, aspect ratio {c['aspect']:.3g} "
                     f"(longest edge / size), volume ratio J = {c['volume_ratio']:.3g}" if hexa else
                     f"smallest size {c['size']:.3g} mm, aspect ratio {c['aspect']:.3g} "
                     f"(longest edge / smallest size), volume ratio J = {c['volume_ratio']:.3g}, corner angles "
                     f"{c['min_angle']:.1f} to {c['max_angle']:.1f} degrees")
                  + (f", mass-scaling density factor {c['factor']:.3g}" if c["factor"] > 1.0 else "")
                  + ". Remedies: ", listed, ". (A lower ", Arg("dt_floor"),
                  " lets the run go on, at ever smaller steps.)")
    results = dict(stop_reason="time_step_floor", stopped_at_us=solver.t * 1e6, dt_collapse_ratio=ratio,
                   collapse_cell=c["cell"],
                   collapse_cell_position_mm=c["position"], collapse_cell_reference_mm=c["reference"],
                   collapse_cell_size_mm=c["size"], collapse_cell_aspect_ratio=c["aspect"],
                   collapse_cell_volume_ratio=c["volume_ratio"])
    if not hexa:
        results["collapse_cell_max_angle_deg"] = c["max_angle"]
    results["collapse_cell_dt_element_s"] = c["dt_element"]
    return TimeStepCollapse(msg, results=results)


#: a point Jacobian falling by more than this in the failed step: the step is long for the motion
FOLD_IN_ONE_STEP = 0.05


def fold_error(solver, fold, dt_stable0, dt_floor, mass_scaling_dt,
               step_key=Message(Arg("dt_safety"))) -> CellFold:
    """The :class:`CellFold` of a step that would fold a cell (collective), the solver back at the
    last finite state. ``fold``: each rank's note of the failed step (``StepGuard.step_failed``:
    ``cell``, its most folded owned cell there, ``j_next`` that cell's smallest point Jacobian,
    ``finite`` whether u was finite, ``dt`` the step [s]). The cell named is the most folded one of
    all ranks (ties: the lowest index in the mesh file), described at the stop as the time-step
    floor's cell is (:func:`critical_cell`), with the remedies: when its point Jacobian would fall by
    more than :data:`FOLD_IN_ONE_STEP` in that one step, the step is long for the motion (the Taylor
    bar at 5000 m/s: nodes move half a cell per step) and ``step_key`` (the argument of the step
    size, with its value: a :class:`~fenics_plast.errors.Message`) is named; otherwise the cell
    flattened over many steps, which a smaller step does not prevent."""
    comm = solver.comm
    i = fold["cell"]
    orig = int(solver.mesh.topology.original_cell_index[i]) if i >= 0 else np.iinfo(np.int64).max
    key = (fold["j_next"], orig, comm.rank)
    keys = comm.allgather(key) if comm.size > 1 else [key]
    best = min(keys)
    finite = all(comm.allgather(fold["finite"])) if comm.size > 1 else fold["finite"]
    dt_stable = solver.stable_dt()                      # at the stop (collective)
    c = None
    if comm.rank == best[2] and i >= 0:
        cs = solver.cell_steps
        d_size = float(cs.size_dt()[i])
        d_el = float(cs.element_dt(np.array([i]))[0])
        c = _cell_info(solver, i, max(d_size, d_el) if solver.stable_step == "element" else d_size, d_size, d_el)
        jnow = np.empty(solver.n_cells_own)
        solver.guard.folded_cells(jnow)
        c["j_now"] = float(jnow[i])
    c = comm.bcast(c, root=best[2]) if comm.size > 1 else c
    j_next = best[0]
    ratio = dt_stable / dt_stable0
    ax = ("r", "z") if solver.kin.axisymmetric else ("x", "y", "z")[: len(c["position"])]
    pos = f"({', '.join(ax)}) = ({', '.join(f'{x:.4g}' for x in c['position'])}) mm"
    ref = f"({', '.join(f'{x:.4g}' for x in c['reference'])}) mm"
    hexa = c["max_angle"] is None
    t_next = (solver.t + fold["dt"]) * 1e6
    if finite:
        head = (f"cell {c['cell']} (the mesh file's cell order) folded in the step to t = {t_next:.4g} us (step "
                f"{solver.step_count + 1}): the smallest volume ratio J at its quadrature points would go from "
                f"{c['j_now']:.3g} to {j_next:.3g} (<= 0: turned inside out), where the material update has "
                f"no answer.")
    else:
        head = (f"the displacement became non-finite in the step to t = {t_next:.4g} us (step "
                f"{solver.step_count + 1}), first seen in cell {c['cell']} (the mesh file's cell order): the "
                f"velocity was not finite (a load, prescribed motion or contact force that is not finite?).")
    shape = (f"size (volume / largest face area) {c['size']:.3g} mm, aspect ratio {c['aspect']:.3g}, volume ratio "
             f"J = {c['volume_ratio']:.3g}" if hexa else
             f"smallest size {c['size']:.3g} mm, aspect ratio {c['aspect']:.3g}, volume ratio J = "
             f"{c['volume_ratio']:.3g}, corner angles {c['min_angle']:.1f} to {c['max_angle']:.1f} degrees")
    scaling = Message("selective mass scaling (", Arg("mass_scaling_dt", mass_scaling_dt, "s", "value", ".4g")
                      if mass_scaling_dt > 0.0 else Arg("mass_scaling_dt"), ")")
    drop = c["j_now"] - j_next
    if finite and drop > FOLD_IN_ONE_STEP:
        step = Message(f"The point Jacobian would fall by {drop:.3g} in this one step: the step is long for the "
                       f"motion there (its nodes move a large part of the cell per step), and a smaller step (",
                       step_key, ") follows the crushing further; ", scaling,
                       " does not. Other remedies:")
    else:
        step = Message("The cell flattened over many steps: neither a smaller step (", step_key, ") nor ", scaling,
                       " prevents the fold. Remedies:")
    msg = Message(f"{head} The run stops at the last finite state, t = {solver.t * 1e6:.4g} us (step "
                  f"{solver.step_count}), where the cell is at {pos} (reference {ref}): {shape}. The stable step "
                  f"is then {ratio:.3g} of its initial value, above ", Arg("dt_floor", dt_floor, form="value"),
                  ": a fold is not a collapse of the time step, which the floor would catch. ", step,
                  " element erosion (", Arg("erosion_ratio"), ", e.g. 0.1) removes a cell about to fold and goes "
                  "on; a finer mesh (", Arg("mesh"), ") or one graded toward that cell delays the fold; another "
                  "element or material model (", Arg("element"), ", ", Arg("material.model"), ") may follow the "
                  "deformation further; a node passing a rigid support's plane is stopped by a wall on every node (",
                  Arg("add_wall"), ")")
    results = dict(stop_reason="cell_fold" if finite else "non_finite_displacement", stopped_at_us=solver.t * 1e6,
                   dt_collapse_ratio=ratio, fold_cell=c["cell"],
                   fold_cell_position_mm=c["position"], fold_cell_reference_mm=c["reference"],
                   fold_cell_size_mm=c["size"], fold_cell_aspect_ratio=c["aspect"],
                   fold_cell_volume_ratio=c["volume_ratio"], fold_cell_min_point_volume_ratio=c["j_now"])
    results["fold_cell_next_point_volume_ratio"] = j_next
    if not hexa:
        results["fold_cell_max_angle_deg"] = c["max_angle"]
    # (a point Jacobian that is not finite is in the message only: no non-finite number in a result)
    results = {k: v for k, v in results.items() if not isinstance(v, float) or np.isfinite(v)}
    e = CellFold(msg, results=results)
    e.dt_stable = dt_stable
    return e


def _nonfinite_cell(solver, local=False):
    """(original index, reference vertex mean [mm]) of the first owned cell, on the lowest rank
    that has one, whose stress is not finite; None when every stress is finite (collective unless
    ``local``: this rank's cells only)."""
    tau = np.asarray(solver.qmap.tau_values).reshape(solver.n_cells_own, -1)
    bad = np.flatnonzero(~np.isfinite(tau).all(axis=1))
    loc = None
    if bad.size:
        i = int(bad[0])
        loc = solver.cell_steps.centre(i)
    gathered = solver.comm.allgather(loc) if solver.comm.size > 1 and not local else [loc]
    found = [x for x in gathered if x is not None]
    return found[0] if found else None


def unstable_message(solver, dt, why, dts=None, local=False) -> Message:
    """The message of an explicit run (``solver``) gone unstable at the step dt [s] for the reason ``why``
    (collective unless ``local``), the remedies naming the solver's arguments
    (:class:`~fenics_plast.errors.Message`)."""
    dts = solver.stable_dt() if dts is None else dts
    head = (f"explicit run went unstable at t = {solver.t * 1e6:.4g} us (step {solver.step_count}): {why}; "
            f"time step {dt:.4g} s, current stable limit {dts:.4g} s.")
    bad = _nonfinite_cell(solver, local)
    if bad is None:
        return Message(head, " Lower ", Arg("dt_safety"), " or raise ", Arg("steps"))
    ax = ("r", "z") if solver.kin.axisymmetric else ("x", "y", "z")[: solver.bs]
    where = f"({', '.join(ax)}) = ({', '.join(f'{x:.4g}' for x in bad[1])}) mm"
    return Message(head, f" The stress became non-finite in cell {bad[0]} (the mesh file's cell order; "
                   f"reference {where}): most likely the cell folded (inverted), which a smaller time step does "
                   "not prevent, nor mass scaling. Remedies: a finer mesh (", Arg("mesh"), ") or one graded "
                   "toward that cell; another element or material model (", Arg("element"), ", ",
                   Arg("material.model"), ") may follow the deformation further; element erosion (",
                   Arg("erosion_ratio"), ") removes such cells and goes on; a node passing a rigid support's "
                   "plane is stopped by a wall on every node (", Arg("add_wall"), ")")
