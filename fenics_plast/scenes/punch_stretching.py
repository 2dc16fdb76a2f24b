"""Stretching of a circular blank by a hemispherical punch (Lee, Wagoner & Nakamachi; seed paper).

Axisymmetric blank 0 <= r <= R_b, 0 <= z <= t, clamped (u = 0) at the rim r = R_b, u_r = 0 on the
axis. Rigid analytic tools (fenics_plast.contact):

* punch: sphere of radius R_p centred on the axis, tangent to the lower face z = 0 at the pole at
  the start, moving up by ``travel * lam``; candidate facets: "lower";
* die shoulder: circle of radius r_d centred at (die_opening_radius + r_d, t + r_d) (fixed), which
  the upper face wraps around; candidate facets: "upper".

Penalty contact with Coulomb / Quasi-Coulomb friction (same mu on punch and die). The run is split
in two legs so that a converged state lands exactly on 20 mm of travel (thickness strain output).

Outputs: history.csv (punch_displacement_mm, punch_force_kN, ...), thickness_strain.csv
(travel_mm, r0_mm, thickness_strain = ln(t/t0) along the blank at 20 mm and at the final state),
force and thickness-strain PNGs, fields.xdmf.
"""
from __future__ import annotations

import time

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

from fenics_plast.checkpoint import Checkpointer
from fenics_plast.contact import DieShoulder, PenaltyContact, SphericalPunch, default_penalty
from fenics_plast.errors import RunError
from fenics_plast.kinematics import Kinematics
from fenics_plast.material import Material
from fenics_plast.meshing import blank_mesh
from fenics_plast.quadrature import von_mises
from fenics_plast.scenes import newton_options
from fenics_plast.solvers.static import StaticSolver

THICKNESS_TRAVEL_MM = 20.0


def build(comm, *, blank_radius=65.53, thickness=1.0, cells_radial=60, cells_thickness=4, grading=1.0,
          material, punch_radius=50.8, die_opening_radius=59.18, die_shoulder_radius=6.35, travel=40.0,
          friction=0.0, law="quasi-coulomb", penalty=None, tangential_penalty=None, element="q1p0",
          solver_options=None, log=None, verbose=True):
    """Mesh, solver, BCs and contact. Returns (solver, contact, info)."""
    mesh, ct, ft, ids = blank_mesh(comm, blank_radius, thickness, cells_radial, cells_thickness, grading)
    kin = Kinematics(mesh, "axisymmetric")
    s = StaticSolver(kin, material, element=element, log=log, verbose=verbose, **(solver_options or {}))
    s.add_dirichlet(0, ft, ids["axis"], 0.0)
    s.add_dirichlet(0, ft, ids["rim"], 0.0)
    s.add_dirichlet(1, ft, ids["rim"], 0.0)
    eps = penalty if penalty else default_penalty(material.E, thickness)
    c = PenaltyContact(s, eps, friction=friction, law=law, tangential_penalty=tangential_penalty)
    punch = c.add_tool(SphericalPunch(punch_radius, travel, z_pole=0.0), ft, ids["lower"])
    die = c.add_tool(DieShoulder(die_shoulder_radius, die_opening_radius + die_shoulder_radius,
                                 thickness + die_shoulder_radius), ft, ids["upper"])
    c.attach()
    s.setup()
    info = dict(mesh=mesh, cell_tags=ct, facet_tags=ft, tag_ids=ids, punch=punch, die=die,
                cells=mesh.topology.index_map(2).size_global, penalty=eps,
                tangential_penalty=c.tangential_penalty, thickness=thickness, travel=travel)
    return s, c, info


class _Faces:
    """Lower/upper face node pairs (same r0) for the thickness, gathered on every rank."""

    def __init__(self, s, ft, ids):
        Vc, vmap = s.V.collapse()
        vmap = np.asarray(vmap).reshape(-1, 2)
        n_owned = Vc.dofmap.index_map.size_local
        X = Vc.tabulate_dof_coordinates()
        self.s = s
        self.sel = {}
        for name in ("lower", "upper"):
            b = fem.locate_dofs_topological(Vc, 1, ft.find(ids[name]))
            b = b[b < n_owned]
            self.sel[name] = (X[b, :2].copy(), vmap[b])

    def gather(self, name):
        X, idx = self.sel[name]
        x = X + self.s.w.x.array[idx]
        data = self.s.comm.allgather(np.hstack([X, x]) if len(X) else np.zeros((0, 4)))
        a = np.vstack(data)
        a = a[np.argsort(a[:, 0], kind="stable")]
        # drop duplicates (none expected: owned only)
        _, keep = np.unique(np.round(a[:, 0], 9), return_index=True)
        return a[keep]

    def thickness_strain(self, t0):
        lo, up = self.gather("lower"), self.gather("upper")
        r0 = lo[:, 0]
        if len(up) != len(lo) or not np.allclose(up[:, 0], r0, atol=1e-8 * max(1.0, r0.max())):
            # graded meshes: match by interpolation of the upper face in r0
            upx = np.column_stack([np.interp(r0, up[:, 0], up[:, 2]), np.interp(r0, up[:, 0], up[:, 3])])
        else:
            upx = up[:, 2:4]
        t = np.linalg.norm(upx - lo[:, 2:4], axis=1)
        return r0, np.log(t / t0)


