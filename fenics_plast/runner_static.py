"""Static analyses: load steps over a pseudo-time t with the SNES solver (see :mod:`fenics_plast.runner`),
on what :mod:`fenics_plast.build` builds from the scene.

Boundary values and tool paths are functions of t (the solver's load factor); each [steps.<name>]
ends at a pseudo-time where a converged state is reached exactly (profiles and fields are written
there); without [steps] the run goes from t = 0 to 1 in ``analysis.increments`` increments.
"""
from __future__ import annotations

import time
from types import SimpleNamespace

import numpy as np
import ufl

from fenics_plast.build import (body_material, boundaries, cell_regions, contact_pairs, tool_force_of,
                                tools_of)
from fenics_plast.errors import RunError
from fenics_plast.kinematics import Kinematics
from fenics_plast.errors import SceneError
from fenics_plast.schema import component_index
from fenics_plast.quadrature import von_mises
from fenics_plast.quantities import Body, Quantities
from fenics_plast.results import (checkpointer, contact_fields, draw_plots, open_fields, penetration_report,
                                  write_final_shape)
from fenics_plast.scene_mesh import read_mesh
from fenics_plast.solvers.static import StaticSolver


def ramp_end(problem, b, value) -> float | None:
    """The pseudo-time t_ramp over which a boundary value is ramped (from 0 at t = 0 to its full value
    at t_ramp, then held): the end of the first load step, for a value that does not depend on t and
    whose amplitude is "ramp" (the default); None: the value is applied as written."""
    if value.depends_on_time or b.get("amplitude") != "ramp":      # absent where amplitude does not apply
        return None
    return load_steps(problem)[0][1]


def _prescribed(value, t_ramp, since=0.0):
    """value(X (3, n), t) for StaticSolver.add_prescribed from a scene value (t = pseudo-time), ramped
    up to ``t_ramp`` (None: as written); ``since`` > 0: the displacement from its value at t = since
    (a mesh made at that load, whose reference is the deformed shape; the value does not depend on x, y,
    z then: validation's rule for [remeshing])."""
    def factor(t):
        return 1.0 if t_ramp is None else min(float(t) / t_ramp, 1.0)
    if value.constant is not None:
        c = float(value.constant)
        base = factor(since) if since > 0.0 else 0.0      # (from the reference: 0, whatever the amplitude)
        return lambda X, t: np.full(X.shape[1], c * (factor(t) - base))
    if since > 0.0:
        def at(t):
            return float(value.evaluate(t=t)) * factor(t)
        return lambda X, t: np.full(X.shape[1], at(t) - at(since))
    return lambda X, t: (np.asarray(value.evaluate(x=X[0], y=X[1], z=X[2], t=t), dtype=float) * factor(t)
                         * np.ones(X.shape[1]))


def _ramped_ufl(expr, t, t_ramp):
    """A UFL boundary value ramped up to ``t_ramp`` in the load Constant ``t`` (None: as written)."""
    return expr if t_ramp is None else expr * ufl.min_value(t / t_ramp, 1.0)


def apply_boundary(problem, s, ft, conditions, since=0.0):
    """Dirichlet conditions and dead loads of [boundary] (``conditions``: :func:`fenics_plast.build.boundaries`);
    returns {group: set of constrained components}. A value that does not depend on t is ramped over
    the first load step unless its amplitude is "step". ``since``: the load at which the mesh was made
    (prescribed displacements count from there)."""
    constrained: dict[str, set] = {}
    X = ufl.SpatialCoordinate(s.mesh)
    w = s.kin.weight
    gdim = s.kin.gdim
    coords = dict(x=X[0], y=X[1], z=X[2]) if gdim == 3 else dict(x=X[0], y=X[1])
    for b in conditions:
        tag, comps = b.tag, b.components
        if b.type in ("fixed", "axis", "symmetry"):
            for c in comps:
                s.add_dirichlet(c, ft, tag, 0.0)
        elif b.type == "displacement":
            for c, val in zip(comps, b.values):
                s.add_prescribed(c, ft, tag, _prescribed(val, ramp_end(problem, b.spec, val), since))
        elif b.type in ("traction", "pressure"):
            ds = ufl.Measure("ds", domain=s.mesh, subdomain_data=ft)(tag)
            t_ufl = s.load
            if b.type == "pressure":
                (value,) = b.values
                p = _ramped_ufl(value.to_ufl(**coords, t=t_ufl), t_ufl, ramp_end(problem, b.spec, value))
                traction = -p * ufl.FacetNormal(s.mesh)
            else:
                tv = [ufl.as_ufl(0.0)] * gdim
                for c, val in zip(comps, b.values):
                    tv[c] = _ramped_ufl(val.to_ufl(**coords, t=t_ufl), t_ufl, ramp_end(problem, b.spec, val))
                traction = ufl.as_vector(tv)
            s.add_residual(-ufl.dot(traction, s.v) * w * ds)
            continue
        else:
            raise SceneError(f"{b.where}.type = {b.type!r} is not available in static analyses")
        constrained.setdefault(b.group, set()).update(comps)
    return constrained


