# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
#       format_version: '1.3'
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Hemispherical punch stretching: frictional contact
#
# A circular aluminium blank (radius 65.53 mm, thickness t0 = 1 mm, clamped at the rim) is
# stretched by a rigid hemispherical punch (radius 50.8 mm) over a die whose shoulder is a circle
# of radius 6.35 mm at the opening radius 59.18 mm (Lee, Wagoner & Nakamachi; seed paper).
# Swift hardening σy = 589 (10⁻⁴ + ε̄p)^0.216 MPa, E = 69 GPa, ν = 0.3, Q1/P0 axisymmetric.
#
# **Contact (penalty, `fenics_plast.contact`).** For a circular tool of centre c and radius R_t
# the gap and the normal at the body's current position x = X + u are exact UFL expressions:
#
#     g = |x − c| − R_t,     N = (x − c)/|x − c|,     p = ε ⟨−g⟩,
#
# the punch's centre moves up with the load factor λ along the scene's path table
# (`tools.punch.path`: y from 0 to 40 mm as t goes from 0 to 1), c(λ) = (0, −R_p + travel·λ).
#
# **Friction (Coulomb as elastoplastic slip).** With T = (N_z, −N_r), the slip increment
# Δs = (u − u_n) − (tool translation since the last converged increment) and a tangential penalty
# ε_T, the trial traction and the return map are
#
#     t_tr = T·t_n − ε_T T·Δs,         t = t_tr if |t_tr| ≤ μ p,   else μ p sign(t_tr),
#
# written with `ufl.conditional`, so `ufl.derivative` gives the consistent tangent. "Quasi-Coulomb"
# (the seed's choice, the default) freezes p and N at the last converged increment during Newton.
# The contact residual −∫ (p N + t T)·v 2πR dA0 uses a nodal (trapezoidal) rule on the facets and
# is added to the solver's R_u; t_n, N_n, p_n are stored at the nodes by `commit()`.
#
# Run: `mpirun -n 2 .venv/bin/python demos/punch_stretching.py [--coarse] [--mu 0.15] [--out DIR]`.

# %%
import time

import numpy as np
from dolfinx import fem, io

from _common import COMM, ROOT, draw_cells, figure, gather_cells, options, say, write_summary
from fenics_plast.contact import PenaltyContact
from fenics_plast.kinematics import Kinematics
from fenics_plast.material import Hardening, Material
from fenics_plast.meshing import mesh_from_file
from fenics_plast.problem import load_problem
from fenics_plast.build import tool_of
from fenics_plast.solvers.static import StaticSolver

args = options("punch_stretching", "Hemispherical punch stretching (contact and friction)",
               extra=[(("--mu",), dict(type=float, default=0.15, help="friction coefficient (default 0.15)")),
                      (("--law",), dict(default="quasi-coulomb", choices=["quasi-coulomb", "coulomb"]))])

# %% [markdown]
# ## Parameters (from `demos/punch_stretching.toml`; coarse: 20 × 1 cells, 20 mm of travel)
# `load_problem` reads and checks the scene file. `--mu` and `--law` set the friction of both
# contact pairs (`contact.punch.friction`, `contact.die.friction`, ...), as `--set` does on the
# command line. The blank's size and cells are the Gmsh parameters of `[mesh.parameters]`; the
# solver settings and the load steps are `[analysis]` and `[steps]`.

# %%
overrides = [f"contact.{pair}.{key}={value}" for pair in ("punch", "die")
             for key, value in (("friction", args.mu), ("law", args.law))]
if args.coarse:     # and only the first step (to 20 mm) below, in increments of at most 1 mm
    overrides += ["mesh.parameters.cells_radial=20", "mesh.parameters.cells_thickness=1",
                  "steps.to_20mm.increments=10", "analysis.max_increment=0.025"]
problem = load_problem(ROOT / "demos" / "punch_stretching.toml", overrides)
p, mat, sv, tl = problem.mesh.parameters, problem.materials["aluminium"], problem.analysis, problem.tools
travel = float(tl["punch"].path["y"].evaluate(t=1.0))      # punch travel at t = 1 [mm]
h = mat.hardening
material = Material(mat.E, mat.nu, Hardening("swift", K=h.K, eps0=h.eps0, n=h.n), model=mat.model)
t0 = p["thickness"]