def run(scene, output) -> dict:
    comm = MPI.COMM_WORLD
    m, sv, ld, tl = scene.mesh, scene.solver, scene.loading, scene.tools
    ct = scene.contact
    refine = int(m.refine)
    material = Material.from_scene(scene.material)
    friction = ct.friction if ct is not None else 0.0
    law = ct.law if ct is not None else "quasi-coulomb"
    penalty = ct.penalty if ct is not None else None
    tpen = ct.tangential_penalty if ct is not None else None
    opts = dict(newton_options(sv), progress=output.progress(1.0, scene.name, what="load"))
    t0 = time.perf_counter()
    travel = ld.travel
    s, c, info = build(comm, blank_radius=m.blank_radius, thickness=m.thickness,
                       cells_radial=m.cells_radial * refine, cells_thickness=m.cells_thickness * refine,
                       grading=m.grading, material=material, punch_radius=tl.punch_radius,
                       die_opening_radius=tl.die_opening_radius, die_shoulder_radius=tl.die_shoulder_radius,
                       travel=travel, friction=friction, law=law, penalty=penalty, tangential_penalty=tpen,
                       element=m.element, solver_options=opts, log=output.log)
    output.log(f"punch_stretching: {info['cells']} cells, {s.dofs} dofs, mu = {friction:g} ({law}), "
               f"penalty {info['penalty']:.4g} N/mm^3, setup {time.perf_counter() - t0:.1f} s")
    faces = _Faces(s, info["facet_tags"], info["tag_ids"])
    t_blank = m.thickness

    # quadrature-point reference radius (location of max eqps)
    q = s.qmap
    r_expr = fem.Expression(ufl.SpatialCoordinate(info["mesh"])[0], q.points)
    r_qp = r_expr.eval(q.cells).reshape(-1)

    hist = dict(d=[0.0], F=[0.0], pen=[0.0])
    thick = {}
    out = dict(every=int(getattr(scene.output, "every", 1)), xdmf=None, count=0)
    # checkpoints (output.checkpoint_every increments) and resuming a killed run (--resume)
    ckpt = Checkpointer.for_run(scene, output, comm)
    loop = None
    if ckpt is not None and ckpt.resuming:
        state = ckpt.load()
        s.load_state(state["solver"])
        c.load_state(state["contact"])
        hist, out["count"], loop = state["runner"]["hist"], state["runner"]["count"], state["loop"]
        if state["runner"]["thick20"] is not None:
            thick[THICKNESS_TRAVEL_MM] = tuple(np.asarray(a) for a in state["runner"]["thick20"])
        output.log(f"punch_stretching: resumed from the checkpoint at increment {len(s.increments)}, "
                   f"travel {travel * s.lam_converged:.4g} mm")
    else:
        output.history(increment=0, load_factor=0.0, punch_displacement_mm=0.0, punch_force_kN=0.0,
                       die_force_kN=0.0, max_penetration_mm=0.0, newton_iterations=0)

    def on_checkpoint(solver, loop_state):
        t20 = thick.get(THICKNESS_TRAVEL_MM)
        ckpt.save(len(solver.increments), solver=solver.state_dict(), contact=c.state_dict(), loop=loop_state,
                  runner=dict(hist=hist, count=out["count"], thick20=None if t20 is None else list(t20)))
    ck_args = {} if ckpt is None else dict(checkpoint_every=ckpt.every, on_checkpoint=on_checkpoint, resume=loop)
    if getattr(scene.output, "xdmf", True):
        from dolfinx import io
        out["xdmf"] = xf = io.XDMFFile(comm, str(output.xdmf_path), "w")
        xf.write_mesh(info["mesh"])
        Vc, vmap = s.V.collapse()
        out["umap"] = np.asarray(vmap)
        out["u"] = fem.Function(Vc, name="displacement")
        out["fields"] = [q.cell_mean(np.zeros(q.n), name=n) for n in
                         ("equivalent_plastic_strain", "von_mises_stress")]

    def write_fields(t):
        xf = out["xdmf"]
        if xf is None:
            return
        out["u"].x.array[:] = s.w.x.array[out["umap"]]
        out["u"].x.scatter_forward()
        eq, vm = out["fields"]
        q.cell_mean(q.eqps, out=eq)
        q.cell_mean(von_mises(q.tau_values), out=vm)    # Kirchhoff von Mises
        xf.write_function(out["u"], t)
        for f in out["fields"]:
            xf.write_function(f, t)

    if loop is None:
        write_fields(0.0)
    lam_20 = min(THICKNESS_TRAVEL_MM / travel, 1.0)

    def on_increment(solver):
        c.commit()
        rec = solver.increments[-1]
        d = travel * solver.lam_converged
        F = info["punch"].force()[1] / 1e3
        Fd = info["die"].force()[1] / 1e3
        pen = c.max_penetration()
        hist["d"].append(d)
        hist["F"].append(F)
        hist["pen"].append(pen)
        output.history(increment=rec["increment"], load_factor=solver.lam_converged, punch_displacement_mm=d,
                       punch_force_kN=F, die_force_kN=Fd, max_penetration_mm=pen,
                       newton_iterations=rec["iterations"])
        if abs(solver.lam_converged - lam_20) < 1e-12 and travel >= THICKNESS_TRAVEL_MM:  # (no 20 mm state below)
            thick[THICKNESS_TRAVEL_MM] = faces.thickness_strain(t_blank)
        out["count"] += 1
        if out["count"] % out["every"] == 0 or solver.lam_converged >= 1 - 1e-12:
            write_fields(d)
        return False

    def results(converged):
        F = np.asarray(hist["F"])
        i = int(np.argmax(F))
        eq = q.eqps
        j = int(np.argmax(eq)) if eq.size else 0
        loc = (float(eq[j]), float(r_qp[j])) if eq.size else (-1.0, 0.0)
        best = max(comm.allgather(loc))
        r0, es = thick["final"]
        k = int(np.argmin(es))
        res = dict(max_punch_force_kN=float(F[i]), punch_displacement_at_max_mm=float(hist["d"][i]),
                   final_punch_displacement_mm=float(hist["d"][-1]),
                   final_punch_force_kN=float(F[-1]),
                   max_penetration_mm=float(max(hist["pen"])),
                   max_penetration_fraction_of_thickness=float(max(hist["pen"]) / t_blank),
                   max_eqps=best[0], r0_of_max_eqps_mm=best[1],
                   min_thickness_strain=float(es[k]), r0_of_min_thickness_mm=float(r0[k]),
                   pole_thickness_strain=float(es[0]),
                   friction=friction, contact_law=law, penalty_N_mm3=info["penalty"],
                   tangential_penalty_N_mm3=info["tangential_penalty"],
                   cells=info["cells"], dofs=s.dofs, converged=converged,
                   increments=len(s.increments), newton_iterations=s.total_iterations,
                   element=m.element,
                   key_results=["final_punch_force_kN", "max_punch_force_kN", "pole_thickness_strain",
                                "min_thickness_strain"],
                   info_results=["max_penetration_mm", "final_punch_displacement_mm"], references={})
        if THICKNESS_TRAVEL_MM in thick:
            r20, e20 = thick[THICKNESS_TRAVEL_MM]
            k20 = int(np.argmin(e20))
            res.update(min_thickness_strain_at_20mm=float(e20[k20]), r0_of_min_thickness_at_20mm_mm=float(r20[k20]))
        return res

    def finish_outputs():
        thick["final"] = faces.thickness_strain(t_blank)
        d_final = travel * s.lam_converged
        cols = dict(travel_mm=[], r0_mm=[], thickness_strain=[])
        for key in (THICKNESS_TRAVEL_MM, "final"):
            if key not in thick or (key != "final" and abs(d_final - THICKNESS_TRAVEL_MM) < 1e-9):
                continue
            r0, es = thick[key]
            tv = THICKNESS_TRAVEL_MM if key != "final" else d_final
            cols["travel_mm"] += [tv] * len(r0)
            cols["r0_mm"] += list(r0)
            cols["thickness_strain"] += list(es)
        output.write_csv("thickness_strain", cols)
        if getattr(scene.output, "plots", True):
            output.draw_plots("punch_stretching", title=scene.name,
                              results=dict(friction=friction, contact_law=law))

    try:
        if lam_20 < 1.0:
            n1 = max(1, int(round(sv.increments * lam_20)))
            # (resumed: a leg already done returns at once; the saved loop state names its leg)
            s.run(increments=n1, min_increment=sv.min_increment, max_increment=sv.max_increment,
                  lam_end=lam_20, callback=on_increment, **ck_args)
            s.run(increments=max(1, sv.increments - n1), min_increment=sv.min_increment,
                  max_increment=sv.max_increment, lam_end=1.0, callback=on_increment, **ck_args)
        else:
            s.run(increments=sv.increments, min_increment=sv.min_increment, max_increment=sv.max_increment,
                  callback=on_increment, **ck_args)
    except RunError as e:
        finish_outputs()
        e.results.update(results(False))
        F = np.asarray(hist["F"])
        i = int(np.argmax(F))
        msg = (f"punch_stretching: stopped at {travel * s.lam_converged:.3f} mm of travel "
               f"(max punch force {F[i]:.3f} kN at {hist['d'][i]:.3f} mm")
        if i < len(F) - 1:
            msg += ", after the maximum: the sheet necks"
        raise RunError(msg + "). " + str(e), results=e.results) from None
    finally:
        if out["xdmf"] is not None:
            out["xdmf"].close()
    finish_outputs()
    return results(True)
