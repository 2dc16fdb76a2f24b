"""Explicit analyses: central differences with a lumped mass (see :mod:`fenics_plast.runner`), on what
:mod:`fenics_plast.build` builds from the scene.

Boundary conditions are velocity constraints: ``fixed``, ``axis`` and ``symmetry`` hold components
at zero velocity (sliding supports; in 3-D scenes, ``problem.mesh.geometry == "3d"`` on a hexahedral
mesh, components x, y, z and symmetry planes normal to x, y or z, as :func:`fenics_plast.build.boundaries`
resolves them); ``velocity`` and ``displacement`` prescribe a component as a function of time.
``traction`` is a dead load, uniform over its group (validation refuses pressure and values of x, y,
z). ``wall`` is a rigid plane the nodes cannot pass (:mod:`fenics_plast.solvers.walls`). Times in
scene files are in µs, seconds inside (the build converts the scene's values; results are written
in µs again).
History rows are ``output.history_points`` equally spaced times (time_us + the declared outputs).
"""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
from dolfinx import fem
from mpi4py import MPI

from fenics_plast import dolfinx_compat as dc
from fenics_plast.build import (body_material, boundaries, cell_regions, contact_pairs, initial_velocity_field,
                                tool_force_of, tools_of)
from fenics_plast.kinematics import Kinematics
from fenics_plast.errors import RunError, SceneError, Terms
from fenics_plast.schema import US, key
from fenics_plast.quantities import Body, Quantities
from fenics_plast.results import (checkpointer, contact_fields, draw_plots, open_fields, penetration_report,
                                  write_final_shape)
from fenics_plast.scene_mesh import read_mesh
from fenics_plast.solvers.collapse import TimeStepCollapse
from fenics_plast.solvers.explicit import ExplicitDynamics

#: added mass (fraction of the body's) above which the run log warns
MASS_WARNING = 0.05


class SceneTerms(Terms):
    """The solver's messages in the scene's words: each argument of the explicit solver named in
    them (:class:`~fenics_plast.errors.Arg`) as the scene key or phrase that sets it, its values in
    that key's units (the schema's ``scale``: µs for times), ``--set key=value`` to set one."""

    #: solver argument -> what sets it in a scene file
    KEYS = {"dt_safety": "analysis.dt_safety", "steps": "analysis.time_steps", "dt_floor": "analysis.dt_floor",
            "mass_scaling_dt": "analysis.mass_scaling_dt", "stable_step": "analysis.stable_step",
            "erosion_ratio": "analysis.erosion_ratio", "element": "mesh.element", "mesh": "mesh.refine",
            "material.model": "materials.<name>.model", "add_wall": "boundary type 'wall'"}

    def name(self, arg):
        return self.KEYS[arg.name]

    def scale_unit(self, arg):
        k = key(self.KEYS[arg.name])
        return k.scale, k.unit.replace("µ", "u")

    def setting(self, arg, value):
        return f"--set {self.name(arg)}={value}"


#: how the driver words the solver's messages (``RunError.worded``)
SCENE_TERMS = SceneTerms()


def velocity_constraints(conditions):
    """Homogeneous velocity constraints [(component, facets)], the prescribed motions [(component,
    facets, kind, function of t [s] in mm/s or mm)] and the loads [Boundary] of ``conditions``
    (:func:`fenics_plast.build.boundaries`; walls: :func:`add_walls`)."""
    zero, moving, loads = [], [], []
    for b in conditions:
        if b.type == "wall":
            continue
        if b.type in ("fixed", "axis", "symmetry"):
            zero += [(c, b.facets) for c in b.components]
        elif b.type in ("velocity", "displacement"):
            for c, val, f in zip(b.components, b.values, b.of_seconds()):
                if b.type == "velocity" and val.constant == 0.0:
                    zero.append((c, b.facets))
                else:
                    moving.append((c, b.facets, b.type, f))
        else:
            loads.append(b)
    return zero, moving, loads


def add_walls(problem, solver, conditions):
    """The rigid walls of ``conditions`` (type "wall") on ``solver``: every node, or the nodes of the
    wall's facet group."""
    for b in conditions:
        if b.type != "wall":
            continue
        nodes = None
        if b.facets is not None:
            nodes = fem.locate_dofs_topological(solver.V, solver.mesh.topology.dim - 1, b.facets)
        try:
            solver.add_wall(b.components[0], b.spec.position, nodes, name=f"boundary.{b.name}")
        except ValueError as e:
            raise SceneError(f"{problem.path}: {e}") from None