# %% [markdown]
# ## Mesh, kinematics, solver and supports
# `mesh_from_file` meshes the scene's `meshes/circular_blank.geo`; its facet groups come back by
# name as (dimension, tag): `axis`, `lower` (z = 0, meets the punch), `upper` (z = t0, meets the
# die) and `rim` (clamped: `[boundary.clamp]`).

# %%
mesh, cell_tags, facet_tags, groups = mesh_from_file(COMM, problem.mesh_file, p)
tags = {name: tag for name, (dim, tag) in groups.items() if dim == 1}     # facet groups
kin = Kinematics(mesh, problem.mesh.geometry)
solver = StaticSolver(kin, material, element=problem.mesh.element, rtol=sv.rtol, atol=sv.atol,
                      max_iterations=sv.max_iterations, linesearch=sv.linesearch, verbose=False)
solver.add_dirichlet(0, facet_tags, tags["axis"], 0.0)
solver.add_dirichlet(0, facet_tags, tags["rim"], 0.0)
solver.add_dirichlet(1, facet_tags, tags["rim"], 0.0)

# %% [markdown]
# ## Contact forms
# `tool_of` turns each `[tools.<name>]` table into a `fenics_plast.tools.Circle` (the punch's
# centre follows its path table). One `ContactPair` per `[contact.<name>]` table (tool, facet
# group, penalty, friction, law) builds g, N, p, the friction return map and the residual;
# `attach()` adds the residual and its `ufl.derivative` to the solver (before `setup()` compiles
# the forms). The scene's penalty, 20 700 N/mm³, is 0.3 E/t0 (penetration below 0.5 % of the
# thickness). These forms are the definition; `fenics-plast run` evaluates the same law compiled,
# node by node (`PenaltyContact(solver)`, `compiled=True`: `fenics_plast.solvers.static_tool_contact`,
# held to the forms by `tests/test_static_tool_contact.py`).

# %%
tools = {name: tool_of(name, spec) for name, spec in tl.items()}
contact = PenaltyContact(solver, compiled=False)
pairs = {name: contact.add_pair(tools[c.tool], facet_tags, tags[c.group], penalty=c.penalty, friction=c.friction,
                                law=c.law, tangential_penalty=c.tangential_penalty)
         for name, c in problem.contact.items()}
punch, die = pairs["punch"], pairs["die"]
contact.attach()
solver.setup()
mu, law = punch.friction, punch.law
say(f"penalty {punch.penalty:.4g} N/mm^3, mu = {mu:g} ({law}), {solver.dofs} dofs")
say(f"punch gap g = {punch.g}")
say(f"contact residual: {len(contact.residual().integrals())} facet integral(s), "
    f"history space {punch.H.ufl_element()}")

# %% [markdown]
# ## Solve
# After every converged increment the contact history is committed; we record the punch and
# die forces (z components of ∫ traction 2πR dA0), the largest penetration and how many nodes
# touch / slip. Like the CLI runner, the load goes through the scene's steps, `to_20mm` (t = 0.5)
# and `to_40mm` (t = 1), so that an increment ends exactly at 20 mm of travel (where the seed
# reports thickness strains): with Quasi-Coulomb friction the result depends slightly on the
# increments (the friction bound lags by one increment). The coarse run stops after the first.

# %%
hist = dict(travel=[0.0], punch=[0.0], die=[0.0], penetration=[0.0])
u_out = solver.displacement_function()
V = u_out.function_space
xdmf = io.XDMFFile(COMM, str(args.out / "fields.xdmf"), "w")
xdmf.write_mesh(mesh)
eqps_dg = None


def on_increment(s):
    global eqps_dg
    contact.commit()
    hist["travel"].append(travel * s.lam_converged)
    hist["punch"].append(punch.force()[1] / 1e3)
    hist["die"].append(die.force()[1] / 1e3)
    hist["penetration"].append(contact.max_penetration())
    on, slip = punch.status()
    say(f"  travel {hist['travel'][-1]:6.2f} mm  punch {hist['punch'][-1]:7.3f} kN  die {hist['die'][-1]:8.3f} kN"
        f"  punch contact nodes {on:3d} (slipping {slip:3d})  Newton {s.increments[-1]['iterations']}")
    eqps_dg = s.qmap.cell_mean(s.qmap.eqps, name="eqps", out=eqps_dg)
    xdmf.write_function(s.displacement_function(), hist["travel"][-1])
    xdmf.write_function(eqps_dg, hist["travel"][-1])
    return False


