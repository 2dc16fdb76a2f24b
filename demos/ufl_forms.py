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
# # The UFL forms of fenics-plast, evaluated on a tiny mesh
#
# This notebook (paired with `demos/ufl_forms.py` in jupytext's percent format) opens the
# pieces the solvers are made of:
#
# 1. the axisymmetric kinematics (`fenics_plast.kinematics.Kinematics`): the 3 × 3 F with the
#    hoop stretch, and F-bar;
# 2. the current-configuration residual ∫σ:∇ₓv dv written on the reference mesh;
# 3. the quadrature callback (`fenics_plast.quadrature.QuadratureMap`): how the material
#    update feeds the Kirchhoff stress into the forms;
# 4. the contact and friction terms (`fenics_plast.contact`).
#
# Each form is printed, assembled on a 2 × 2 mesh and compared with a closed-form answer.
# Units: mm, N, MPa.

# %%
import json
import os
import sys
from pathlib import Path

import numpy as np
import ufl
from dolfinx import fem
from dolfinx import mesh as dm
from dolfinx.fem import petsc as fpetsc
from mpi4py import MPI

from fenics_plast import dolfinx_compat as dc      # the calls that differ between dolfinx 0.5 and 0.9
from fenics_plast.contact import PenaltyContact
from fenics_plast.kinematics import Kinematics
from fenics_plast.material import Hardening, Material
from fenics_plast.material.point import uniaxial_stress
from fenics_plast.quadrature import QuadratureMap
from fenics_plast.solvers.static import StaticSolver
from fenics_plast.tools import Plane, piecewise_path

comm = MPI.COMM_WORLD
r1, r2, height = 1.0, 2.0, 1.0          # a ring section: r in [1, 2] mm, z in [0, 1] mm
mesh = dm.create_rectangle(comm, [np.array([r1, 0.0]), np.array([r2, height])], [2, 2],
                           dm.CellType.quadrilateral)
kin = Kinematics(mesh, "axisymmetric")
V = dc.vector_space(mesh)                   # CG1 displacements, 2 components
D0 = dc.function_space(mesh, "DG", 0)
u = fem.Function(V, name="u")
n_cells = mesh.topology.index_map(2).size_local
cells = np.arange(n_cells, dtype=np.int32)
print(f"{n_cells} cells, {V.dofmap.index_map.size_global} nodes, quadrature degree {kin.degree}")

# %% [markdown]
# ## 1. Axisymmetric kinematics
# With x = (r, z) and u = (u_r, u_z), the deformation gradient in the (r, z, θ) axes is
#
#     F = [[1 + ∂u_r/∂r, ∂u_r/∂z, 0], [∂u_z/∂r, 1 + ∂u_z/∂z, 0], [0, 0, 1 + u_r/r]]:
#
# F_θθ is the hoop stretch, the current over the reference radius. The weight w = 2πr turns
# integrals over the section into totals over the revolution.

# %%
print("F =", kin.F(u))
print("w =", kin.weight)

# %% [markdown]
# Evaluate F at the quadrature points for u_r = a r + s z, u_z = c z: then F_rr = 1 + a,
# F_rz = s, F_zz = 1 + c and the hoop stretch 1 + a + s z / r varies over the mesh. A compiled
# `fem.Expression` evaluates the UFL at the reference quadrature points of every cell.

# %%
a, s, c = 0.10, 0.05, -0.08
u.interpolate(lambda x: np.vstack([a * x[0] + s * x[1], c * x[1]]))
pts, _ = dc.quadrature_rule("quadrilateral", kin.degree)
F_qp = dc.eval_expression(fem.Expression(kin.F(u), pts), mesh, cells).reshape(-1, 3, 3)
X_qp = dc.eval_expression(fem.Expression(kin.x, pts), mesh, cells).reshape(-1, 2)
F_exact = np.zeros_like(F_qp)
F_exact[:, 0, 0], F_exact[:, 0, 1], F_exact[:, 1, 1] = 1 + a, s, 1 + c
F_exact[:, 2, 2] = 1 + a + s * X_qp[:, 1] / X_qp[:, 0]
print(f"{len(F_qp)} points; max |F - F_exact| = {np.abs(F_qp - F_exact).max():.2e}")
print("hoop stretch at the points:", np.round(F_qp[:, 2, 2], 4))