def reaction_dofs(problem, s, ft, groups, constrained):
    """Owned dofs of each reaction output; a dof also constrained in the same component by another
    group is left out (its reaction belongs to both and to neither, e.g. a corner on a symmetry line)."""
    out = {}
    for name, o in problem.outputs.items():
        if o.quantity != "reaction":
            continue
        c = component_index(o.component, problem.mesh.geometry)
        if c not in constrained.get(o.group, set()):
            raise SceneError(f"{problem.path}: outputs.{name}: group {o.group!r} has no boundary condition "
                             f"on component {o.component}: there is no reaction to record")
        dofs = s.constrained_dofs(c, ft, groups[o.group][1])
        for other, comps in constrained.items():
            if other != o.group and c in comps:
                dofs = np.setdiff1d(dofs, s.constrained_dofs(c, ft, groups[other][1]))
        out[(o.group, o.component)] = dofs.astype(np.int32)
    return out


def add_contact(s, ft, specs):
    """The contact pairs ``specs`` (name -> :class:`fenics_plast.build.ContactPair`) as terms of the solver:
    (the contact set or None when there are none, {name: pair})."""
    from fenics_plast.contact import PenaltyContact
    if not specs:
        return None, {}
    c = PenaltyContact(s)            # every pair carries its own penalty, friction and law
    pairs = {}
    for name, p in specs.items():
        if p.master_tag is not None:        # two facet groups of the body
            pairs[name] = c.add_surface_pair(ft, p.tag, p.master_tag, **p.options(), two_pass=p.two_pass,
                                             mirror_tags=p.mirror_tags, name=name)
        else:
            pairs[name] = c.add_pair(p.tool, ft, p.tag, **p.options())
    c.attach()
    return c, pairs


#: a penalty this many times above or below its pair's default is named as a likely cause of a failure
PENALTY_HINT_RATIO = 100.0


def _penalty_hint(b, pairs) -> str:
    """A sentence naming the contact pairs whose penalty is far from their default, with what the default
    would do at the last converged state (how deep the nodes would then be in, against the cells' depth), or
    "". A possible cause, not a diagnosis: too stiff makes Newton's systems ill-conditioned and its steps
    overshoot, too soft lets the body through; the same penalty that fails between two bodies may converge
    against a tool or with friction (issue 36: a kink of the master surface's normal was the cause there).
    Collective (the pairs' penetrations)."""
    hints = []
    b.solver.restore()              # (the last converged state, where the penetrations are measured)
    for n, p in pairs.items():
        spec = b.contact_pairs[n]
        ratio = p.penalty / spec.default_penalty
        if ratio > PENALTY_HINT_RATIO or ratio < 1.0 / PENALTY_HINT_RATIO:
            depth = p.max_penetration() * ratio
            hints.append(f"contact.{n}.penalty = {p.penalty:.3g} N/mm^3 is {ratio:.3g} times this pair's default "
                         f"({spec.default_penalty:.3g} N/mm^3, at which the nodes would be about {depth:.2g} mm in, "
                         f"{100 * depth / spec.depth:.2g} % of a cell's depth, at the last converged load)")
    return f" Possible cause: {'; '.join(hints)}." if hints else ""