wall0 = time.perf_counter()
steps = list(problem.steps.values())
for step in steps[:1] if args.coarse else steps:
    solver.run(increments=step.increments or sv.increments, min_increment=sv.min_increment,
               max_increment=step.max_increment or sv.max_increment, lam_end=step.end, callback=on_increment)
xdmf.close()
wall = time.perf_counter() - wall0

# %% [markdown]
# ## Thickness strain ln(t/t0) along the blank
# Lower and upper face nodes share their initial radius r0 (structured mesh): gather their
# current positions and take the distance.

# %%
u = solver.displacement_function()
n_own = V.dofmap.index_map.size_local
X = V.tabulate_dof_coordinates()[:n_own, :2]
x = X + u.x.array.reshape(-1, 2)[:n_own]
faces = {}
for name in ("lower", "upper"):
    nodes = fem.locate_dofs_topological(V, 1, facet_tags.find(tags[name]))
    nodes = nodes[nodes < n_own]
    rows = np.concatenate(COMM.allgather(np.column_stack([X[nodes, 0], x[nodes]])))
    faces[name] = rows[np.argsort(rows[:, 0])]
r0 = faces["lower"][:, 0]
thickness_strain = np.log(np.linalg.norm(faces["upper"][:, 1:] - faces["lower"][:, 1:], axis=1) / t0)

# %% [markdown]
# ## Results and plots

# %%
k = int(np.argmin(thickness_strain))
results = write_summary(args.out, dict(
    punch_displacement_mm=hist["travel"][-1], punch_force_kN=hist["punch"][-1],
    max_punch_force_kN=max(hist["punch"]), die_force_kN=hist["die"][-1],
    max_penetration_mm=max(hist["penetration"]), thickness_strain_at_start=float(thickness_strain[0]),
    min_thickness_strain=float(thickness_strain[k]), s0_of_min_thickness_strain_mm=float(r0[k]),
    punch_normal_force_kN=punch.normal_force() / 1e3, punch_tangential_force_kN=punch.tangential_force() / 1e3,
    friction=mu, law=law, increments=len(solver.increments),
    newton_iterations=solver.total_iterations, wall_time_s=wall, cells=mesh.topology.index_map(2).size_global,
    coarse=args.coarse))
for key in ("punch_displacement_mm", "punch_force_kN", "die_force_kN", "max_penetration_mm",
            "thickness_strain_at_start", "min_thickness_strain", "s0_of_min_thickness_strain_mm",
            "punch_normal_force_kN", "punch_tangential_force_kN", "increments", "newton_iterations", "wall_time_s"):
    say(f"{key:30s} {results[key]:.10g}")

polys, vals = gather_cells(V, u.x.array, solver.qmap.cell_mean(solver.qmap.eqps).x.array)
if COMM.rank == 0:
    fig, (ax0, ax1, ax2) = figure(3, width=4.4)
    ax0.plot(hist["travel"], hist["punch"], "o-", ms=3)
    ax0.set(xlabel="punch travel [mm]", ylabel="punch force [kN]", title=f"mu = {mu:g} ({law})")
    ax1.plot(r0, thickness_strain, ".-")
    ax1.set(xlabel="initial radius r0 [mm]", ylabel="ln(t / t0)",
            title=f"thickness strain at {hist['travel'][-1]:g} mm")
    for ax in (ax0, ax1):
        ax.grid(alpha=0.3)
    draw_cells(ax2, polys, vals, "equivalent plastic strain", mirror=False, cmap="inferno")
    a = np.linspace(0.0, np.pi, 200)
    Rp, zc = tl["punch"].radius, tl["punch"].center[1] + hist["travel"][-1]      # where the punch stopped
    rp, zp = Rp * np.cos(a / 2), zc + Rp * np.sin(a / 2)
    ax2.plot(rp[zp > -2.0], zp[zp > -2.0], "k-", lw=1, label="punch")
    Rd, (rc, zd) = tl["die"].radius, tl["die"].center
    b = np.pi + a / 2                                  # quarter of the shoulder that faces the blank
    ax2.plot(np.r_[rc + Rd * np.cos(b), p["radius"]], np.r_[zd + Rd * np.sin(b), t0], "b-", lw=1, label="die")
    ax2.set(xlabel="r [mm]", ylabel="z [mm]", title="deformed blank and tools")
    ax2.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(args.out / "punch_stretching.png", dpi=120)
say(f"results in {args.out}/ (punch_stretching.png, fields.xdmf, summary.json)")