# %% [markdown]
# ### F-bar (Q1/P0)
# The element's dilatation θ is a DG0 field, the cell mean of J = det F with the weight w. F-bar
# replaces the volumetric part of F by θ:  F̄ = (θ/J)^{1/3} F, so det F̄ = θ while the isochoric
# part F̄/det F̄^{1/3} = F/J^{1/3} is untouched. That removes volumetric locking of Q1 in
# (nearly) incompressible plastic flow.
#
# θ = ∫ J w q dV / ∫ w q dV for the DG0 test function q: the DG0 mass matrix is diagonal, so the
# "projection" is a division of two assembled vectors.

# %%
def cell_mean_dilatation(u_fun):
    """theta (DG0): the w-weighted cell mean of J = det F(u)."""
    q = ufl.TestFunction(D0)
    num = fpetsc.assemble_vector(fem.form(kin.J(u_fun) * q * kin.weight * kin.dx))
    den = fpetsc.assemble_vector(fem.form(q * kin.weight * kin.dx))
    theta = fem.Function(D0, name="theta")
    theta.x.array[: len(num.array)] = num.array / den.array
    theta.x.scatter_forward()
    return theta


u.interpolate(lambda x: np.vstack([0.2 * x[0] ** 2 - 0.1 * x[1], 0.15 * x[0] * x[1]]))   # J varies in a cell
theta = cell_mean_dilatation(u)
J_qp = dc.eval_expression(fem.Expression(kin.J(u), pts), mesh, cells)
Fbar = kin.Fbar(u, theta)
detFbar_qp = dc.eval_expression(fem.Expression(ufl.det(Fbar), pts), mesh, cells)
iso = fem.Expression(Fbar / ufl.det(Fbar) ** (1 / 3) - kin.F(u) / kin.J(u) ** (1 / 3), pts)
print("J at the 4 points of cell 0:       ", np.round(J_qp[0], 5))
print("det Fbar at the 4 points of cell 0:", np.round(detFbar_qp[0], 5), " theta =", round(theta.x.array[0], 5))
fbar_error = np.abs(detFbar_qp - theta.x.array[:n_cells, None]).max()
iso_error = np.abs(dc.eval_expression(iso, mesh, cells)).max()
print(f"J varies by {np.ptp(J_qp, axis=1).max():.3f} within a cell; max |det Fbar - theta| = {fbar_error:.1e}, "
      f"max |iso(Fbar) - iso(F)| = {iso_error:.1e}")

# %% [markdown]
# ## 2. The current-configuration residual
# The weak form ∫ σ : ∇ₓv dv over the deformed body, pulled back to the reference mesh
# (dv = J dV, ∇ₓv = Grad v F⁻¹) and written with the F-bar Kirchhoff stress τ̄ = θ σ̄:
#
#     R_u(v) = ∫ (J/θ) τ̄ : (Grad v F⁻¹) w dV.
#
# τ̄ is not a UFL expression: it is a coefficient in a *quadrature space* (one 3 × 3 value per
# quadrature point), filled by the material. Every form that touches it must use the same
# quadrature degree and scheme: `kin.dx` carries them.

# %%
QT = dc.quadrature_space(mesh, kin.degree, (3, 3))     # 3 x 3 values at each point of the rule
tau = fem.Function(QT, name="tau")
v = ufl.TestFunction(V)
R_u = kin.internal_virtual_work(u, theta, tau, v)
print(R_u)

# %% [markdown]
# **Check.** Deform the ring homogeneously (u_r = a r, u_z = c z) and put a uniform Cauchy
# stress σ with σ_rr = σ_θθ (divergence-free in cylindrical coordinates) into τ̄ = θσ. Then
# R_u is the virtual work of the boundary tractions σn on the *current* boundary: the z-forces
# of the top nodes add up to σ_zz times the current top area π(1 + a)²(r2² − r1²), and all
# z-forces add up to zero.

# %%
u.interpolate(lambda x: np.vstack([a * x[0], c * x[1]]))
theta = cell_mean_dilatation(u)
sigma = np.array([[30.0, 0.0, 0.0], [0.0, 100.0, 0.0], [0.0, 0.0, 30.0]])      # MPa
nq = len(pts)
blocks = dc.cell_dofs(QT)[:n_cells].reshape(-1)     # dof block of each (cell, point)
tau.x.array.reshape(-1, 9)[blocks] = np.repeat(theta.x.array[:n_cells], nq)[:, None] * sigma.reshape(1, 9)
tau.x.scatter_forward()
R_form = fem.form(kin.internal_virtual_work(u, theta, tau, v))
b = fpetsc.assemble_vector(R_form)
f = b.array.reshape(-1, 2)
top = dm.locate_entities_boundary(mesh, 0, lambda x: np.isclose(x[1], height))
top_nodes = fem.locate_dofs_topological(V, 0, top)
expected = sigma[1, 1] * np.pi * (1 + a) ** 2 * (r2 ** 2 - r1 ** 2)
top_force = f[top_nodes, 1].sum()
print(f"sum of top z-forces {top_force:.10f} N, sigma_zz x current area {expected:.10f} N")
print(f"sum of all z-forces {f[:, 1].sum():.2e} N")

