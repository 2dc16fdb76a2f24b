"""Taylor bar: a round bar flying at ``loading.velocity`` hits a rigid, frictionless wall at z = 0.

Axisymmetric half-plane (x = r, y = z); the bar occupies 0 <= z <= L and moves towards -z.
Sliding supports (seed paper, Taylor bar section): axial velocity 0 on the impact face (z = 0),
radial velocity 0 on the axis. Explicit central differences with a lumped mass
(:mod:`fenics_plast.solvers.explicit`).

Results: final length (top face position), final radius of the impact face (outer radius of
the bottom face), max equivalent plastic strain, the energy balance. history.csv: time_us,
length_mm, radius_mm and energies in J (1 J = 1e3 N mm). fields.xdmf: displacement (CG1) and
eqps (DG0 cell mean) every ``output.every`` history rows, time in us.
"""
from __future__ import annotations

import numpy as np
from dolfinx import fem, io
from mpi4py import MPI

from fenics_plast.checkpoint import Checkpointer
from fenics_plast.kinematics import Kinematics
from fenics_plast.material import Material
from fenics_plast.meshing import bar_mesh
from fenics_plast.solvers.explicit import ExplicitDynamics

MJ_TO_J = 1e-3          # N mm -> J

#: Seed paper, Table 3, and the scene settings under which its values apply (summary ``references``).
PAPER = {"final_radius_mm": 7.11, "final_length_mm": 21.47, "max_eqps": 3.09}
PAPER_CONDITIONS = {("loading", "end_time_us"): 80.0, ("loading", "velocity_m_s"): 227.0, ("mesh", "radius"): 3.2,
                    ("mesh", "length"): 32.4, ("material", "E"): 117e3}


def paper_references(scene) -> dict:
    """The seed paper's values as summary ``references``, or {} when the scene is not the paper's."""
    same = all(np.isclose(float(getattr(getattr(scene, s), k)), v, rtol=1e-9)
               for (s, k), v in PAPER_CONDITIONS.items())
    hard = scene.material.get("hardening")
    same = same and hard is not None and np.isclose(float(hard.yield_stress), 400.0, rtol=1e-9)
    return {k: {"value": v, "source": "seed paper, Table 3"} for k, v in PAPER.items()} if same else {}


def build(scene, comm=MPI.COMM_WORLD, log=None):
    """Mesh, kinematics, material and solver (forms compiled), initial velocity set."""
    m = scene.mesh
    refine = int(m.refine)
    mesh, cell_tags, facet_tags, tag_ids = bar_mesh(
        comm, m.radius, m.length, m.cells_radial * refine, m.cells_axial * refine,
        imperfection=m.get("imperfection", 0.0) or 0.0)
    kin = Kinematics(mesh, m.geometry)
    material = Material.from_scene(scene.material)
    bcs = [(0, facet_tags.find(tag_ids["axis"])),        # radial velocity 0 on the axis
           (1, facet_tags.find(tag_ids["bottom"]))]      # axial velocity 0 on the impact face
    solver = ExplicitDynamics(mesh, kin, material, scene.material.density, bcs, element=m.element, log=log,
                              internal_force=scene.solver.internal_force)
    solver.set_velocity((0.0, -scene.loading.velocity))
    fdim = mesh.topology.dim - 1
    solver.bottom_nodes = fem.locate_dofs_topological(solver.V, fdim, facet_tags.find(tag_ids["bottom"]))
    solver.facet_tags, solver.tag_ids = facet_tags, tag_ids
    return solver


def bar_shape(solver):
    """(length, impact-face radius) of the deformed bar [mm], global."""
    x = solver.nodal_positions()
    comm = solver.comm
    zmax = comm.allreduce(float(x[:, 1].max()) if x.size else -np.inf, op=MPI.MAX)
    bn = solver.bottom_nodes
    rmax = comm.allreduce(float(x[bn, 0].max()) if bn.size else -np.inf, op=MPI.MAX)
    return zmax, rmax


