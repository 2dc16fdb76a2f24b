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
# # Necking of a round bar in tension: quasi-static Newton
#
# Simo's classic: a steel bar (radius R = 6.413 mm, length 53.334 mm) with a 1.8 % smaller radius
# at mid-length is pulled by 14 mm; a neck forms at mid-length and the force passes a maximum.
# Symmetry lets us model the upper half, 0 ≤ z ≤ L/2, with u_z = 0 on z = 0 (the neck), u_r = 0
# on the axis and u_z = ½ · 14 mm · λ on the gripped end (λ the load factor, 0 → 1).
#
# **Material.** J2 plasticity with Voce hardening
# σy(ε̄p) = 450 + 265 (1 − e^{−16.93 ε̄p}) + 129.24 ε̄p MPa, E = 206.9 GPa, ν = 0.29.
#
# **Weak form (Q1/P0 by F-bar).** Unknowns: Q1 displacement u and the DG0 cell dilatation θ:
#
#     R_u = ∫ (J/θ) τ̄ : (Grad v F⁻¹) 2πr dV = 0,        R_θ = ∫ (θ − J) q 2πr dV = 0,
#
# τ̄ the Kirchhoff stress from F̄ = (θ/J)^{1/3} F (`Kinematics.internal_virtual_work`,
# `Kinematics.dilatation_residual`). Newton's Jacobian uses the material's consistent spatial
# tangent a (δτ = a : δF̄ F̄⁻¹), stored per quadrature point next to τ by the `QuadratureMap`
# (`Kinematics.internal_virtual_work_derivative`): quadratic convergence.
#
# **A check by hand (Considère).** A bar in uniaxial stress reaches its maximum force where
# dσ/dε = σ; with the smallest section A_min = π(0.982 R)² this gives
# F_max ≈ σ(ε*) A_min e^{−ε*}. The finite-element maximum lies slightly above it (triaxial
# stress in the neck).
#
# Run: `mpirun -n 2 .venv/bin/python demos/bar_tension.py [--coarse] [--out DIR]`.

# %%
import time

import numpy as np
from dolfinx import fem, io
from mpi4py import MPI
from scipy.optimize import brentq

from _common import COMM, ROOT, draw_cells, figure, gather_cells, options, say, write_summary
from fenics_plast.kinematics import Kinematics
from fenics_plast.material import Hardening, Material
from fenics_plast.meshing import mesh_from_file
from fenics_plast.problem import load_problem
from fenics_plast.solvers.static import StaticSolver

args = options("bar_tension", "Necking of a round bar in tension (static Newton)")

# %% [markdown]
# ## Parameters (from `demos/bar_tension.toml`; coarse: 4 × 12 cells)
# `load_problem` reads and checks the scene file. The geometry is the Gmsh parameters of
# `[mesh.parameters]` (`length` is the modelled half), the solver settings are `[analysis]`, the
# material `[materials.steel]`, and the gripped end's displacement is `boundary.grip.value`, an
# expression of the load factor t (7 mm at t = 1).

# %%
overrides = ["mesh.parameters.cells_radial=4", "mesh.parameters.cells_axial=12"] if args.coarse else []
problem = load_problem(ROOT / "demos" / "bar_tension.toml", overrides)
p, mat, sv = problem.mesh.parameters, problem.materials["steel"], problem.analysis
R, half, imp = p["radius"], p["length"], p["imperfection"]
end_displacement = float(problem.boundary["grip"].value.evaluate(t=1.0))   # of the modelled half [mm]
h = mat.hardening
material = Material(mat.E, mat.nu, Hardening("voce", yield_stress=h.yield_stress, Q=h.Q, b=h.b,
                                             modulus=h.modulus), model=mat.model)

# %% [markdown]
# ## Mesh and kinematics
# `mesh_from_file` meshes the scene's `meshes/round_bar.geo`, which tapers the radius linearly from
# R at z = L/2 to R(1 − 0.018) at z = 0; its facet groups (`axis`, `bottom`, `top`, `outer`) come
# back by name as (dimension, tag).

# %%
mesh, cell_tags, facet_tags, groups = mesh_from_file(COMM, problem.mesh_file, p)
tags = {name: tag for name, (dim, tag) in groups.items() if dim == 1}     # facet groups
kin = Kinematics(mesh, problem.mesh.geometry)

# %% [markdown]
# ## Spaces, forms, boundary conditions
# `StaticSolver` builds the mixed space W = [Q1]² × DG0, the quadrature map (τ and the 9 × 9
# tangent per point), R = R_u + R_θ and its Jacobian, and wraps them in a PETSc SNES (Newton,
# MUMPS). Dirichlet values are multiplied by the load factor λ.

# %%
solver = StaticSolver(kin, material, element=problem.mesh.element, rtol=sv.rtol, atol=sv.atol,
                      max_iterations=sv.max_iterations, linesearch=sv.linesearch, verbose=False)