#: a run whose settings imply more time steps than this is announced with a warning (at ~1e5 steps a
#: minute on a small mesh, 1e7 steps are hours)
MANY_STEPS = 10 ** 7


def estimated_steps(problem, solver) -> float:
    """The number of time steps the run will take (collective): analysis.time_steps, or end_time over
    dt_safety x the initial stable step (cells and contact springs; or mass_scaling_dt where larger). A
    fixed step above the stable limit refuses the scene (SceneError)."""
    ana = problem.analysis
    dt_stable = solver.stable_dt()
    if ana.time_steps is not None:
        dt = ana.end_time / ana.time_steps
        if dt > dt_stable:
            raise SceneError(
                f"{problem.path}: analysis.time_steps = {ana.time_steps}: the time step end_time/time_steps = "
                f"{dt:.4g} s exceeds the stable limit {dt_stable:.4g} s "
                f"({solver.cell_steps.limit_text(dt_stable)}); use at "
                f"least {math.ceil(ana.end_time / dt_stable)} steps or drop analysis.time_steps")
        return float(ana.time_steps)
    return math.ceil(ana.end_time / (ana.dt_safety * max(dt_stable, ana.mass_scaling_dt)) - 1e-9)


def checked_steps(problem, solver) -> int:
    """The number of history rows of the run (collective): ``output.history_points``, capped at one
    per time step (:func:`estimated_steps`: rows closer than a step would force shorter steps)."""
    return int(min(problem.output.history_points, max(estimated_steps(problem, solver), 1) + 1))


def many_steps_warning(problem, solver) -> str | None:
    """A warning when the settings imply more than :data:`MANY_STEPS` time steps (collective), naming
    what sets the step (dt_safety, the stable step of the cells, a contact penalty)."""
    steps = estimated_steps(problem, solver)
    if steps <= MANY_STEPS:
        return None
    ana = problem.analysis
    dt_cells, dt = solver.cell_steps.stable_dt(), solver.stable_dt()
    why = [f"analysis.dt_safety = {ana.dt_safety:g}"] if ana.time_steps is None else []
    why.append(f"the stable step {dt:.3g} s" + (f" (the contact penalties' springs; the cells' alone: {dt_cells:.3g} s)"
                                                if dt < 0.5 * dt_cells else ""))
    return (f"warning: {problem.path}: about {steps:.3g} time steps to analysis.end_time ({', '.join(why)}): "
            f"such a run takes hours or days; check dt_safety, the contact penalties and the smallest cell")


