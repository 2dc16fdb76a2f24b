"""Thick-walled cylinder under internal pressure, plane strain (quarter ring), quasi-static.

Loading choice (documented): the inner radial displacement is PRESCRIBED (u = delta * x / a on
r = a, load factor times delta_max), and the internal pressure is computed from the reaction:
p = (sum of the x- and y-reactions on the inner boundary) / (2 a_current), which is exact for
the axisymmetric state of the quarter ring (the resultant of p on the quarter arc is p a_current
in x and in y); at the two corner nodes the component normal to the symmetry line is left out
(it carries hoop force) and its pressure share is corrected for exactly (see ``solve``). Displacement control passes the limit load without arc-length: for an
elastic-perfectly plastic material the pressure plateaus at the limit pressure
(2/sqrt(3)) sigma_y ln(b/a) in small strain. The run stops when the pressure reaches
``loading.pressure`` or when delta_max is reached; ``limit_pressure_MPa`` is the largest
converged pressure. delta_max = 3 x the inner displacement at which the small-strain
incompressible solution becomes fully plastic, so the plateau is reached; with
sigma_y / E ~ 1e-3 or less strains stay small.
"""
from __future__ import annotations

import math
import time

import numpy as np
from mpi4py import MPI

from fenics_plast.checkpoint import Checkpointer
from fenics_plast.errors import RunError
from fenics_plast.kinematics import Kinematics
from fenics_plast.material import Material
from fenics_plast.meshing import ring_mesh
from fenics_plast.scenes import newton_options
from fenics_plast.solvers.static import StaticSolver


def limit_pressure(yield_stress, a, b):
    """Small-strain limit pressure of a thick cylinder, plane strain, von Mises."""
    return 2.0 / math.sqrt(3.0) * yield_stress * math.log(b / a)


def full_plastic_displacement(material, yield_stress, a, b):
    """Inner radial displacement at which the plastic zone reaches r = b (incompressible estimate)."""
    _, mu = material.lame
    # elastic outer zone at r = b just yielding: u(b) = sqrt(3)/2 * sigma_y b / (2 mu); u r = const
    ub = math.sqrt(3.0) / 2.0 * yield_stress * b / (2.0 * mu)
    return ub * b / a


def solve(comm, a, b, cells_radial, cells_circumferential, material, element="q1p0",
          delta=None, p_stop=None, increments=20, min_increment=1e-4, max_increment=0.1,
          solver_options=None, log=None, verbose=True, on_increment=None, checkpointer=None):
    """Run the displacement-controlled ring; returns dict with pressure history and the solver.
    ``checkpointer``: a :class:`fenics_plast.checkpoint.Checkpointer` (checkpoints; resume)."""
    mesh, ct, ft, ids = ring_mesh(comm, a, b, cells_radial, cells_circumferential)
    kin = Kinematics(mesh, "plane_strain")
    s = StaticSolver(kin, material, element=element, log=log, verbose=verbose, **(solver_options or {}))
    if delta is None:
        sy = material.hardening.initial_yield_stress if material.hardening is not None else 1.0
        delta = 3.0 * full_plastic_displacement(material, sy, a, b)
    s.add_dirichlet(1, ft, ids["bottom"], 0.0)
    s.add_dirichlet(0, ft, ids["left"], 0.0)
    s.add_dirichlet(0, ft, ids["inner"], lambda x: delta * x[0] / a)
    s.add_dirichlet(1, ft, ids["inner"], lambda x: delta * x[1] / a)
    s.setup()
    # Reactions on the inner boundary, leaving out the component normal to a symmetry line at the
    # two corner nodes (it carries the hoop force of the symmetry plane, not the pressure).
    inner_x = s.constrained_dofs(0, ft, ids["inner"], where=lambda X: X[:, 0] > 1e-9 * a)
    inner_y = s.constrained_dofs(1, ft, ids["inner"], where=lambda X: X[:, 1] > 1e-9 * a)
    # For a uniform pressure on the polygonal inner boundary (nodes on r = a, angle step dphi) the
    # corner nodes' left-out shares are p a (1 - cos dphi) / 2 each.
    dphi = 0.5 * math.pi / cells_circumferential
    corner = 0.5 * (1.0 + math.cos(dphi))
    hist = dict(inner_displacement_mm=[0.0], pressure_MPa=[0.0])

    def cb(solver):
        d = delta * solver.lam_converged
        p = (solver.reaction(inner_x) + solver.reaction(inner_y)) / (2.0 * (a + d) * corner)
        hist["inner_displacement_mm"].append(d)
        hist["pressure_MPa"].append(p)
        if on_increment is not None:
            on_increment(solver, d, p)
        return p_stop is not None and p >= p_stop

    ck_args = {}
    if checkpointer is not None:
        loop = None
        if checkpointer.resuming:
            state = checkpointer.load()
            s.load_state(state["solver"])
            hist, loop = state["runner"]["hist"], state["loop"]

        def on_checkpoint(solver, loop_state):
            checkpointer.save(len(solver.increments), solver=solver.state_dict(), loop=loop_state,
                              runner=dict(hist=hist))
        ck_args = dict(checkpoint_every=checkpointer.every, on_checkpoint=on_checkpoint, resume=loop)

    converged = True
    try:
        s.run(increments=increments, min_increment=min_increment, max_increment=max_increment, callback=cb,
              **ck_args)
    except RunError as e:
        converged = False
        error = e
    out = dict(solver=s, history=hist, delta=delta, converged=converged,
               cells=mesh.topology.index_map(2).size_global, dofs=s.dofs,
               limit_pressure_MPa=float(max(hist["pressure_MPa"])))
    if not converged:
        out["error"] = error
    return out