def load_steps(problem) -> list[tuple[str, float, int, float]]:
    """[(name, end pseudo-time, initial increments, largest increment)] of the static steps."""
    ana = problem.analysis
    return [(n, st.end, st.increments or ana.increments, st.max_increment or ana.max_increment)
            for n, st in problem.steps.items()] or [("load", 1.0, ana.increments, ana.max_increment)]


def build_static(problem, comm, mesh_data=None, log=None, progress=None, since=0.0, penalties=None
                 ) -> SimpleNamespace:
    """The static solver of ``problem`` with its boundary conditions, loads and contact pairs, set
    up and ready to ``run``: a namespace of ``solver``, ``material``, ``tools``, ``contact`` (the
    contact set or None), ``pairs``, ``contact_pairs`` (name -> :class:`fenics_plast.build.ContactPair`:
    depth, default penalty), ``thermal`` (the heat conduction's
    :class:`fenics_plast.thermal.build.ThermalCoupling`, None without [thermal]), ``reactions``
    ((group, component) -> dofs), ``body``
    (:class:`Body`, on the collapsed displacement space), ``positions()`` (current node positions),
    mesh, cell_tags, facet_tags, groups. ``log``, ``progress``: as for :class:`StaticSolver`. A mesh made
    by remeshing at load ``since``: prescribed displacements count from there, and the contact pairs keep
    the first mesh's ``penalties`` ({pair: N/mm^3}: a default penalty is of the first mesh's cells)."""
    mesh, ct, ft, groups = mesh_data if mesh_data is not None else read_mesh(problem, comm)
    ana = problem.analysis
    material, _ = body_material(problem, ct, groups, mesh.topology.index_map(mesh.topology.dim).size_local)
    kin = Kinematics(mesh, problem.mesh.geometry)
    opts = dict(rtol=ana.rtol, atol=ana.atol, max_iterations=ana.max_iterations, linesearch=ana.linesearch,
                linear_solver=ana.linear_solver, linear_rtol=ana.linear_rtol,
                linear_max_iterations=ana.linear_max_iterations, jacobian_every=ana.jacobian_every,
                jacobian_rate=ana.jacobian_rate, predictor=ana.predictor)
    s = StaticSolver(kin, material, element=problem.mesh.element, log=log, progress=progress, **opts)
    s.time_scale = ana.duration or 0.0
    Vc, vmap = s.displacement_space()
    constrained = apply_boundary(problem, s, ft, boundaries(problem, Vc, ft, groups), since)
    tools = tools_of(problem, comm)
    specs = contact_pairs(problem, mesh, ft, groups, material, tools, penalties)
    contact, pairs = add_contact(s, ft, specs)
    s.setup()
    reactions = reaction_dofs(problem, s, ft, groups, constrained)

    gdim = kin.gdim
    X = Vc.tabulate_dof_coordinates()[:, :gdim].copy()

    def positions():
        return X + s.w.x.array[vmap].reshape(-1, gdim)

    tool_force = tool_force_of(problem, pairs, gdim)
    thermal = None
    if problem.thermal is not None:
        from fenics_plast.thermal.build import thermal_coupling
        thermal = thermal_coupling(problem, kin, s.u, s.qmap, material, ft, groups, ana.duration, Vc, pairs)

    def tool_translation(tool, t):
        return tools[tool].translation(t, use_ufl=False)

    body = Body(comm, Vc, X, positions, s.qmap, cell_regions(ct, groups, s.qmap.n_owned),
                reaction=s.reaction, tool_force=tool_force, tool_translation=tool_translation,
                geometry=problem.mesh.geometry,
                contact_force=lambda name: np.asarray(pairs[name].force()),
                contact_nodes=lambda name: pairs[name].contact_nodes(),
                heat=None if thermal is None else thermal.heat)
    return SimpleNamespace(solver=s, material=material, tools=tools, contact=contact, pairs=pairs, thermal=thermal,
                           contact_pairs=specs,
                           reactions=reactions, body=body, positions=positions, Vc=Vc, mesh=mesh, cell_tags=ct,
                           facet_tags=ft, groups=groups)