# %% [markdown]
# ## 3. The quadrature callback
# A `QuadratureMap` holds a compiled expression of the incremental deformation gradient
# Fu = F̄(u, θ) F̄(u_n, θ_n)⁻¹ and the material state (b_e⁻¹, ε̄p) at each point. One
# `update()`:
#
# 1. evaluates Fu at the quadrature points of the owned cells (`fem.Expression.eval`);
# 2. runs the numba material kernel `material.update_into(Fu, binv_n, eqps_n, ...)` from the
#    committed state;
# 3. writes τ (and the 9 × 9 consistent tangent) into the quadrature Functions, which the
#    compiled residual and Jacobian forms read at their next assembly.
#
# `commit()` makes the trial state the new committed state (after a converged Newton solve).
# The static solver calls `update()` inside its SNES residual callback; the explicit one once
# per time step.
#
# **Check.** Drive the ring through a homogeneous uniaxial-stress path, F = diag(λ_t, λ_a, λ_t),
# with the stretches taken from the material-point driver (which finds λ_t such that the lateral
# stresses vanish), and compare the FE top force with σ_axial × current area.

# %%
material = Material(E=117e3, nu=0.35, hardening=Hardening("linear", yield_stress=400.0, modulus=100.0))
path = uniaxial_stress(material, log_strain=0.3, steps=30)          # uniaxial along axis 0
u_n = fem.Function(V, name="u_n")
theta_fun, theta_n = fem.Function(D0, name="theta"), fem.Function(D0, name="theta_n")
theta_fun.x.array[:] = theta_n.x.array[:] = 1.0
qmap = QuadratureMap(mesh, kin, material, kin.Fu(u, theta_fun, u_n, theta_n))
R_form = fem.form(kin.internal_virtual_work(u, theta_fun, qmap.tau, v))
strain, force_fe, force_point = [0.0], [0.0], [0.0]
u.x.array[:] = 0.0
for la, lt, s_ax in zip(path["axial_stretch"][1:], path["lateral_stretch"][1:], path["cauchy_axial_MPa"][1:]):
    u_n.x.array[:] = u.x.array
    theta_n.x.array[:] = theta_fun.x.array
    u.interpolate(lambda x: np.vstack([(lt - 1) * x[0], (la - 1) * x[1]]))
    theta_fun.x.array[:] = cell_mean_dilatation(u).x.array
    qmap.update()                        # Fu -> material -> tau, tangent
    qmap.commit()
    b = fpetsc.assemble_vector(R_form)
    strain.append(np.log(la))
    force_fe.append(b.array.reshape(-1, 2)[top_nodes, 1].sum() / 1e3)
    force_point.append(s_ax * np.pi * lt ** 2 * (r2 ** 2 - r1 ** 2) / 1e3)
rel = np.max(np.abs(np.subtract(force_fe, force_point))) / np.max(np.abs(force_point))
print(f"max eqps {qmap.eqps.max():.4f}; FE vs material point: max relative difference {rel:.1e}")

# %% [markdown]
# ## 4. Contact and friction terms
# A `PenaltyContact` adds to a solver's residual, for each rigid tool, the terms below
# (x = X + u the current position, w the nodal weight 2πR, a nodal rule on the facets); with
# `compiled=False` as UFL forms, their definition (runs evaluate them compiled, node by node):
#
#     g = (x − p(λ))·N,   p = ε⟨−g⟩,   t_tr = T·t_n − ε_T T·Δs,   t = clamp(t_tr, −μp, μp),
#     R_c(v) = −∫ (p N + t T)·v w dA0.
#
# We press a flat wall (normal N = e_z) up into the bottom face of the ring by δ (load factor
# 0 → 0.5) and slide it along r (0.5 → 1) while *prescribing* u = 0: no solve, we just
# evaluate the forms. Expected: normal force ε δ π (r2² − r1²); friction force ε_T × slip while
# sticking, then μ × normal force (Quasi-Coulomb: the normal force of the last commit).

