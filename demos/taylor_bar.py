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
# # Taylor bar impact: explicit dynamics
#
# A copper bar (radius R = 3.2 mm, length L = 32.4 mm) flies at v0 = 227 m/s against a rigid,
# frictionless wall and mushrooms for 80 µs (seed paper; reference final radius 7.03–7.15 mm,
# final length 21.42–21.47 mm, max ε̄p 2.96–3.13 on 6 × 36 cells).
#
# **Model.** Axisymmetric (x = r, y = z), weight w = 2πr. The momentum balance in the reference
# configuration, with the Q1/P0 (F-bar) internal force of `fenics_plast.kinematics`:
#
#     ∫ ρ0 ü·v w dV + ∫ (J/θ) τ̄ : (Grad v F⁻¹) w dV = 0,      F̄ = (θ/J)^{1/3} F,
#
# θ the cell's mean dilatation ∫J w dV / ∫w dV, τ̄ the Kirchhoff stress of the material
# (J2 plasticity, linear hardening σy = 400 + 100 ε̄p MPa) driven by the incremental deformation
# gradient Fu = F̄ F̄ₙ⁻¹ at every quadrature point.
#
# **Time integration.** Lumped (row-sum) mass Mᵢ = ∫ρ Nᵢ w dV and central differences,
#
#     v_{n+½} = v_n + ½Δt a_n,   u_{n+1} = u_n + Δt v_{n+½},   a_{n+1} = −M⁻¹ f_int(u_{n+1}),
#     v_{n+1} = v_{n+½} + ½Δt a_{n+1},
#
# stable for Δt ≤ h_min / c with c = √((λ + 2μ)/ρ) (we use 0.8 of it). Sliding supports:
# v_r = 0 on the axis, v_z = 0 on the impact face.
#
# Run: `mpirun -n 2 .venv/bin/python demos/taylor_bar.py [--coarse] [--out DIR]`.

# %%
import time

import numpy as np
from dolfinx import fem, io
from mpi4py import MPI

from _common import COMM, ROOT, draw_cells, figure, gather_cells, options, say, write_summary
from fenics_plast.kinematics import Kinematics
from fenics_plast.material import Hardening, Material
from fenics_plast.meshing import mesh_from_file
from fenics_plast.problem import load_problem
from fenics_plast.solvers.explicit import ExplicitDynamics

args = options("taylor_bar", "Taylor bar impact (explicit dynamics)")

# %% [markdown]
# ## Parameters
# They come from the shipped scene file `demos/taylor_bar.toml`, read by `load_problem` (units: mm,
# N, MPa, s; the file gives the density in kg/m³, converted to tonne/mm³ on reading, the end time
# in µs, converted to s, and the initial velocity `initial_velocity.bar.value` in m/s). The bar's
# dimensions and cell counts are the Gmsh parameters of `[mesh.parameters]`. The coarse setting
# halves the mesh in each direction.

# %%
overrides = ["mesh.parameters.cells_radial=3", "mesh.parameters.cells_axial=18"] if args.coarse else []
problem = load_problem(ROOT / "demos" / "taylor_bar.toml", overrides)
p, mat = problem.mesh.parameters, problem.materials["copper"]
R, L = p["radius"], p["length"]
rho = mat.density                                                   # tonne/mm^3
v0 = -float(problem.initial_velocity["bar"].value[1].evaluate()) * 1e3  # m/s (towards -z) -> mm/s
end_time = problem.analysis.end_time                                # s
say(f"R = {R} mm, L = {L} mm, {p['cells_radial']} x {p['cells_axial']} cells, "
    f"v0 = {v0 / 1e3:g} m/s, rho = {rho:.4g} t/mm^3, {end_time * 1e6:g} us")

# %% [markdown]
# ## Mesh, kinematics and material
# `mesh_from_file` meshes the scene's `mesh.file`, `meshes/round_bar.geo`, with Gmsh on rank 0
# (its parameters set from `[mesh.parameters]`) and distributes it; the Gmsh physical groups come
# back by name as (dimension, tag): the facet groups `axis`, `bottom`, `top`, `outer`.
# `Kinematics` carries the 3 × 3 axisymmetric F (hoop stretch 1 + u_r/r), the weight 2πr and the
# quadrature measure.

# %%
mesh, cell_tags, facet_tags, groups = mesh_from_file(COMM, problem.mesh_file, p)
tags = {name: tag for name, (dim, tag) in groups.items() if dim == 1}     # facet groups
kin = Kinematics(mesh, problem.mesh.geometry)
h = mat.hardening
material = Material(mat.E, mat.nu, Hardening("linear", yield_stress=h.yield_stress, modulus=h.modulus),
                    model=mat.model)
lam, mu = material.lame
say(f"{mesh.topology.index_map(2).size_global} cells; Lame lambda = {lam:.5g} MPa, mu = {mu:.5g} MPa, "
    f"wave speed {material.wave_speed(rho) / 1e3:.1f} m/s; groups {sorted(tags)}")

# %% [markdown]
# ## Spaces and forms
# `ExplicitDynamics` builds the CG1 displacement space, the DG0 dilatation θ, a
# `QuadratureMap` (the Kirchhoff stress τ lives in a quadrature space; its update calls the
# numba material kernel on the Fu expression) and compiles two forms once:
# the internal force `kin.internal_virtual_work(u, θ, τ, v)` and the lumped mass
# `ρ (1, 1)·v w dx`. The velocity constraints are (component, facets) pairs: the scene's
# `[boundary.axis]` (type "axis") and `[boundary.wall]` (type "fixed", component z).
#
# Check: the lumped masses add up to the bar's mass ρπR²L (per component).