solver.add_dirichlet(0, facet_tags, tags["axis"], 0.0)                 # u_r = 0 on the axis
solver.add_dirichlet(1, facet_tags, tags["bottom"], 0.0)               # symmetry plane z = 0, where the neck forms
solver.add_dirichlet(1, facet_tags, tags["top"], end_displacement)     # gripped end, times t
solver.setup()
top_dofs = solver.constrained_dofs(1, facet_tags, tags["top"])
say(f"W = {solver.W.ufl_element()}\n{solver.dofs} dofs, {solver.qmap.n} quadrature points on rank 0")
say(f"residual: {len(solver.R_int.integrals())} integral(s) over {solver.R_int.integrals()[0].integral_type()}, "
    f"tau in a quadrature space ({solver.qmap.nq} points per cell), tangent shape {solver.qmap.a.ufl_shape}")

# %% [markdown]
# ## Solve: load increments with Newton, recording the end force and the neck radius
# The force is the reaction on the gripped end, the sum of the assembled internal force R_u over
# its u_z dofs (the 2π of the weight is in the form, so this is the total force in N).

# %%
Vu = solver.displacement_function().function_space      # collapsed CG1 space of u
bottom_nodes = fem.locate_dofs_topological(Vu, 1, facet_tags.find(tags["bottom"]))
hist = dict(elongation=[0.0], force=[0.0], neck=[R * (1 - imp)], iterations=[0])
xdmf = io.XDMFFile(COMM, str(args.out / "fields.xdmf"), "w")
xdmf.write_mesh(mesh)
eqps_dg = None


def on_increment(s):
    global eqps_dg
    u = s.displacement_function()                   # CG1 copy of the u part of w
    x = Vu.tabulate_dof_coordinates()[bottom_nodes, 0] + u.x.array.reshape(-1, 2)[bottom_nodes, 0]
    hist["elongation"].append(2 * end_displacement * s.lam_converged)
    hist["force"].append(s.reaction(top_dofs) / 1e3)
    hist["neck"].append(COMM.allreduce(float(x.max()) if x.size else -np.inf, op=MPI.MAX))
    hist["iterations"].append(s.increments[-1]["iterations"])
    say(f"  elongation {hist['elongation'][-1]:6.3f} mm  force {hist['force'][-1]:8.3f} kN  "
        f"neck radius {hist['neck'][-1]:.4f} mm  Newton {hist['iterations'][-1]}")
    eqps_dg = s.qmap.cell_mean(s.qmap.eqps, name="eqps", out=eqps_dg)
    xdmf.write_function(u, hist["elongation"][-1])
    xdmf.write_function(eqps_dg, hist["elongation"][-1])
    return False                                    # True would stop the run


t0 = time.perf_counter()
solver.run(increments=sv.increments, min_increment=sv.min_increment, max_increment=sv.max_increment,
           callback=on_increment)
xdmf.close()
wall = time.perf_counter() - t0

# %% [markdown]
# ## Results: maximum force against Considère's estimate, neck, plots

# %%
sy = lambda e: h.yield_stress + h.Q * (1 - np.exp(-h.b * e)) + h.modulus * e     # noqa: E731
dsy = lambda e: h.Q * h.b * np.exp(-h.b * e) + h.modulus                        # noqa: E731
eps_star = brentq(lambda e: dsy(e) - sy(e), 1e-6, 5.0)
considere = sy(eps_star) * np.pi * (R * (1 - imp)) ** 2 * np.exp(-eps_star) / 1e3
i = int(np.argmax(hist["force"]))
results = write_summary(args.out, dict(
    max_force_kN=hist["force"][i], elongation_mm_at_max_force_kN=hist["elongation"][i],
    considere_force_kN=considere, considere_strain=eps_star, neck_radius_mm=hist["neck"][-1],
    force_kN=hist["force"][-1], increments=len(solver.increments),
    newton_iterations=solver.total_iterations, wall_time_s=wall, cells=mesh.topology.index_map(2).size_global,
    coarse=args.coarse))
for k in ("max_force_kN", "elongation_mm_at_max_force_kN", "considere_force_kN", "neck_radius_mm",
          "increments", "newton_iterations", "wall_time_s"):
    say(f"{k:30s} {results[k]:.10g}")

u = solver.displacement_function()
polys, vals = gather_cells(Vu, u.x.array, solver.qmap.cell_mean(solver.qmap.eqps).x.array)
if COMM.rank == 0:
    fig, (ax0, ax1) = figure(2)
    ax0.plot(hist["elongation"], hist["force"], "o-", ms=3, label="finite elements")
    ax0.axhline(considere, color="k", ls="--", lw=0.8, label="Considère, smallest section")
    ax0.set(xlabel="elongation [mm]", ylabel="force [kN]", title="Round bar in tension")
    ax0.grid(alpha=0.3)
    ax0.legend()
    full = np.concatenate([polys, polys * np.array([1.0, -1.0])])    # mirror the half bar in z
    draw_cells(ax1, full, np.concatenate([vals, vals]), "equivalent plastic strain", cmap="inferno")
    ax1.set(xlabel="r [mm]", ylabel="z [mm]", title=f"elongation {hist['elongation'][-1]:.3g} mm")
    fig.tight_layout()
    fig.savefig(args.out / "bar_tension.png", dpi=120)
say(f"results in {args.out}/ (bar_tension.png, fields.xdmf, summary.json)")