def build_explicit(problem, comm, mesh_data=None, log=None) -> SimpleNamespace:
    """The explicit solver of ``problem`` with its constraints, loads, contact pairs and initial
    velocity, ready to ``run``: a namespace of ``solver``, ``material``, ``tools`` (name -> tool),
    ``pairs`` (contact name -> pair), ``contact_pairs`` (name -> :class:`fenics_plast.build.ContactPair`:
    depth, default penalty), ``thermal`` (with [thermal]: the heat conduction's
    :class:`fenics_plast.thermal.build.ThermalCoupling`, stepped at each history row; else None), ``body``
    (:class:`Body`), mesh, cell_tags, facet_tags, groups.
    ``log``: progress lines (None: quiet)."""
    mesh, ct, ft, groups = mesh_data if mesh_data is not None else read_mesh(problem, comm)
    ana = problem.analysis
    material, density = body_material(problem, ct, groups, mesh.topology.index_map(mesh.topology.dim).size_local)
    kin = Kinematics(mesh, problem.mesh.geometry)
    conditions = boundaries(problem, dc.vector_space(mesh), ft, groups)
    zero, moving, loads = velocity_constraints(conditions)
    solver = ExplicitDynamics(mesh, kin, material, density, zero, element=problem.mesh.element,
                              log=log if log is not None else (lambda m: None), internal_force=ana.internal_force,
                              stable_step=ana.stable_step, erosion_ratio=ana.erosion_ratio)
    add_walls(problem, solver, conditions)
    for c, facets, kind, f in moving:           # f: of t [s], in mm/s or mm (build.time_function)
        dofs = fem.locate_dofs_topological(solver.V, mesh.topology.dim - 1, facets)
        if kind == "velocity":
            solver.add_prescribed_velocity(c, dofs, f)
        else:
            solver.add_prescribed_displacement(c, dofs, f)
    for b in loads:                             # uniform tractions (validation), of t [s] in MPa
        fns = [None] * solver.bs
        for c, f in zip(b.components, b.of_seconds()):
            fns[c] = f
        solver.add_traction(ft, b.tag, tuple(fn or (lambda t: 0.0) for fn in fns))
    tools = tools_of(problem, comm)
    specs = contact_pairs(problem, mesh, ft, groups, material, tools)
    pairs = {name: solver.add_contact(p.tool, ft, p.tag, **p.options()) if p.master_tag is None else
             solver.add_surface_contact(ft, p.tag, p.master_tag, two_pass=p.two_pass, **p.options(),
                                        mirror_tags=p.mirror_tags, name=name)
             for name, p in specs.items()}
    # per node (regions, expressions of x, y, z) [mm/s]
    solver.set_velocity(initial_velocity_field(problem, solver.V, ct, groups))

    # what the automatic quantities read (quantities/kinds/mass_scaling.py, wall_energy.py, erosion.py)
    cs = solver.cell_steps
    scaling = SimpleNamespace(stats=cs.mass_scaling_stats, target_us=ana.mass_scaling_dt / US) \
        if ana.mass_scaling_dt > 0.0 else None
    erosion = SimpleNamespace(stats=cs.erosion_stats, ratio=solver.erosion_ratio, cells=cs.eroded_cells) \
        if solver.erosion_ratio > 0.0 else None
    thermal = None
    if problem.thermal is not None:     # a heat step at every history row (on_row), over its time [s]
        from fenics_plast.thermal.build import thermal_coupling
        thermal = thermal_coupling(problem, kin, solver.u, solver.qmap, material, ft, groups, duration=1.0)
    body = Body(comm, solver.V, solver.reference_positions, solver.nodal_positions, solver.qmap,
                cell_regions(ct, groups, solver.qmap.n_owned), tool_force=tool_force_of(problem, pairs, solver.bs),
                energies=solver.energies, tool_translation=lambda tool, t: tools[tool].translation(t, use_ufl=False),
                geometry=problem.mesh.geometry, mass_scaling=scaling, erosion=erosion,
                wall_energy=solver.walls.energy if solver.walls.active else None,
                contact_force=lambda name: np.asarray(pairs[name].force()),
                contact_nodes=lambda name: pairs[name].contact_nodes(),
                heat=None if thermal is None else thermal.heat)
    return SimpleNamespace(solver=solver, material=material, tools=tools, pairs=pairs, contact_pairs=specs, thermal=thermal,
                           body=body, mesh=mesh, cell_tags=ct, facet_tags=ft, groups=groups)