def simulate(scene, output=None, comm=MPI.COMM_WORLD, log=None):
    """Run the scene; returns (results dict, solver). ``output`` (RunOutput) may be None."""
    if log is None and output is not None:
        log = output.log
    solver = build(scene, comm, log=log)
    end_time = scene.loading.end_time_us * 1e-6
    out = scene.output if "output" in scene.sections and scene.output is not None else None
    rows = int(out.history_points) if out is not None else 2
    every = int(out.every) if out is not None else 1
    want_xdmf = output is not None and out is not None and bool(out.xdmf)
    hist = {k: [] for k in ("time_us", "length_mm", "radius_mm", "kinetic_energy_J", "elastic_energy_J",
                            "plastic_dissipation_J", "external_work_J", "energy_balance_error")}
    row_index = [0]
    # checkpoints (output.checkpoint_every steps) and resuming a killed run (--resume)
    ckpt = Checkpointer.for_run(scene, output, comm)
    loop = None
    if ckpt is not None and ckpt.resuming:
        state = ckpt.load()
        solver.load_state(state["solver"])
        hist = state["runner"]["hist"]
        row_index[0] = state["runner"]["row_index"]
        loop = state["loop"]
        solver.log(f"taylor_bar: resumed from the checkpoint at step {solver.step_count}, "
                   f"t = {solver.t * 1e6:.4g} us")

    def on_checkpoint(s, loop_state):
        ckpt.save(s.step_count, solver=s.state_dict(), loop=loop_state,
                  runner=dict(hist=hist, row_index=row_index[0]))

    xdmf = None
    eqps_dg = None
    if want_xdmf:
        xdmf = io.XDMFFile(comm, str(output.xdmf_path), "w")
        xdmf.write_mesh(solver.mesh)

    def on_row(s, t):
        length, radius = bar_shape(s)
        e = s.energies()
        row = dict(time_us=t * 1e6, length_mm=length, radius_mm=radius,
                   kinetic_energy_J=e["kinetic"] * MJ_TO_J, elastic_energy_J=e["elastic"] * MJ_TO_J,
                   plastic_dissipation_J=e["plastic"] * MJ_TO_J, external_work_J=e["external_work"] * MJ_TO_J)
        for k, v in row.items():
            hist[k].append(v)
        hist["energy_balance_error"].append(e["balance_error"])
        if output is not None:
            output.history(**row)
        if xdmf is not None and (row_index[0] % every == 0 or t >= end_time * (1 - 1e-12)):
            nonlocal eqps_dg
            eqps_dg = s.qmap.cell_mean(s.qmap.eqps, name="eqps", out=eqps_dg)
            xdmf.write_function(s.u, t * 1e6)
            xdmf.write_function(eqps_dg, t * 1e6)
        row_index[0] += 1

    steps = scene.solver.get("steps", None)
    try:
        bar = (output.progress(scene.loading.end_time_us, scene.name, what="t", unit="us")
               if output is not None else None)
        ck_args = {} if ckpt is None else dict(checkpoint_every=ckpt.every, on_checkpoint=on_checkpoint,
                                               resume=loop)
        stats = solver.run(end_time, dt_safety=scene.solver.dt_safety, steps=steps, rows=rows, on_row=on_row,
                           bar=bar, **ck_args)
    finally:
        if xdmf is not None:
            xdmf.close()
    e = solver.energies()
    length, radius = bar_shape(solver)
    results = dict(
        final_length_mm=length,
        final_radius_mm=radius,
        max_eqps=solver.max_eqps(),
        energy_balance_error=e["balance_error"],
        energy_balance_error_max=float(max(hist["energy_balance_error"])),
        initial_kinetic_energy_J=solver.KE0 * MJ_TO_J,
        final_kinetic_energy_J=e["kinetic"] * MJ_TO_J,
        elastic_energy_J=e["elastic"] * MJ_TO_J,
        plastic_dissipation_J=e["plastic"] * MJ_TO_J,
        external_work_J=e["external_work"] * MJ_TO_J,
        steps=stats["steps"],
        dt_s=stats["dt_max"],
        dt_min_s=stats["dt_min"],
        dt_stable_initial_s=stats["dt_stable_initial"],
        dt_stable_final_s=stats["dt_stable_final"],
        wave_speed_m_s=solver.c * 1e-3,
        element=solver.element,
        model=solver.material.model,
        internal_force=solver.internal_force_route,
        step_loop_time_s=stats["wall_s"],
        time_per_step_s=stats["time_per_step_s"],
        setup_time_s=solver.timings["setup_s"],
        cells=solver.cells_global,
        dofs=solver.dofs_global,
        converged=True,
        key_results=["final_radius_mm", "final_length_mm", "max_eqps"],
        info_results=["energy_balance_error", "dt_s"],
        references=paper_references(scene),
    )
    if output is not None and out is not None and bool(out.plots):
        from fenics_plast.plots import cells_table     # final_shape.csv: deformed cells and their eqps
        eq = solver.qmap.cell_mean(solver.qmap.eqps, name="eqps")
        output.write_csv("final_shape", cells_table(solver.V, solver.nodal_positions(), eq, "eqps"))
        output.draw_plots("taylor_bar", title=scene.name)
    return results, solver


def run(scene, output):
    """CLI entry point (DESIGN.md runner contract)."""
    results, _ = simulate(scene, output, comm=output.comm if output.comm is not None else MPI.COMM_WORLD)
    return results