# %%
velocity_bcs = [(0, facet_tags.find(tags["axis"])),      # v_r = 0 on the axis
                (1, facet_tags.find(tags["bottom"]))]    # v_z = 0 on the wall
solver = ExplicitDynamics(mesh, kin, material, rho, velocity_bcs, element=problem.mesh.element)
qmap = solver.qmap
mass_fe = COMM.allreduce(solver.mass.reshape(-1, 2)[: solver.n_own // 2, 1].sum())
mass_exact = rho * np.pi * R ** 2 * L
say(f"spaces: u {solver.V.ufl_element()}, tau in a quadrature space "
    f"({qmap.nq} points per cell); dofs {solver.dofs_global}")
say(f"mass: lumped {mass_fe:.10e} t, rho pi R^2 L {mass_exact:.10e} t")

# %% [markdown]
# ## Solve
# Initial velocity −v0 along z (zero on the constrained dofs: the impact face starts at rest
# along z, so the initial kinetic energy is ½ (m − m_face) v0² with m_face = ρπR²h/2, h the
# first cell's height). `run` adapts Δt = 0.8 h_min/c and calls `on_row` at equally spaced times,
# where we record the bar's shape and energies and write the fields to XDMF.

# %%
solver.set_velocity((0.0, -v0))
bottom = fem.locate_dofs_topological(solver.V, 1, facet_tags.find(tags["bottom"]))
hist = {k: [] for k in ("t_us", "length", "radius", "kinetic", "plastic", "error")}
xdmf = io.XDMFFile(COMM, str(args.out / "fields.xdmf"), "w")
xdmf.write_mesh(mesh)
eqps_dg = None


def shape():
    """(current length, current radius of the impact face) [mm], all ranks."""
    x = solver.nodal_positions()
    z_top = x[:, 1].max() if x.size else -np.inf
    r_face = x[bottom, 0].max() if bottom.size else -np.inf
    return COMM.allreduce(float(z_top), op=MPI.MAX), COMM.allreduce(float(r_face), op=MPI.MAX)


def on_row(s, t):
    global eqps_dg
    length, radius = shape()
    e = s.energies()
    for k, val in zip(hist, (t * 1e6, length, radius, e["kinetic"] * 1e-3, e["plastic"] * 1e-3,
                             e["balance_error"])):
        hist[k].append(val)
    if len(hist["t_us"]) % 8 == 1 or t >= end_time * (1 - 1e-12):
        eqps_dg = qmap.cell_mean(qmap.eqps, name="eqps", out=eqps_dg)
        xdmf.write_function(s.u, t * 1e6)
        xdmf.write_function(eqps_dg, t * 1e6)


t0 = time.perf_counter()
stats = solver.run(end_time, dt_safety=problem.analysis.dt_safety, rows=41 if args.coarse else 161,
                   on_row=on_row, progress=4)
xdmf.close()
wall = time.perf_counter() - t0

# %% [markdown]
# ## Results
# Final shape, plastic strain, and the energy balance |KE + W_int − KE0| / KE0 (the wall is fixed,
# so it does no work). The plot shows the deformed section coloured by ε̄p and the histories.

# %%
e = solver.energies()
ke0_exact = 0.5 * rho * np.pi * R ** 2 * (L - 0.5 * L / p["cells_axial"]) * v0 ** 2
results = write_summary(args.out, dict(
    length_mm=hist["length"][-1], radius_mm=hist["radius"][-1], max_eqps=solver.max_eqps(),
    initial_kinetic_energy_J=solver.KE0 * 1e-3, initial_kinetic_energy_exact_J=ke0_exact * 1e-3,
    plastic_dissipation_J=e["plastic"] * 1e-3, energy_balance_error=e["balance_error"],
    lumped_mass_t=mass_fe, exact_mass_t=mass_exact, steps=stats["steps"], wall_time_s=wall,
    cells=solver.cells_global, coarse=args.coarse))
for k in ("length_mm", "radius_mm", "max_eqps", "initial_kinetic_energy_J",
          "initial_kinetic_energy_exact_J", "energy_balance_error", "steps", "wall_time_s"):
    say(f"{k:32s} {results[k]:.10g}")

eqps_cells = qmap.cell_mean(qmap.eqps).x.array
polys, vals = gather_cells(solver.V, solver.u.x.array, eqps_cells)
if COMM.rank == 0:
    fig, (ax0, ax1) = figure(2)
    draw_cells(ax0, polys, vals, "equivalent plastic strain", cmap="inferno")
    ax0.plot([-R, -R, R, R], [0, L, L, 0], "c--", lw=0.8)
    ax0.set(xlabel="r [mm]", ylabel="z [mm]", title=f"t = {end_time * 1e6:g} us")
    ax1.plot(hist["t_us"], hist["length"], label="length [mm]")
    ax1.plot(hist["t_us"], hist["radius"], label="impact-face radius [mm]")
    ax1.plot(hist["t_us"], np.array(hist["kinetic"]) / 10, label="kinetic energy [10 J]")
    ax1.set(xlabel="time [us]", title="Taylor bar histories")
    ax1.grid(alpha=0.3)
    ax1.legend()
    fig.tight_layout()
    fig.savefig(args.out / "taylor_bar.png", dpi=120)
say(f"results in {args.out}/ (taylor_bar.png, fields.xdmf, summary.json)")
