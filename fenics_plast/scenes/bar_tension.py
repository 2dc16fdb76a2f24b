"""Necking of a round bar in tension (Simo's classic), axisymmetric, quasi-static.

The runner models the upper half of the bar (symmetry plane z = 0, where the imperfection
puts the neck): u_r = 0 on the axis, u_z = 0 on the symmetry plane, u_z = displacement / 2
on the gripped end (radially free). The force is the total reaction on the end (2 pi r weight).
"""
from __future__ import annotations

import time

import numpy as np
from mpi4py import MPI

from fenics_plast.checkpoint import Checkpointer
from fenics_plast.errors import RunError
from fenics_plast.kinematics import Kinematics
from fenics_plast.material import Material
from fenics_plast.meshing import bar_mesh
from fenics_plast.quadrature import pressure, von_mises
from fenics_plast.scenes import newton_options
from fenics_plast.solvers.static import StaticSolver


def build(comm, radius, half_length, cells_radial, cells_axial, imperfection, material,
          element="q1p0", solver_options=None, log=None, verbose=True):
    """Mesh + solver + BCs (end displacement = 1 at load factor 1). Returns (solver, info)."""
    mesh, ct, ft, ids = bar_mesh(comm, radius, half_length, cells_radial, cells_axial, imperfection)
    kin = Kinematics(mesh, "axisymmetric")
    s = StaticSolver(kin, material, element=element, log=log, verbose=verbose, **(solver_options or {}))
    s.add_dirichlet(0, ft, ids["axis"], 0.0)
    s.add_dirichlet(1, ft, ids["bottom"], 0.0)
    s.add_dirichlet(1, ft, ids["top"], 1.0)
    s.setup()
    top = s.constrained_dofs(1, ft, ids["top"])
    return s, dict(mesh=mesh, cell_tags=ct, facet_tags=ft, tag_ids=ids, top_dofs=top,
                   cells=mesh.topology.index_map(2).size_global)


def neck_radius(solver, radius, half_length, imperfection):
    """Smallest current radius of the outer surface (all ranks)."""
    u = solver.displacement_function()
    X = u.function_space.tabulate_dof_coordinates()
    r0 = radius * (1 - imperfection * (1 - X[:, 1] / half_length))
    outer = np.isclose(X[:, 0], r0, rtol=0, atol=1e-8 * radius)
    vals = u.x.array.reshape(-1, 2)
    local = np.min(X[outer, 0] + vals[outer, 0]) if outer.any() else np.inf
    return solver.comm.allreduce(float(local), op=MPI.MIN)


def run(scene, output) -> dict:
    comm = MPI.COMM_WORLD
    m, sv, ld = scene.mesh, scene.solver, scene.loading
    refine = int(m.refine)
    material = Material.from_scene(scene.material)
    R, half = m.radius, 0.5 * m.length
    imp = m.imperfection
    opts = dict(newton_options(sv), progress=output.progress(1.0, scene.name, what="load"))
    t0 = time.perf_counter()
    s, info = build(comm, R, half, m.cells_radial * refine, m.cells_axial * refine, imp, material,
                    element=m.element, solver_options=opts, log=output.log)
    end_disp = 0.5 * ld.displacement          # half bar
    for bc, g, g0 in s._bcs:                  # scale the unit end displacement
        g0 *= end_disp
    output.log(f"bar_tension: {info['cells']} cells, {s.dofs} dofs, element {m.element}, "
               f"setup {time.perf_counter() - t0:.1f} s")

    hist = dict(elongation_mm=[0.0], force_kN=[0.0], neck_radius_mm=[R * (1 - imp)])
    out = dict(every=int(getattr(scene.output, "every", 1)), xdmf=None, count=0)
    # checkpoints (output.checkpoint_every increments) and resuming a killed run (--resume)
    ckpt = Checkpointer.for_run(scene, output, comm)
    loop = None
    if ckpt is not None and ckpt.resuming:
        state = ckpt.load()
        s.load_state(state["solver"])
        hist, out["count"], loop = state["runner"]["hist"], state["runner"]["count"], state["loop"]
        output.log(f"bar_tension: resumed from the checkpoint at increment {len(s.increments)}, "
                   f"load factor {s.lam_converged:.6g}")
    else:
        output.history(increment=0, load_factor=0.0, elongation_mm=0.0, force_kN=0.0,
                       neck_radius_mm=R * (1 - imp), newton_iterations=0)

    def on_checkpoint(solver, loop_state):
        ckpt.save(len(solver.increments), solver=solver.state_dict(), loop=loop_state,
                  runner=dict(hist=hist, count=out["count"]))
    ck_args = {} if ckpt is None else dict(checkpoint_every=ckpt.every, on_checkpoint=on_checkpoint, resume=loop)
    if getattr(scene.output, "xdmf", True):
        from dolfinx import io
        out["xdmf"] = xf = io.XDMFFile(comm, str(output.xdmf_path), "w")
        xf.write_mesh(info["mesh"])
        q = s.qmap
        out["fields"] = [q.cell_mean(np.zeros(q.n), name=n) for n in
                         ("equivalent_plastic_strain", "von_mises_stress", "pressure")]

    def write_fields(t):
        xf = out["xdmf"]
        if xf is None:
            return
        q = s.qmap
        J = s.qp_jacobian()
        eq, vm, pr = out["fields"]
        q.cell_mean(q.eqps, out=eq)
        q.cell_mean(von_mises(q.tau_values, J), out=vm)
        q.cell_mean(pressure(q.tau_values, J), out=pr)
        xf.write_function(s.displacement_function(), t)
        for f in out["fields"]:
            xf.write_function(f, t)

    if loop is None:
        write_fields(0.0)

    def on_increment(solver):
        rec = solver.increments[-1]
        elong = 2 * end_disp * solver.lam_converged
        force = solver.reaction(info["top_dofs"]) / 1e3
        rn = neck_radius(solver, R, half, imp)
        hist["elongation_mm"].append(elong)
        hist["force_kN"].append(force)
        hist["neck_radius_mm"].append(rn)
        output.history(increment=rec["increment"], load_factor=solver.lam_converged, elongation_mm=elong,
                       force_kN=force, neck_radius_mm=rn, newton_iterations=rec["iterations"])
        out["count"] += 1
        if out["count"] % out["every"] == 0 or solver.lam_converged >= 1 - 1e-12:
            write_fields(elong)
        return False

    def results(converged):
        f = np.asarray(hist["force_kN"])
        i = int(np.argmax(f))
        return dict(max_force_kN=float(f[i]), elongation_at_max_mm=float(hist["elongation_mm"][i]),
                    final_elongation_mm=float(hist["elongation_mm"][-1]),
                    min_radius_mm=float(min(hist["neck_radius_mm"])),
                    cells=info["cells"], dofs=s.dofs, converged=converged,
                    increments=len(s.increments), newton_iterations=s.total_iterations,
                    element=m.element,
                    key_results=["max_force_kN", "elongation_at_max_mm", "min_radius_mm"],
                    info_results=["final_elongation_mm"], references={})

    try:
        s.run(increments=sv.increments, min_increment=sv.min_increment, max_increment=sv.max_increment,
              callback=on_increment, **ck_args)
    except RunError as e:
        e.results.update(results(False))
        raise
    finally:
        if out["xdmf"] is not None:
            out["xdmf"].close()
        if getattr(scene.output, "plots", True) and len(hist["force_kN"]) > 1:
            output.draw_plots("bar_tension", title=scene.name)
    return results(True)