def run_explicit(problem, output, comm, mesh_data=None) -> dict:
    if isinstance(mesh_data, SimpleNamespace):      # built by runner.prepare (before anything was written)
        b = mesh_data
        b.solver.log = output.log
    else:
        b = build_explicit(problem, comm, mesh_data, log=output.log)
    b.u_before = 0.0
    ana = problem.analysis
    remesher = None
    if problem.remeshing is not None:
        from fenics_plast.remeshing.remesher import Remesher
        remesher = Remesher(problem.remeshing, problem.mesh.geometry == "axisymmetric")
        remesher.initial_volumes = remesher.volumes(b.mesh, None, b.solver.qmap.degree, b.solver.qmap.state()["binv"])
    run = SimpleNamespace(b=b, quantities=Quantities(problem.outputs, b.body, b.facet_tags, b.groups), xf=None,
                          remesh_reason="")
    end_time = ana.end_time
    rows = b.history_rows if "history_rows" in vars(b) else checked_steps(problem, b.solver)
    if rows < problem.output.history_points:
        output.log(f"{problem.name}: output.history_points = {problem.output.history_points} is more than the run's "
                   f"about {rows - 1} time steps: {rows} history rows (one per step at most)")
    every = int(problem.output.every)
    run.xf = open_fields(problem, output, comm, b.mesh)
    state = dict(row=0, fields={})

    ck = checkpointer(problem, output, comm)
    loop = None
    if ck is not None and ck.resuming:
        saved = ck.load()
        if saved["runner"].get("remesh"):
            # a checkpoint of a remeshed body: its mesh again, the solver built on it
            from fenics_plast.remeshing.resume import restore_u_before, resumed_mesh
            new, _ = resumed_mesh(comm, saved, remesher)
            nb = build_explicit(problem, comm, tuple(new), log=output.log)
            restore_u_before(nb, nb.solver.V, saved, new)
            if run.xf is not None:
                run.xf.close()
                run.xf = open_fields(problem, output, comm, nb.mesh)
            b = run.b = nb
            run.quantities = Quantities(problem.outputs, nb.body, nb.facet_tags, nb.groups)
        b.solver.restart.load_state(saved["solver"])
        if b.thermal is not None:
            b.thermal.load_state(saved["thermal"])
        r = saved["runner"]
        quantities = run.quantities
        quantities.history, quantities.times, state["row"] = r["history"], r["times"], r["row"]
        loop = saved["loop"]
        output.log(f"{problem.name}: resumed at step {b.solver.step_count}, t = {b.solver.t / US:.4g} us")

    def on_checkpoint(s, loop_state):
        entry, keyed = None, {}
        if remesher is not None and remesher.count:
            from fenics_plast.remeshing.resume import checkpoint_groups
            entry, keyed = checkpoint_groups(run.b, remesher, s.V)
            keyed = {"remesh_state": keyed}
        ck.save(s.step_count, solver=s.restart.state_dict(), loop=loop_state,
                runner=dict(history=run.quantities.history, times=run.quantities.times, row=state["row"],
                            remesh=entry), **keyed,
                **({} if run.b.thermal is None else {"thermal": run.b.thermal.state_dict()}))

    scaling = ana.mass_scaling_dt > 0.0

    def on_row(s, t):
        # (a stop right after landing on a row time writes the fields only, not a second row)
        quantities, xf = run.quantities, run.xf
        if run.b.thermal is not None and t > run.b.thermal.t_last:
            run.b.thermal.after_increment(t)    # (the heat step over the row's time, staggered)
        if not (state.get("stop") and quantities.times and t / US <= quantities.times[-1]):
            cols = quantities.row(t / US)          # the declared outputs, then the automatic ones
            if scaling:
                if cols["added_mass_fraction"] > MASS_WARNING and not state.get("mass_warned"):
                    state["mass_warned"] = True
                    output.log(f"warning: at t = {t / US:.4g} us selective mass scaling has added "
                               f"{100 * cols['added_mass_fraction']:.3g} % of the body's mass (to "
                               f"{cols['mass_scaled_cells']} cells): the answer may be another body's; a "
                               f"smaller analysis.mass_scaling_dt adds less")
            if remesher is not None:
                cols["remeshes"] = remesher.count
            nonfinite_guard(cols, f"{problem.name}: history row at t = {t / US:.6g} us")
            output.history(time_us=t / US, **cols)
        # (a stop where fields were just written, e.g. a fold in the first step, writes none again)
        if xf is not None and (state["row"] % every == 0 or t >= end_time * (1 - 1e-12) or state.get("stop")) \
                and state.get("fields_t") != t:
            write_fields(s, t)
        state["row"] += 1

    def write_fields(s, t):
        state["fields_t"] = t
        fields_guard(s, f"{problem.name}: fields at t = {t / US:.6g} us")
        run.xf.write_function(s.u, t / US)
        for name, f in s.qmap.fields(out=state["fields"]).items():     # eqps, temperature (Johnson-Cook) [K]
            # (with [thermal] the points' temperature of a Johnson-Cook law is the nodal field's, written as such)
            if name != "temperature" or run.b.thermal is None:
                run.xf.write_function(f, t / US)
        if run.b.thermal is not None:
            run.xf.write_function(run.b.thermal.heat.T, t / US)
        for f in contact_fields(run.b, s.V):
            run.xf.write_function(f, t / US)
        if s.erosion_ratio > 0.0:   # 1 on the eroded cells (a Threshold in ParaView hides them)
            state["eroded"] = eroded_field(s, state.get("eroded"))
            run.xf.write_function(state["eroded"], t / US)

    def on_check(s):
        from fenics_plast.remeshing.quality import deformed_nodes
        s.u.x.scatter_forward()         # (the ghost nodes' displacements, which the cells' shapes need)
        run.remesh_reason = remesher.due(run.b.mesh, deformed_nodes(s.u))
        return bool(run.remesh_reason)

    def remesh(reason):
        stop = remesher.check_budget()
        if stop:
            raise RunError(stop)
        from fenics_plast.remeshing.new_mesh import RemeshError
        from fenics_plast.runner_explicit_remesh import remeshed_explicit
        try:
            nb, rec, before = remeshed_explicit(problem, comm, run.b, remesher, reason, run.quantities, build_explicit)
        except RemeshError as e:
            raise RunError(f"remesh {remesher.count} at t = {run.b.solver.t / US:.4g} us failed: {e}") from None
        q = Quantities(problem.outputs, nb.body, nb.facet_tags, nb.groups)
        q.history, q.times, q.profiles = run.quantities.history, run.quantities.times, run.quantities.profiles
        after = q.one_column_values(nb.solver.t / US)
        rec.jump = {k: (before[k], after[k]) for k in before}
        run.b, run.quantities = nb, q
        output.log(rec.line())
        state["fields"] = {}
        state.pop("eroded", None)
        if run.xf is not None:
            run.xf.close()
            run.xf = open_fields(problem, output, comm, nb.mesh, name=f"fields_remesh{rec.number}")
            write_fields(nb.solver, nb.solver.t)

    bar = output.progress(end_time / US, problem.name, what="t", unit="us")
    ck_args = {} if ck is None else dict(checkpoint_every=ck.every, on_checkpoint=on_checkpoint)
    stop = None
    earlier_wall_s = 0.0            # the step loops of the meshes before the last (a remeshed run)
    try:
        while True:
            solver = run.b.solver
            try:
                stats = solver.run(end_time, dt_safety=ana.dt_safety, steps=ana.time_steps, rows=rows, on_row=on_row,
                                   bar=bar, dt_floor=ana.dt_floor, mass_scaling_dt=ana.mass_scaling_dt, resume=loop,
                                   on_check=on_check if remesher is not None else None, **ck_args)
                if "loop" not in stats:
                    break
                loop, reason = stats["loop"], run.remesh_reason
            except TimeStepCollapse as e:
                if remesher is None or remesher.increments_since == 0 or e.loop is None:
                    if e.stats is not None:
                        e.stats["wall_s"] += earlier_wall_s
                    raise
                stats, loop, reason = e.stats, e.loop, f"a cell would fold at t = {solver.t / US:.4g} us"
            earlier_wall_s += stats["wall_s"]
            remesh(reason)
        stats["wall_s"] += earlier_wall_s
        stats["time_per_step_s"] = stats["wall_s"] / max(solver.step_count, 1)
    except TimeStepCollapse as e:
        # the state at the stop is sound: a last history row, the fields and a checkpoint there
        stop, stats = e, e.stats
        state["stop"] = True
        on_row(run.b.solver, run.b.solver.t)
        if ck is not None:
            on_checkpoint(run.b.solver, e.loop)
    except RunError as e:
        # gone unstable (non-finite): the outputs of the history rows so far, not of the state now
        solver = run.b.solver
        e.results.update(run.quantities.summary("time_us"))
        e.results.update(run.quantities.study_keys())
        e.results.update(stopped_at_us=solver.t / US, steps=solver.step_count, cells=solver.cells_global,
                         dofs=solver.dofs_global, converged=False)
        e.results.update(run.quantities.automatic_summary(failed=True))
        if remesher is not None:
            e.results.update(remesher.summary())
        raise e.reword(SCENE_TERMS)
    finally:
        if run.xf is not None:
            run.xf.close()
    solver, pairs, quantities = run.b.solver, run.b.pairs, run.quantities
    res = quantities.summary("time_us")
    res.update(quantities.study_keys(automatic=True))
    e = solver.energies()
    res.update(energy_balance_error=e["balance_error"], steps=stats["steps"], dt_s=stats["dt_max"],
               dt_min_s=stats["dt_min"], dt_stable_initial_s=stats["dt_stable_initial"],
               dt_stable_final_s=stats["dt_stable_final"], wave_speed_m_s=solver.c * 1e-3,
               element=solver.element, model=run.b.material.model, internal_force=solver.internal_force_route,
               step_loop_time_s=stats["wall_s"], time_per_step_s=stats["time_per_step_s"],
               setup_time_s=solver.timings["setup_s"], cells=solver.cells_global, dofs=solver.dofs_global,
               converged=stop is None)
    res.update(quantities.automatic_summary())      # mass scaling, walls, erosion: when the run has them
    if run.b.thermal is not None:
        res.update(heat_steps=run.b.thermal.heat.steps, heat_time_s=run.b.thermal.heat.time)
    if remesher is not None:
        from fenics_plast.remeshing.quality import deformed_nodes
        last = remesher.volumes(run.b.mesh, deformed_nodes(solver.u), solver.qmap.degree, solver.qmap.state()["binv"])
        res.update(remesher.summary((remesher.initial_volumes, last)))
    if pairs:
        # the contact terms of the balance (energy_balance_error includes them) and, per pair, the
        # largest penetration of the run and its penalty; the springs' stable-step limit (collective calls)
        res.update(contact_work_J=e["contact_work"] * 1e-3, contact_stored_J=e["contact_stored"] * 1e-3,
                   tool_work_J=e["tool_work"] * 1e-3, dt_stable_contact_s=solver.contact.dt_stable)
        warnings = []
        for name, p in pairs.items():
            res[f"{name}_max_penetration_mm"] = p.max_penetration_run()
            res[f"{name}_penalty_N_mm3"] = p.penalty
            spec = run.b.contact_pairs[name]
            report = penetration_report(name, res[f"{name}_max_penetration_mm"], spec.depth, p.penalty,
                                        spec.default_penalty, comm)
            warnings += report.pop("warnings")
            res.update(report)
        if warnings:
            res["warnings"] = warnings
    nonfinite_guard(res, f"{problem.name}: results")
    write_final_shape(problem, output, solver.V, solver.nodal_positions(), solver.qmap, run.b.thermal)
    draw_plots(problem, output)
    if stop is not None:
        res.update(stop.results)
        raise RunError(f"{problem.name}: {stop.worded(SCENE_TERMS)}", results=res)
    return res


