"""Several materials in one body (MaterialRegions): static and explicit solvers, scenes, refusals.

The bar of meshes/two_region_bar.geo: region "lower" (0 <= y <= 4 mm) below region "upper"
(4 <= y <= 10 mm), 2 mm wide, the interface a mesh line.

* static, two elastic materials in series (nu = 0, so each region stretches uniaxially): the end
  displacements equal the finite-strain closed form E_i ln(l_i) / l_i = T (Hencky, P = tau / l);
* static, the same material given to both regions: the same numbers as one material;
* explicit, two materials (isochoric copper, seed steel): the fused pass equals the UFL route, the
  lumped mass is sum rho_i V_i, the stable step the smallest h / c of each cell's own material;
* scenes: a region in two materials, or a region in none, exits 2 before anything is written.
"""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from fenics_plast.kinematics import Kinematics
from fenics_plast.material import Hardening, Material, MaterialRegions
from fenics_plast.meshing import mesh_from_file
from fenics_plast.solvers.explicit import ExplicitDynamics
from fenics_plast.solvers.static import StaticSolver
from test_fused_force import two_increments

ROOT = Path(__file__).resolve().parent.parent
SCENES = ROOT / "tests" / "scenes"
GEO = ROOT / "meshes" / "two_region_bar.geo"
FP = [sys.executable, "-m", "fenics_plast.cli"]
ENV = dict(os.environ, FENICS_PLAST_PROGRESS="off", OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
W, L1, L2 = 2.0, 4.0, 6.0                      # mm (the .geo's defaults)

COPPER = Material(117e3, 0.35, Hardening("linear", yield_stress=400.0, modulus=100.0))
STEEL = Material(210e3, 0.3, Hardening("swift", K=900.0, eps0=0.002, n=0.2), model="seed")
RHO_CU, RHO_ST = 8.93e-9, 7.85e-9              # tonne/mm^3


def two_region_mesh(comm=MPI.COMM_SELF, **parameters):
    """Mesh, facet tags, groups and the owned cells of each region."""
    mesh, ct, ft, groups = mesh_from_file(comm, GEO, parameters)
    n_owned = mesh.topology.index_map(2).size_local
    cells = {}
    for name in ("lower", "upper"):
        c = ct.find(groups[name][1])
        cells[name] = c[c < n_owned]
    return mesh, ft, groups, cells, n_owned


def run_cli(*args):
    return subprocess.run(FP + list(args), capture_output=True, text=True, cwd=ROOT, env=ENV, timeout=600)


def hencky_stretch(E, T):
    """Uniaxial stretch l with E ln(l) / l = T (dead traction T per reference area, nu = 0)."""
    lam = 1.0
    for _ in range(50):
        lam -= (E * math.log(lam) / lam - T) / (E * (1.0 - math.log(lam)) / lam ** 2)
    return lam


# ----------------------------------------------------------------------------------------------
# the class itself


def test_each_point_gets_its_own_material():
    """Pointwise the same numbers as each material alone (same kernel): stress, state, tangent,
    energy; cells given twice or not at all are refused."""
    rng = np.random.default_rng(3)
    n_cells, nq = 6, 4
    n = n_cells * nq
    Fu = np.eye(3) + 0.02 * rng.standard_normal((n, 3, 3))
    binv_n = np.tile(np.eye(3), (n, 1, 1))
    eqps_n = np.zeros(n)
    lower = np.array([0, 3, 4])
    mats = MaterialRegions([(COPPER, lower), (STEEL, np.array([5, 1, 2]))], n_cells)
    tau, binv, eqps, a = mats.update(Fu, binv_n, eqps_n)
    assert (eqps > 0).sum() > n // 2, "the test state must be plastic"
    in_lower = np.isin(np.arange(n) // nq, lower)
    for mat, pts in ((COPPER, in_lower), (STEEL, ~in_lower)):
        ref = mat.update(Fu[pts], binv_n[pts], eqps_n[pts])
        for got, want in zip((tau, binv, eqps, a), ref):
            assert np.array_equal(got[pts], want)
        assert np.array_equal(mats.energy(binv)[pts], mat.energy(binv[pts]))
    assert list(mats.per_cell([1.0, 2.0])) == [1.0, 2.0, 2.0, 1.0, 1.0, 2.0]
    with pytest.raises(ValueError, match="more than one material"):
        MaterialRegions([(COPPER, [0, 1, 2]), (STEEL, [2, 3, 4, 5])], n_cells)
    with pytest.raises(ValueError, match="1 of 6 cells have no material"):
        MaterialRegions([(COPPER, [0, 1, 2]), (STEEL, [3, 4])], n_cells)


# ----------------------------------------------------------------------------------------------
# static


def test_series_bar_matches_closed_form(tmp_path):
    """tests/scenes/two_region_bar.toml: soft (E = 100 GPa) below stiff (250 GPa), T = 300 MPa.
    The interface moves by L1 (l_soft - 1), the top by that + L2 (l_stiff - 1) (measured: 3e-13
    and 6e-13 relative)."""
    out = tmp_path / "bar"
    p = run_cli("run", str(SCENES / "two_region_bar.toml"), "--out", str(out))
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-2000:]
    s = json.loads((out / "summary.json").read_text())
    l_soft, l_stiff = hencky_stretch(100e3, 300.0), hencky_stretch(250e3, 300.0)
    assert s["interface_mm"] == pytest.approx(L1 * (l_soft - 1.0), rel=1e-9, abs=0.0)
    assert s["top_mm"] == pytest.approx(L1 * (l_soft - 1.0) + L2 * (l_stiff - 1.0), rel=1e-9, abs=0.0)
    assert s["max_eqps"] == 0.0


def _static_bar(material_of_cells):
    """Plane-strain bar pulled by 0.6 mm at the top (plastic), 3 increments; returns the solver."""
    mesh, ft, groups, cells, n_owned = two_region_mesh()
    s = StaticSolver(Kinematics(mesh, "plane_strain"), material_of_cells(cells, n_owned), verbose=False)
    s.add_dirichlet(1, ft, groups["bottom"][1], 0.0)
    s.add_dirichlet(0, ft, groups["left"][1], 0.0)
    s.add_dirichlet(1, ft, groups["top"][1], 0.6)
    s.run(increments=3, max_increment=0.34)
    return s


def test_same_material_in_two_regions_equals_one_material():
    one = _static_bar(lambda cells, n: COPPER)
    two = _static_bar(lambda cells, n: MaterialRegions([(COPPER, cells["lower"]), (COPPER, cells["upper"])], n))
    assert one.qmap.eqps.max() > 0.02, "the test state must be plastic"
    assert [r["iterations"] for r in two.increments] == [r["iterations"] for r in one.increments]
    assert np.abs(two.w.x.array - one.w.x.array).max() <= 1e-14 * np.abs(one.w.x.array).max()
    assert np.abs(two.qmap.eqps - one.qmap.eqps).max() <= 1e-14 * one.qmap.eqps.max()


# ----------------------------------------------------------------------------------------------
# explicit


def _explicit(route, comm=MPI.COMM_SELF):
    mesh, ft, groups, cells, n_owned = two_region_mesh(comm, cells_across=3, cells_lower=8, cells_upper=6)
    mats = MaterialRegions([(COPPER, cells["lower"]), (STEEL, cells["upper"])], n_owned)
    bcs = [(0, ft.find(groups["left"][1])), (1, ft.find(groups["bottom"][1]))]
    return ExplicitDynamics(mesh, Kinematics(mesh, "axisymmetric"), mats, [RHO_CU, RHO_ST], bcs, internal_force=route,
                            log=lambda m: None)


def _field(X, scale):
    """A smooth displacement field [mm] that yields both materials (bulge, shortening, shear)."""
    r, z = X[:, 0], X[:, 1]
    u = np.empty((len(r), 2))
    u[:, 0] = scale * (0.06 * r * (1.0 + 0.3 * z / 10.0) + 0.01 * z)
    u[:, 1] = scale * (-0.05 * z - 0.003 * z * z / 10.0 + 0.02 * r)
    return u.reshape(-1)


def test_same_material_in_two_regions_equals_one_material_explicit():
    """Lumped mass (DG0 density), stable step and a 1.5 us impact: the numbers of one material."""
    runs = []
    for two in (False, True):
        mesh, ft, groups, cells, n = two_region_mesh(cells_across=3, cells_lower=8, cells_upper=6)
        mat, rho = ((MaterialRegions([(COPPER, cells["lower"]), (COPPER, cells["upper"])], n), [RHO_CU, RHO_CU])
                    if two else (COPPER, RHO_CU))
        bcs = [(0, ft.find(groups["left"][1])), (1, ft.find(groups["bottom"][1]))]
        s = ExplicitDynamics(mesh, Kinematics(mesh, "axisymmetric"), mat, rho, bcs, log=lambda m: None)
        runs.append((s.stable_dt(), s.mass.copy()))
        s.set_velocity((0.0, -150e3))
        s.run(1.5e-6, rows=2, progress=0)
        runs[-1] += (s.u.x.array.copy(), s.qmap.eqps.copy(), s.step_count)
    (dt1, m1, u1, e1, n1), (dt2, m2, u2, e2, n2) = runs
    assert dt2 == pytest.approx(dt1, rel=1e-15, abs=0.0) and n1 == n2
    assert np.abs(m2 - m1).max() <= 1e-15 * m1.max()
    # round-off only; not bitwise: the two-material pass is a separately compiled specialisation
    # (a fresh compile and one loaded from numba's cache may contract FMAs differently)
    assert np.abs(u2 - u1).max() <= 1e-11 * np.abs(u1).max()
    assert e1.max() > 0.05 and np.abs(e2 - e1).max() <= 1e-11 * e1.max()


def test_fused_equals_ufl_with_two_materials():
    fused = two_increments(_explicit("fused"), _field)
    ufl = two_increments(_explicit("ufl"), _field)
    mats = fused.material
    for k in range(2):
        pts = np.isin(np.arange(fused.qmap.n) // fused.qmap.nq, mats.cells[k])
        assert fused.qmap.eqps[pts].max() > 0.01, f"material {k} must yield"
    assert np.abs(fused.f - ufl.f).max() <= 1e-12 * np.abs(ufl.f).max()
    for name in ("tau_values", "binv", "eqps"):
        a, b = getattr(fused.qmap, name), getattr(ufl.qmap, name)
        assert np.abs(a - b).max() <= 1e-12 * max(np.abs(b).max(), 1.0), name
    assert fused.elastic_energy() == pytest.approx(ufl.elastic_energy(), rel=1e-12, abs=0.0)


def test_short_impact_same_with_either_route():
    """1.5 us at 150 m/s onto the wall (plastic at the impact end): same displacements and state."""
    out = {}
    for route in ("fused", "ufl"):
        s = _explicit(route)
        s.set_velocity((0.0, -150e3))
        s.run(1.5e-6, rows=2, progress=0)
        out[route] = s
    f, u = out["fused"], out["ufl"]
    assert f.step_count == u.step_count > 10
    assert f.max_eqps() > 0.05
    assert np.abs(f.u.x.array - u.u.x.array).max() <= 1e-10 * np.abs(u.u.x.array).max()
    assert np.abs(f.qmap.eqps - u.qmap.eqps).max() <= 1e-10 * u.qmap.eqps.max()


def test_lumped_mass_and_stable_step_per_material():
    s = _explicit("fused")
    m = s.mass[0::2].sum()                          # each component carries the whole mass
    volume = math.pi * W ** 2                       # axisymmetric: pi R^2 per mm of length
    assert m == pytest.approx(RHO_CU * volume * L1 + RHO_ST * volume * L2, rel=1e-12, abs=0.0)
    # cells: copper W/3 x L1/8 (h = 0.5 mm), steel W/3 x L2/6 (h = 2/3 mm); Gmsh's transfinite
    # nodes are off by ~3e-12 mm (measured: dt 7e-12 relative below the exact value)
    c = [mat.wave_speed(rho) for mat, rho in ((COPPER, RHO_CU), (STEEL, RHO_ST))]
    dt = min(0.5 / c[0], (W / 3) / c[1])
    assert s.stable_dt() == pytest.approx(dt, rel=1e-10, abs=0.0)
    assert dt > 0.5 / max(c) * 1.2                  # one wave speed for the whole bar would be 20 % off
    assert s.c == max(c)


def test_default_contact_penalty_uses_the_material_along_the_group():
    from fenics_plast.build import contact_modulus
    mesh, ft, groups, cells, n = two_region_mesh()
    mats = MaterialRegions([(COPPER, cells["lower"]), (STEEL, cells["upper"])], n)
    E = {g: contact_modulus(mats, mesh, ft, groups[g][1]) for g in ("bottom", "top", "left")}
    assert E == {"bottom": COPPER.E, "top": STEEL.E, "left": STEEL.E}      # left: both, the stiffer
    assert contact_modulus(COPPER, mesh, ft, groups["top"][1]) == COPPER.E


def test_impact_scene_runs_two_materials(tmp_path):
    """tests/scenes/two_region_impact.toml through the runner: the stable step of each material's
    own wave speed, the fastest one reported, both regions plastic, energy balanced."""
    out = tmp_path / "impact"
    p = run_cli("run", str(SCENES / "two_region_impact.toml"), "--out", str(out))
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-2000:]
    s = json.loads((out / "summary.json").read_text())
    c = [mat.wave_speed(rho) for mat, rho in ((COPPER, RHO_CU), (STEEL, RHO_ST))]
    assert s["dt_stable_initial_s"] == pytest.approx(min(0.5 / c[0], (W / 3) / c[1]), rel=1e-10, abs=0.0)
    assert s["wave_speed_m_s"] == pytest.approx(max(c) * 1e-3, rel=1e-14, abs=0.0)
    assert s["model"] == "isochoric+seed"
    assert s["eqps_steel"] > 0.0 and s["max_eqps"] > 0.3
    assert s["energy_balance_error"] < 5e-3


# ----------------------------------------------------------------------------------------------
# refusals


def test_region_in_two_materials_is_refused_before_anything_is_written(tmp_path):
    out = tmp_path / "overlap"
    p = run_cli("run", str(SCENES / "two_region_bar.toml"), "--out", str(out),
                "--set", 'materials.stiff.regions=["lower", "upper"]')
    assert p.returncode == 2, p.stderr
    assert "materials.stiff.regions" in p.stderr and "'lower'" in p.stderr
    assert not out.exists()


def test_region_in_no_material_is_refused_before_anything_is_written(tmp_path):
    out = tmp_path / "unclaimed"
    p = run_cli("run", str(SCENES / "two_region_unclaimed.toml"), "--out", str(out))
    assert p.returncode == 2, p.stderr
    assert "materials.soft.regions" in p.stderr and "leaves region(s) 'upper' (12 cells) without a material" in p.stderr
    assert not out.exists()


@pytest.mark.mpi
def test_series_bar_on_two_ranks(tmp_path):
    out = tmp_path / "bar2"
    p = subprocess.run(["mpirun", "-n", "2", "--oversubscribe"] + FP + ["run", str(SCENES / "two_region_bar.toml"),
                                                                        "--out", str(out)],
                       capture_output=True, text=True, cwd=ROOT, env=ENV, timeout=600)
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-2000:]
    s = json.loads((out / "summary.json").read_text())
    l_soft, l_stiff = hencky_stretch(100e3, 300.0), hencky_stretch(250e3, 300.0)
    assert s["top_mm"] == pytest.approx(L1 * (l_soft - 1.0) + L2 * (l_stiff - 1.0), rel=1e-9, abs=0.0)


def test_overlapping_physical_surfaces_are_refused_before_anything_is_written(tmp_path):
    """Two physical surfaces of the mesh that share a surface would put its cells in two regions:
    refused when the mesh is read (exit 2, mesh.file and both names in the message)."""
    geo = (ROOT / "meshes" / "two_region_bar.geo").read_text()
    geo += '\nPhysical Surface("both") = {1, 2};\n'
    (tmp_path / "overlap.geo").write_text(geo)
    scene = (SCENES / "two_region_bar.toml").read_text().replace(
        'file = "../../meshes/two_region_bar.geo"', 'file = "overlap.geo"')
    (tmp_path / "s.toml").write_text(scene)
    out = tmp_path / "out"
    p = run_cli("run", str(tmp_path / "s.toml"), "--out", str(out))
    assert p.returncode == 2, p.stderr
    assert "mesh.file" in p.stderr and "'both'" in p.stderr and "must not overlap" in p.stderr
    assert not out.exists()
