"""The static runner's remeshing (issue 35): a run built by :func:`fenics_plast.runner_static.build_static`
on a new mesh of its deformed outline (:func:`remeshed`: the state transferred, the solver built anew at
the same load, the contact history carried, equilibrium restored), and the build of a checkpoint written
on a remeshed body (:func:`resumed_build`). The decision and the new mesh are the solver-independent
:class:`fenics_plast.remeshing.remesher.Remesher`'s; :func:`fenics_plast.runner_static.run_static` calls
these between its load steps' increments.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from fenics_plast.errors import RunError

__all__ = ["remeshed", "resumed_build"]


def remeshed(problem, comm, b, remesher, reason, quantities, build, log=None, progress=None) -> SimpleNamespace:
    """The run ``b`` (:func:`build_static`'s, at a converged load t) on a new mesh of its deformed outline:
    the quadrature state and the reference volume ratio (:func:`_volume_ratio`) transferred, the solver built
    anew (prescribed displacements counted from t,
    the contact pairs' penalties kept, their committed tractions carried to the new nodes,
    :func:`_carry_contact_history`; a [thermal] run's temperature field, :func:`_carry_temperature`), equilibrium restored at the same load (one Newton solve, no load change) and the
    jump of the one-column outputs across the remesh recorded (``quantities``: the old mesh's; ``build``:
    :func:`fenics_plast.runner_static.build_static`, passed in: the runner imports this module).
    Returns the new build with ``u_before`` (the displacement from the first mesh's reference at its
    nodes, so that the outputs keep measuring from there) and ``group_facets``. Collective; RunError
    when equilibrium is not found."""
    from dolfinx import fem
    from fenics_plast.remeshing.quality import deformed_nodes
    from fenics_plast.remeshing.remesher import carry_displacement, timed
    s = b.solver
    t = s.lam_converged
    u = s.displacement_function()
    x = deformed_nodes(u)
    cells = b.mesh.topology.index_map(b.mesh.topology.dim).size_global
    rec = remesher.start(t, reason, cells, remesher.quality(b.mesh, x))
    before = quantities.one_column_values(t)
    clock = timed()
    fits = {spec.group: _tool_gap(b.tools[spec.tool], t) for spec in problem.contact.values() if spec.get("tool")}
    new = remesher.new_mesh(b.mesh, b.cell_tags, b.facet_tags, b.groups, x, getattr(b, "group_facets", None),
                            fits=fits)
    rec.mesh_s = clock.lap()
    state, rec.transfer, transfer = remesher.transfer(b.mesh, x, s.qmap.degree, s.qmap.state(), new[0])
    reference_volume = transfer.point_values(_volume_ratio(s), new[0])
    total = fem.Function(u.function_space)
    total.x.array[:] = u.x.array + b.u_before
    rec.transfer_s = clock.lap()
    nb = build(problem, comm, tuple(new), log=log, progress=progress, since=t,
               penalties={n: p.penalty for n, p in b.pairs.items()})
    new_total = fem.Function(nb.Vc)
    transfer.nodal_function(total, new_total)
    carry_displacement(nb, new_total.x.array)
    if b.thermal is not None:
        rec.transfer["temperature_shift_K"] = _carry_temperature(b.thermal, nb.thermal, transfer, state, t)
    nb.group_facets, nb.remesh_record, nb.since = new.group_facets, new.record, t
    s2 = nb.solver
    s2.qmap.set_state(state)
    s2.qmap.reference_volume = reference_volume
    for k in ("increments", "cutbacks", "linesearch_retries", "total_iterations", "total_iterations_failed",
              "jacobians", "force_scale", "roundoff_floor"):
        setattr(s2, k, getattr(s, k))
    for k, v in s.times.items():
        s2.times[k] = s2.times.get(k, 0.0) + v
    s2.lam_converged = t
    if nb.contact is not None:          # slips count from here: the tools' motion up to t is not slip
        nb.contact.lam_c.value = t
    _carry_contact_history(b.pairs, nb.pairs, comm)
    rec.rebuild_s = clock.lap()
    its_before = s2.total_iterations
    _equilibrate(s2, nb.contact, t, f"remesh {rec.number} at t = {t:.6g} ({reason})")
    rec.equilibrium_s = clock.lap()
    rec.equilibrium_iterations = s2.total_iterations - its_before
    rec.new_cells = nb.mesh.topology.index_map(nb.mesh.topology.dim).size_global
    q = remesher.quality(nb.mesh, None)
    rec.new_quality = remesher.fresh = (q.min_scaled_jacobian, q.max_angle_deg)
    s.close()
    if b.thermal is not None:
        b.thermal.heat.close()
    return nb, rec, before


def _volume_ratio(s):
    """(owned points,) each point's volume ratio dv / dV_0 to the first mesh's reference: the solver's det Fbar
    (theta, q1p0; J, q1) times its mesh's :attr:`~fenics_plast.quadrature.QuadratureMap.reference_volume`.
    Carried to a new mesh as its reference volume: the Cauchy stress tau / (J_ref theta) goes on from the
    old one's (taken as 1 on the new reference, the stress would jump by the elastic volume change, 0.2 %
    in the billet at 300 MPa of pressure)."""
    ratio = s.qp_jacobian()                 # (the solver's buffer: copied or multiplied into a new array)
    return ratio.copy() if s.qmap.reference_volume is None else ratio * s.qmap.reference_volume


#: the share of a new mesh's out-of-balance force applied at each stage of a re-equilibration that did
#: not converge at once (the transferred stress near a tool edge can be far from equilibrium)
EQUILIBRIUM_STAGES = (0.25, 0.5, 0.75, 1.0)


class _Imbalance:
    """A residual term of the static solver (``solver.terms``) that takes back ``scale`` times the force
    ``r0`` (owned entries of the residual at the new mesh's start): with it the solver finds the
    equilibrium of part of the out-of-balance force, without it the whole."""

    def __init__(self, r0):
        self.r0, self.scale = r0, 0.0

    def residual(self, b):
        with b.localForm() as bl:
            bl.array[: len(self.r0)] -= self.scale * self.r0

    def jacobian(self, A):
        pass


def _solve(s, t):
    """One equilibrium solve at load t, again with the other line search if the first fails (as the load
    stepping does): (ok, why)."""
    ok, its, why = s.solve_increment(t)
    if not ok:
        other = "bt" if s.options["linesearch"] == "basic" else "basic"
        s.set_linesearch(other)
        try:
            ok, its, why = s.solve_increment(t)
        finally:
            s.set_linesearch(s.options["linesearch"])
    return ok, why


def _equilibrate(s, contact, t, where):
    """Equilibrium of the new mesh's solver ``s`` at the load t it stands at, committed (``contact``: its
    contact set, committed too): one Newton solve; if it fails, the out-of-balance force in
    :data:`EQUILIBRIUM_STAGES` (each stage committed). RunError naming ``where`` if a stage fails."""
    ok, why = _solve(s, t)
    if not ok:
        s.log(f"  {where}: equilibrium in stages ({why})")
        term = _Imbalance(s.out_of_balance(t))
        s.terms.append(term)
        try:
            for share in EQUILIBRIUM_STAGES:
                term.scale = 1.0 - share
                ok, why = _solve(s, t)
                if not ok:
                    break
                s.commit()
                if contact is not None:
                    contact.commit()
        finally:
            s.terms.remove(term)
    if not ok:
        raise RunError(f"no equilibrium on the new mesh of {where}: {why}, "
                       f"|R| = {', '.join(f'{n:.3e}' for n in s.norms[:4] + s.norms[-3:])}")
    s.commit()
    if contact is not None:
        contact.commit()


def resumed_build(problem, comm, b, saved, remesher, build, log, progress) -> SimpleNamespace:
    """The build of a checkpoint written on a remeshed body (``saved``: the checkpoint): its mesh made
    again (:mod:`fenics_plast.remeshing.resume`), the solver built on it as at the remesh (prescribed
    displacements from the remesh load, the contact penalties kept), the carried displacement and the
    remesher's records restored; ``b`` (the scene's mesh) is closed; ``build``: as for :func:`remeshed`. The
    caller loads the solver's state. Collective."""
    from fenics_plast.remeshing.resume import restore_u_before, resumed_mesh
    new, entry = resumed_mesh(comm, saved, remesher)
    b.solver.close()
    if b.thermal is not None:
        b.thermal.heat.close()
    nb = build(problem, comm, tuple(new), log=log, progress=progress, since=float(entry["since"]),
               penalties=entry["penalties"])
    nb.since = float(entry["since"])
    restore_u_before(nb, nb.Vc, saved, new)
    return nb