def run_static(problem, output, comm, mesh_data=None) -> dict:
    t_setup = time.perf_counter()
    steps = load_steps(problem)
    t_end = steps[-1][1]
    progress = output.progress(t_end, problem.name, what="t")
    if isinstance(mesh_data, SimpleNamespace):      # built by runner.prepare (before anything was written)
        b, t_setup = mesh_data, t_setup - mesh_data.setup_s
        b.solver.log_to, b.solver.progress = output.log, progress
    else:
        b = build_static(problem, comm, mesh_data, log=output.log, progress=progress)
    b.u_before = 0.0
    ana = problem.analysis
    remesher = None
    if problem.remeshing is not None:
        from fenics_plast.remeshing.remesher import Remesher
        remesher = Remesher(problem.remeshing, problem.mesh.geometry == "axisymmetric")
        remesher.initial_volumes = remesher.volumes(b.mesh, None, b.solver.qmap.degree, b.solver.qmap.state()["binv"])
    energy = None
    if any(o.quantity == "energy" for o in problem.outputs.values()):
        from fenics_plast.static_energy import StaticEnergy
        energy = StaticEnergy(b, problem.mesh.geometry == "axisymmetric")
        b.body.energies = energy.energies
    run = SimpleNamespace(b=b, quantities=Quantities(problem.outputs, b.body, b.facet_tags, b.groups, b.reactions),
                          xf=None, remesh_reason="")
    cells = b.mesh.topology.index_map(b.mesh.topology.dim).size_global
    output.log(f"{problem.name}: {cells} cells, {b.solver.dofs} dofs, element {problem.mesh.element}, "
               f"linear solver {b.solver.linear_solver_text}, "
               f"physics {', '.join(problem.active_physics) or 'elastic'}, set-up {time.perf_counter() - t_setup:.1f} s")

    fields = {}                 # the state's cell means (QuadratureMap.fields), then von_mises_stress
    state = dict(count=0)
    ck = checkpointer(problem, output, comm)
    saved = ck.load() if ck is not None and ck.resuming else None
    if saved is not None and saved["runner"].get("remesh"):
        # a checkpoint of a remeshed body: its mesh again, the solver built on it
        from fenics_plast.runner_static_remesh import resumed_build
        b = resumed_build(problem, comm, b, saved, remesher, build_static, output.log, progress)
        if energy is not None:
            energy.remeshed(b, energy.elastic())
            b.body.energies = energy.energies
        run.b, run.quantities = b, Quantities(problem.outputs, b.body, b.facet_tags, b.groups, b.reactions)
    run.xf = open_fields(problem, output, comm, b.mesh)

    def remesh_columns():
        return {} if remesher is None else dict(remeshes=remesher.count)

    def time_columns(t):
        """The physical time [s] of pseudo-time t, in a run that has one (analysis.duration)."""
        return {} if ana.duration is None else dict(time_s=t * ana.duration)

    def write_fields(t):
        if run.xf is None:
            return
        s = run.b.solver
        q = s.qmap
        q.fields(out=fields)
        fields["von_mises_stress"] = q.cell_mean(von_mises(q.tau_values, s.qp_jacobian()), name="von_mises_stress",
                                                 out=fields.get("von_mises_stress"))
        run.xf.write_function(s.displacement_function(), t)
        for name, f in fields.items():
            # (with [thermal] the points' temperature of a Johnson-Cook law is the nodal field's, written as such)
            if name != "temperature" or run.b.thermal is None:
                run.xf.write_function(f, t)
        for f in contact_fields(run.b, run.b.Vc):
            run.xf.write_function(f, t)
        if run.b.thermal is not None:
            run.xf.write_function(run.b.thermal.heat.T, t)

    loop = None
    if saved is not None:
        b.solver.restart.load_state(saved["solver"])
        if b.contact is not None:
            b.contact.load_state(saved["contact"])
        if b.thermal is not None:
            b.thermal.load_state(saved["thermal"])
        r = saved["runner"]
        quantities = run.quantities
        quantities.history, quantities.times, state["count"] = r["history"], r["times"], r["count"]
        quantities.profiles = {k: [(t, np.asarray(a), np.asarray(b)) for t, a, b in v] for k, v in r["profiles"].items()}
        loop = saved["loop"]
        if energy is not None:
            energy.W_int, energy.W_tool, energy.W_bc, energy.W_c = r["energy"]
            energy.resumed()
        output.log(f"{problem.name}: resumed at increment {len(b.solver.increments)}, t = {b.solver.lam_converged:.6g}")
    else:
        output.history(increment=0, time=0.0, **time_columns(0.0), **run.quantities.row(0.0), newton_iterations=0,
                       **remesh_columns())
        write_fields(0.0)

    def on_checkpoint(solver, loop_state):
        quantities = run.quantities
        remeshed_body = remesher is not None and remesher.count > 0
        remesh_entry = remesh_state = None
        if remeshed_body:
            from fenics_plast.remeshing.resume import checkpoint_groups
            remesh_entry, remesh_state = checkpoint_groups(run.b, remesher, run.b.Vc, since=run.b.since,
                                                           penalties={n: p.penalty for n, p in run.b.pairs.items()})
        ck.save(len(solver.increments), solver=solver.restart.state_dict(),
                contact=run.b.contact.state_dict() if run.b.contact is not None else {}, loop=loop_state,
                runner=dict(history=quantities.history, times=quantities.times, count=state["count"],
                            energy=[] if energy is None else [energy.W_int, energy.W_tool, energy.W_bc, energy.W_c],
                            profiles={k: [(t, list(a), list(b)) for t, a, b in v]
                                      for k, v in quantities.profiles.items()},
                            remesh=remesh_entry),
                **({"remesh_state": remesh_state} if remeshed_body else {}),
                **({} if run.b.thermal is None else {"thermal": run.b.thermal.state_dict()}))
    ck_args = {} if ck is None else dict(checkpoint_every=ck.every, on_checkpoint=on_checkpoint)

    def make_callback(step_end):
        def on_increment(solver):
            if run.b.thermal is not None:       # (before the commit: the friction's dissipation since the last)
                run.b.thermal.after_increment(solver.lam_converged)
            contact = run.b.contact
            if contact is not None:
                contact.commit()
            rec = solver.increments[-1]
            t = solver.lam_converged
            if energy is not None:
                energy.update()
            output.history(increment=rec["increment"], time=t, **time_columns(t), **run.quantities.row(t),
                           newton_iterations=rec["iterations"], **remesh_columns())
            if abs(t - step_end) <= 1e-12 * max(1.0, step_end):
                run.quantities.record_profiles(t)
            state["count"] += 1
            if state["count"] % problem.output.every == 0 or abs(t - t_end) <= 1e-12 * max(1.0, t_end):
                write_fields(t)
            if remesher is not None and t < t_end - 1e-12 * max(1.0, t_end):
                from fenics_plast.remeshing.quality import deformed_nodes
                run.remesh_reason = remesher.due(run.b.mesh, deformed_nodes(solver.displacement_function()))
                return bool(run.remesh_reason)
            return False
        return on_increment

    def remesh(reason):
        stop = remesher.check_budget()
        if stop:
            raise RunError(stop)
        old = run.b
        elastic_old = energy.elastic() if energy is not None else 0.0
        from fenics_plast.remeshing.new_mesh import RemeshError
        from fenics_plast.runner_static_remesh import remeshed
        try:
            nb, rec, before = remeshed(problem, comm, old, remesher, reason, run.quantities, build_static,
                                       log=output.log, progress=progress)
        except RemeshError as e:
            raise RunError(f"remesh {remesher.count} at t = {old.solver.lam_converged:.6g} failed: {e}") from None
        if energy is not None:
            energy.remeshed(nb, elastic_old)
            nb.body.energies = energy.energies
        q = Quantities(problem.outputs, nb.body, nb.facet_tags, nb.groups, nb.reactions)
        q.history, q.times, q.profiles = run.quantities.history, run.quantities.times, run.quantities.profiles
        after = q.one_column_values(nb.solver.lam_converged)
        rec.jump = {k: (before[k], after[k]) for k in before}
        run.b, run.quantities = nb, q
        output.log(rec.line())
        fields.clear()              # (functions on the old mesh)
        if run.xf is not None:
            run.xf.close()
            run.xf = open_fields(problem, output, comm, nb.mesh, name=f"fields_remesh{rec.number}")
            write_fields(nb.solver.lam_converged)

    def results(converged):
        s, pairs = run.b.solver, run.b.pairs
        res = run.quantities.summary("t")
        res.update(run.quantities.study_keys())
        res.update(cells=run.b.mesh.topology.index_map(run.b.mesh.topology.dim).size_global, dofs=s.dofs,
                   converged=converged, increments=len(s.increments),
                   newton_iterations=s.total_iterations, cutbacks=len(s.cutbacks),
                   linesearch_retries=len(s.linesearch_retries), element=problem.mesh.element,
                   final_time=s.lam_converged, jacobians=s.jacobians, solve_time_s=time.perf_counter() - t_solve,
                   solver_times_s={k: round(v, 4) for k, v in s.times.items()})
        if energy is not None:
            e = energy.energies()
            res.update(energy_balance_error=e["balance_error"], contact_work_J=e["contact_work"] * 1e-3,
                       tool_work_J=e["tool_work"] * 1e-3, plastic_dissipation_J=e["plastic"] * 1e-3)
            w_p = energy.plastic_from_state()
            if w_p is not None:
                res["plastic_dissipation_from_eqps_J"] = w_p * 1e-3
        if run.b.thermal is not None:
            res.update(heat_steps=run.b.thermal.heat.steps, heat_time_s=run.b.thermal.heat.time)
        if remesher is not None:
            from fenics_plast.remeshing.quality import deformed_nodes
            last = remesher.volumes(run.b.mesh, deformed_nodes(s.displacement_function()), s.qmap.degree,
                                    s.qmap.state()["binv"])
            res.update(remesher.summary((remesher.initial_volumes, last)))
        if pairs:
            res["max_penetration_mm"] = max(p.max_penetration() for p in pairs.values())
            warnings = []
            for n, p in pairs.items():
                res[f"penalty_{n}_N_mm3"] = p.penalty
                spec = run.b.contact_pairs[n]
                report = penetration_report(n, p.max_penetration(), spec.depth, p.penalty, spec.default_penalty, comm)
                warnings += report.pop("warnings")
                res.update(report)
            if warnings:
                res["warnings"] = warnings
        return res

    def finish():
        quantities = run.quantities
        for name in quantities.profiles:
            if quantities.profiles[name]:
                output.write_csv(name, quantities.profile_table(name))
        write_final_shape(problem, output, run.b.Vc, run.b.positions(), run.b.solver.qmap, run.b.thermal)
        draw_plots(problem, output)

    t_solve = time.perf_counter()
    try:
        for name, end, increments, max_increment in steps:
            resume = loop
            while run.b.solver.lam_converged < end - 1e-12 * max(1.0, end):
                s = run.b.solver
                try:
                    if s.run(increments=increments, min_increment=ana.min_increment, max_increment=max_increment,
                             lam_end=end, callback=make_callback(end), resume=resume,
                             fast_iterations=ana.fast_iterations, **ck_args):
                        break
                    reason = run.remesh_reason
                except RunError as e:
                    if remesher is None or remesher.increments_since == 0:
                        raise
                    reason = f"no convergence at t = {s.lam_converged:.6g}+"
                    output.log(f"{problem.name}: {e}")
                remesh(reason)
                last = run.b.solver.increments[-1]["step"] if run.b.solver.increments else None
                resume = None if last is None else dict(dl=last, prev_step=None, lam_end=end)
    except RunError as e:
        s = run.b.solver
        run.quantities.record_profiles(s.lam_converged)
        e.results.update(results(False))
        finish()
        raise RunError(f"{problem.name}: stopped at t = {s.lam_converged:.6g}. {e}{_penalty_hint(run.b, run.b.pairs)}",
                       results=e.results) from None
    finally:
        fields.clear()              # (functions on the old mesh)
        if run.xf is not None:
            run.xf.close()
    finish()
    return results(True)


__all__ = ["run_static", "build_static", "apply_boundary", "reaction_dofs", "add_contact"]