# %%
eps, mu, delta, slide = 1.0e3, 0.3, 0.01, 0.01
solver = StaticSolver(kin, Material(1000.0, 0.3), verbose=False)
facets = dm.locate_entities_boundary(mesh, 1, lambda x: np.isclose(x[1], 0.0))
bottom_tags = dm.meshtags(mesh, 1, np.sort(facets).astype(np.int32), np.full(len(facets), 1, np.int32))
contact = PenaltyContact(solver, eps, friction=mu, law="quasi-coulomb", compiled=False)   # as forms
wall = Plane(point=(0.0, 0.0), normal=(0.0, 1.0),       # path: load factors, then dx and dy at each [mm]
             path=piecewise_path([0.0, 0.5, 1.0], [0.0, 0.0, slide], [0.0, delta, delta]))
pair = contact.add_tool(wall, bottom_tags, 1)
print("gap g =", pair.g)
print("pressure p =", pair.p)

solver.set_load(0.5)                        # wall pressed in by delta, u = 0
N_force = pair.normal_force()
print(f"normal force {N_force:.10f} N, eps delta pi (r2^2 - r1^2) = {eps * delta * np.pi * (r2**2 - r1**2):.10f} N")
contact.commit()                            # history: p_n, N_n, t_n at the nodes
slips, friction_force = [], []
for lam in np.linspace(0.5, 1.0, 41):
    solver.set_load(lam)
    slips.append(slide * (lam - 0.5) / 0.5)
    friction_force.append(pair.tangential_force())
stick = eps * np.array(slips) * np.pi * (r2**2 - r1**2)
print(f"stick: {friction_force[4]:.6f} N vs eps_T slip area {stick[4]:.6f} N; "
      f"slip: {friction_force[-1]:.6f} N vs mu N {mu * N_force:.6f} N; nodes (contact, slipping) {pair.status()}")

# %% [markdown]
# ## Plots: the quadrature callback's uniaxial force, and the friction return map
# The PNG goes to `results/demo_ufl_forms/` (or `$FENICS_PLAST_DEMO_OUT`), relative to the
# working directory.

# %%
from matplotlib.backends.backend_agg import FigureCanvasAgg   # noqa: E402
from matplotlib.figure import Figure                          # noqa: E402

fig = Figure(figsize=(10, 4))
FigureCanvasAgg(fig)
ax0, ax1 = fig.subplots(1, 2)
ax0.plot(strain, force_point, "-", label="material point x current area")
ax0.plot(strain, force_fe, "o", ms=4, label="FE: QuadratureMap + R_u")
ax0.set(xlabel="axial log strain", ylabel="axial force [kN]", title="uniaxial stress, ring section")
ax1.plot(slips, friction_force, "o-", ms=3, label="tangential force (form)")
ax1.plot(slips, np.minimum(stick, mu * N_force), "k--", lw=0.8, label="min(eps_T s A, mu N)")
ax1.set(xlabel="wall slide s [mm]", ylabel="friction force [N]", title="friction return map")
for ax in (ax0, ax1):
    ax.grid(alpha=0.3)
    ax.legend()
fig.tight_layout()
out = Path(os.environ.get("FENICS_PLAST_DEMO_OUT", "results/demo_ufl_forms"))
out.mkdir(parents=True, exist_ok=True)
fig.savefig(out / "ufl_forms.png", dpi=110)
if "ipykernel" in sys.modules:               # in Jupyter: show it
    from IPython.display import Image, display
    display(Image(filename=str(out / "ufl_forms.png")))
print(f"plot written to {out / 'ufl_forms.png'}")

# %% [markdown]
# The numbers the test suite checks (`tests/test_demos.py` runs this notebook), also written to
# `checks.json` next to the plot:

# %%
checks = dict(F_error=np.abs(F_qp - F_exact).max(), fbar_det_error=fbar_error, fbar_iso_error=iso_error,
              top_force_N=top_force, top_force_exact_N=expected, uniaxial_relative_difference=rel,
              normal_force_N=N_force, normal_force_exact_N=eps * delta * np.pi * (r2**2 - r1**2),
              friction_stick_N=friction_force[4], friction_stick_exact_N=stick[4],
              friction_slip_N=friction_force[-1], friction_slip_exact_N=mu * N_force)
checks = {key: float(value) for key, value in checks.items()}
(out / "checks.json").write_text(json.dumps(checks, indent=1) + "\n")
for key, value in checks.items():
    print(f"{key:30s} {value:.12g}")