def _carry_contact_history(old_pairs, new_pairs, comm):
    """The committed traction, normal and pressure of each tool pair's nodes (the friction's stick state)
    carried from the old nodes (at their current positions) to the new ones
    (:func:`fenics_plast.remeshing.transfer.scattered_values`): friction held at the remesh load stays
    held (reset, it would be lost at every remesh and rebuilt only by slip: 12-24 % of the die's
    friction force a remesh at rest, measured in tests/test_remesh_static.py). Pairs between two groups
    of the body start anew."""
    from fenics_plast.remeshing.transfer import scattered_values
    for name, new in new_pairs.items():
        old = old_pairs.get(name)
        if not (hasattr(old, "hist") and hasattr(new, "hist")):
            continue
        h = old.hist
        x_old = old.X + old.solver.w.x.array[old.idx]
        values = scattered_values(x_old[:, :2], np.concatenate([h.t_n, h.N_n, h.p_n[:, None]], axis=1),
                                  new.X[:, :2], comm)
        d = new.gdim
        new.hist.store(values[:, :d], values[:, d:2 * d], values[:, 2 * d])


def _carry_temperature(old, new, transfer, state, t):
    """The temperature field of a [thermal] run (``old``, ``new``: the builds' ThermalCoupling) carried to
    the new mesh: T evaluated at the new nodes (:meth:`fenics_plast.remeshing.transfer.StateTransfer.nodal_function`,
    linear fields exact), the accumulated heats and step count kept, the last heat step's eqps the
    transferred ones (``state``), its stresses unknown (the next step starts at the end's), the points of a
    temperature-dependent law at the new field. The heat capacity per volume (rho c) is carried as the
    deformed body's, rho c / J per old cell, its total kept (StateTransfer.cell_values, ``conserve``): the new
    reference is the deformed shape, the mass the old one (thermal expansion, elastic volume change). The
    interpolation of T gains or loses heat (a piecewise-linear field evaluated at other nodes), so the field is then
    shifted uniformly to keep the stored heat int rho c (T - T_0) dV: the heat balance stays closed, and the
    shift [K] (returned) is the transfer's measure, in the remesh's record. With thermal expansion, the
    stretch of the last heat step, not yet taken by an increment, is dropped (the new reference is the
    deformed shape; its points' thermal stretch counts from their temperature now)."""
    from fenics_plast import dolfinx_compat as dc
    from fenics_plast.remeshing.transfer import quadrature_volumes
    from fenics_plast.thermal.plastic_heat import NOT_FLOWING
    stored = old.heat.heat_balance()["stored"]
    # the heat capacity per volume of the deformed body (rho c per reference volume / J, cell by cell), carried
    # with its total kept: the new reference is the deformed shape, its mass the old mass
    mesh, n_old = transfer.mesh, transfer.mesh.topology.index_map(transfer.mesh.topology.dim).size_local
    J = (quadrature_volumes(mesh, transfer.degree, transfer.axisymmetric, transfer.x).sum(axis=1)
         / quadrature_volumes(mesh, transfer.degree, transfer.axisymmetric).sum(axis=1))
    rho_c = old.heat.rho_c.x.array[dc.cell_dofs(old.heat.rho_c.function_space).reshape(-1)[:n_old]] / J
    new_mesh = new.heat.mesh
    n_new = new_mesh.topology.index_map(new_mesh.topology.dim).size_local
    new.heat.rho_c.x.array[dc.cell_dofs(new.heat.rho_c.function_space).reshape(-1)[:n_new]] = \
        transfer.cell_values(rho_c, new_mesh, conserve=True)
    new.heat.rho_c.x.scatter_forward()
    new.heat.update_capacity()
    transfer.nodal_function(old.heat.T, new.heat.T)
    new.heat.heat.update(old.heat.heat)
    shift = (stored - new.heat.heat_balance()["stored"]) / new.heat.capacity
    new.heat.T.x.array[:] += shift
    new.heat.T_n.x.array[:] = new.heat.T.x.array
    new.heat.steps, new.heat.time = old.heat.steps, old.heat.time
    new.plastic.eqps_last = np.array(state["eqps"], dtype=float)
    new.plastic.tau_last = np.full_like(new.plastic.eqps_last, NOT_FLOWING)
    new.t_last = t
    new.to_points(expand=False)
    return shift


def _tool_gap(tool, t):
    """The gap function of ``tool`` (a :class:`fenics_plast.tools.Tool` or meshed tool) at load t for
    :func:`fenics_plast.remeshing.new_mesh.fitted_chain`: points (k, 2) [mm] -> (gap (k,), normal (k, 2))."""
    return lambda x: tool.gap_np(x, t)