def run(scene, output) -> dict:
    comm = MPI.COMM_WORLD
    m, sv = scene.mesh, scene.solver
    refine = int(m.refine)
    if m.geometry != "plane_strain":
        output.log("thick_cylinder: the ring is modelled in plane strain (mesh.geometry ignored)")
    material = Material.from_scene(scene.material)
    opts = dict(newton_options(sv), progress=output.progress(1.0, scene.name, what="load"))
    t0 = time.perf_counter()

    def on_increment(solver, d, p):
        rec = solver.increments[-1]
        output.history(increment=rec["increment"], load_factor=solver.lam_converged,
                       inner_displacement_mm=d, pressure_MPa=p, newton_iterations=rec["iterations"])

    r = solve(comm, m.inner_radius, m.outer_radius, m.cells_radial * refine,
              m.cells_circumferential * refine, material, element=m.element,
              p_stop=scene.loading.pressure, increments=sv.increments, min_increment=sv.min_increment,
              max_increment=sv.max_increment, solver_options=opts, log=output.log,
              on_increment=on_increment, checkpointer=Checkpointer.for_run(scene, output, comm))
    s, hist = r["solver"], r["history"]
    res = dict(limit_pressure_MPa=r["limit_pressure_MPa"],
               final_pressure_MPa=float(hist["pressure_MPa"][-1]),
               final_inner_displacement_mm=float(hist["inner_displacement_mm"][-1]),
               pressure_reached=bool(hist["pressure_MPa"][-1] >= scene.loading.pressure),
               cells=r["cells"], dofs=r["dofs"], converged=r["converged"],
               increments=len(s.increments), newton_iterations=s.total_iterations,
               element=m.element, setup_and_solve_s=time.perf_counter() - t0,
               key_results=["limit_pressure_MPa", "final_pressure_MPa"],
               info_results=["final_inner_displacement_mm"], references={})
    hard = scene.material.get("hardening") if hasattr(scene.material, "get") else None
    if hard is not None and getattr(hard, "law", None) == "linear" and getattr(hard, "modulus", 0) == 0:
        res["analytic_limit_pressure_MPa"] = limit_pressure(hard.yield_stress, m.inner_radius, m.outer_radius)
    if getattr(scene.output, "plots", True):
        output.draw_plots("thick_cylinder", title=scene.name, results=res)
    if not r["converged"]:
        raise RunError(str(r["error"]), results=res)
    return res
