"""The explicit runner's remeshing (issue 35): a run built by :func:`fenics_plast.runner_explicit.build_explicit`
on a new mesh of its deformed outline at time t (:func:`remeshed_explicit`: the state and velocities
transferred, the solver built anew with its step count and energy accumulators). The decision and the new
mesh are the solver-independent :class:`fenics_plast.remeshing.remesher.Remesher`'s;
:func:`fenics_plast.runner_explicit.run_explicit` calls it at a step-size check or a fold.
"""
from __future__ import annotations

from fenics_plast.schema import US

__all__ = ["remeshed_explicit"]


def remeshed_explicit(problem, comm, b, remesher, reason, quantities, build) -> tuple:
    """The explicit run ``b`` (:func:`build_explicit`'s, at time t) on a new mesh of its deformed outline
    (issue 35): the quadrature state and the velocities transferred (the nodal velocity field evaluated
    at the new nodes), the solver built anew at t with the step count, the initial kinetic energy and the
    work accumulators carried; the internal work takes the change of elastic energy, so that the
    balance counts what the transfer changed in kinetic and elastic energy as its error. The mass of
    the new mesh is the reference density times its volume (the old deformed one): off by the elastic
    volume change (recorded in the jump), and so is its stress: the reference's volume ratio, which the
    static runner carries (:func:`fenics_plast.runner_static_remesh._volume_ratio`), is not carried here.
    ``build``: :func:`fenics_plast.runner_explicit.build_explicit` (passed in: the runner imports this
    module). Returns (the new build with ``u_before``, the record, the
    outputs before). Collective."""
    from dolfinx import fem
    from fenics_plast.remeshing.quality import deformed_nodes
    from fenics_plast.remeshing.remesher import carry_displacement, timed
    s = b.solver
    t = s.t
    for f in (s.u, s.v):            # the step updates the owned entries: the ghosts' values from their owners
        f.x.scatter_forward()
    x = deformed_nodes(s.u)
    rec = remesher.start(t / US, reason, s.cells_global, remesher.quality(b.mesh, x))
    before = quantities.one_column_values(t / US)
    e_old = s.energies()
    clock = timed()
    new = remesher.new_mesh(b.mesh, b.cell_tags, b.facet_tags, b.groups, x, getattr(b, "group_facets", None))
    rec.mesh_s = clock.lap()
    state, rec.transfer, transfer = remesher.transfer(b.mesh, x, s.qmap.degree, s.qmap.state(), new[0])
    total = fem.Function(s.u.function_space)
    total.x.array[:] = s.u.x.array + b.u_before
    rec.transfer_s = clock.lap()
    nb = build(problem, comm, tuple(new))
    s2 = nb.solver
    s2.log = s.log
    new_total = fem.Function(s2.V)
    transfer.nodal_function(total, new_total)
    carry_displacement(nb, new_total.x.array)
    nb.group_facets, nb.remesh_record = new.group_facets, new.record
    v = fem.Function(s2.V)
    transfer.nodal_function(s.v, v)
    s2.set_velocity(v.x.array.reshape(-1, s2.bs))
    s2.qmap.set_state(state)
    rec.transfer_s += clock.lap()
    s2.t, s2.step_count = s.t, s.step_count
    s2.initialize()
    root = comm.rank == 0
    s2.KE0 = s.KE0
    e_new = s2.energies()
    s2.W_int = (e_old["internal_work"] + e_new["elastic"] - e_old["elastic"]) if root else 0.0
    s2.W_ext = e_old["external_work"] if root else 0.0
    if s2.walls.active:
        s2.walls.restore(e_old["wall"], root)
    rec.rebuild_s = clock.lap()
    rec.new_cells = s2.cells_global
    q = remesher.quality(nb.mesh, None)
    rec.new_quality = remesher.fresh = (q.min_scaled_jacobian, q.max_angle_deg)
    rec.energy_jump = dict(kinetic_J=(e_old["kinetic"] * 1e-3, e_new["kinetic"] * 1e-3),
                           elastic_J=(e_old["elastic"] * 1e-3, e_new["elastic"] * 1e-3))
    return nb, rec, before