def nonfinite_guard(values: dict, where: str):
    """The last line against a non-finite number in a result file: a RunError (a failed run, exit 1)
    naming the entries of ``values`` (name -> number; other entries are not looked at) that are not
    finite, instead of writing them. The solver stops at its last finite state before that (a fold,
    :class:`~fenics_plast.solvers.collapse.CellFold`), so this is a defect's report."""
    bad = [k for k, x in values.items() if isinstance(x, (float, np.floating)) and not np.isfinite(x)]
    if bad:
        raise RunError(f"{where}: {', '.join(bad)} not finite, not written (the explicit solver should have "
                       f"stopped at its last finite state: a defect, please report it with the scene)")


def fields_guard(solver, where: str):
    """:func:`nonfinite_guard` for the fields written (displacement, the written state variables:
    their sources; collective)."""
    arrays = [solver.u.x.array] + [getattr(solver.qmap, v.name) for v in solver.qmap.variables if v.output]
    bad = not all(np.isfinite(a).all() for a in arrays)
    if solver.comm.size > 1:
        bad = solver.comm.allreduce(bad, op=MPI.LOR)
    if bad:
        raise RunError(f"{where}: a field value is not finite, not written (the explicit solver should have "
                       f"stopped at its last finite state: a defect, please report it with the scene)")


def eroded_field(solver, out=None):
    """DG0 function "eroded": 1 on the eroded cells, 0 elsewhere (``out``: reused)."""
    if out is None:
        out = fem.Function(dc.function_space(solver.mesh, "DG", 0), name="eroded")
    dofs = dc.cell_dofs(out.function_space).reshape(-1)[: solver.n_cells_own]
    out.x.array[dofs] = (solver.alive == 0).astype(float)
    out.x.scatter_forward()
    return out


__all__ = ["run_explicit", "SceneTerms", "SCENE_TERMS", "checked_steps", "estimated_steps", "many_steps_warning",
           "MANY_STEPS", "velocity_constraints", "add_walls", "nonfinite_guard", "fields_guard"]
