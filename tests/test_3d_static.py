"""3-D static analyses (issue #14): scene keys, hexahedral meshes, the static solver and its GAMG option.

* tests/scenes/bar_3d.toml: a homogeneous quarter bar (O-grid hexahedra, symmetry on x = 0, y = 0,
  z = 0) pulled into the plastic range gives the material-point uniaxial force on the faceted
  section (fenics_plast.material.point.uniaxial_stress) to 1e-10, with both elements and both
  linear solvers; serial equals ``mpirun -n 2``;
* ``analysis.linear_solver = "gamg"`` gives MUMPS's displacements to the solver tolerance on a
  clamped (non-homogeneous) bar, both elements;
* the quarter-bar meshes: all hexahedra, the benchmark size (972 cells), their groups;
* bad 3-D input (a 2-vector in 3-D, an axis in 3-D, a sphere in 2-D, ...) is refused with exit 2
  naming the key.
"""
from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from fenics_plast.errors import SceneError
from fenics_plast.material.point import uniaxial_stress
from fenics_plast.problem import load_problem
from fenics_plast.build import material_of

from scene_runs import ROOT, history, run_scene

SCENE = ROOT / "tests" / "scenes" / "bar_3d.toml"
PLASTIC = ("materials.steel.hardening.law=linear", "materials.steel.hardening.yield_stress=250",
           "materials.steel.hardening.modulus=2000", 'boundary.grip.value="1.2 * t"')
R, L = 1.5, 4.0


def faceted_area(radius, cells_radial):
    """Area of the quarter section of round_bar_quarter.geo: 2 Ceil(cells_radial / 2) chords."""
    n = 2 * math.ceil(cells_radial / 2)
    return n * 0.5 * radius ** 2 * math.sin(math.pi / (2 * n))


def reference_force(problem, stretch):
    """Whole-bar uniaxial force [N] at the axial stretch: the material point (isochoric model: the
    return map is exact along the proportional path, any steps) times the current faceted area x 4."""
    mat = material_of(problem.materials["steel"])
    u = uniaxial_stress(mat, math.log(stretch), 4)
    return u["cauchy_axial_MPa"][-1] * 4 * faceted_area(R, 2) * u["lateral_stretch"][-1] ** 2, u


@pytest.mark.parametrize("element,solver", [("q1p0", "mumps"), ("q1", "mumps"), ("q1p0", "gamg"),
                                            ("q1", "gamg")])
def test_homogeneous_quarter_bar_equals_material_point(tmp_path, element, solver):
    if MPI.COMM_WORLD.size > 1:
        pytest.skip("spawns its own runs")
    s = run_scene(SCENE, tmp_path, *PLASTIC, f"mesh.element={element}", f"analysis.linear_solver={solver}")
    p = load_problem(SCENE, PLASTIC)
    assert s["cells"] == 9 and s["converged"]
    h = history(tmp_path)
    checked = 0
    for t, f, x in zip(h["time"][1:], h["force_N"][1:], h["radius_mm"][1:]):
        ref, u = reference_force(p, 1 + 1.2 * t / L)
        assert f == pytest.approx(ref, rel=1e-10)
        assert x == pytest.approx(R * u["lateral_stretch"][-1], rel=1e-10)
        checked += 1
    assert checked >= 5 and u["eqps"][-1] > 0.2
    assert s["top_z_mm"] == pytest.approx(1.2, rel=1e-12)
    assert s["x_at_rim_mm"] == pytest.approx(s["radius_mm"], rel=1e-12)


@pytest.mark.mpi
@pytest.mark.parametrize("solver", ["mumps", "gamg"])
def test_serial_equals_two_ranks(tmp_path, solver):
    """Serial and 2 ranks give the same forces (1e-8), with MUMPS and with GAMG (q1p0: the dilatation condensed
    by sub-matrices of the distributed Jacobian, whose index sets PETSc needs sorted on 2 ranks)."""
    if MPI.COMM_WORLD.size > 1:
        pytest.skip("spawns its own runs")
    sets = PLASTIC + ("mesh.parameters.cells_axial=6", "boundary.mid_plane.type=fixed",
                      "boundary.mid_plane.components=['x', 'y', 'z']", f"analysis.linear_solver={solver}")
    a = run_scene(SCENE, tmp_path / "serial", *sets)
    b = run_scene(SCENE, tmp_path / "mpi", *sets, np_ranks=2)
    assert a["cells"] == b["cells"] == 18 and b["mpi_ranks"] == 2
    for k in ("force_N", "radius_mm", "x_at_rim_mm", "top_z_mm"):
        assert b[k] == pytest.approx(a[k], rel=1e-8), k
    ha, hb = history(tmp_path / "serial"), history(tmp_path / "mpi")
    np.testing.assert_allclose(hb["force_N"], ha["force_N"], rtol=1e-8)


def _clamped_run(element, solver):
    """The bar clamped at z = 0 (non-homogeneous: the section necks towards the grip's free end),
    2 increments into the plastic range; returns (displacements by node coordinates, force [N],
    linear iterations)."""
    from fenics_plast.runner_static import build_static
    sets = PLASTIC + (f"mesh.element={element}", f"analysis.linear_solver={solver}", "analysis.increments=2",
                      "mesh.parameters.cells_radial=4", "mesh.parameters.cells_axial=6",
                      "boundary.mid_plane.type=fixed", "boundary.mid_plane.components=['x', 'y', 'z']",
                      "analysis.linear_rtol=1e-10", 'boundary.grip.value="0.2 * t"')
    b = build_static(load_problem(SCENE, sets), MPI.COMM_SELF)
    b.solver.verbose = False
    b.solver.run(increments=2, max_increment=0.5)
    X = b.body.X
    order = np.lexsort(np.round(X, 9).T)
    u = (b.positions() - X)[order]
    force = b.solver.reaction(b.reactions[("top", "z")])
    its = b.solver.linear_iterations
    b.solver.close()
    return u, force, its


@pytest.mark.parametrize("element", ["q1p0", "q1"])
def test_gamg_equals_mumps(element):
    u_lu, f_lu, its_lu = _clamped_run(element, "mumps")
    u_mg, f_mg, its_mg = _clamped_run(element, "gamg")
    assert its_lu == [] and len(its_mg) >= 4 and max(its_mg) < 100
    assert np.abs(u_mg - u_lu).max() <= 1e-8 * np.abs(u_lu).max()
    assert f_mg == pytest.approx(f_lu, rel=1e-8)
    # not homogeneous: the clamp holds the section's radius at z = 0
    assert np.ptp(u_lu[:, 0]) > 1e-3


def test_quarter_bar_mesh_is_hexahedral_benchmark_size():
    from dolfinx.mesh import CellType
    from fenics_plast.meshing import mesh_from_file
    m, ct, ft, groups = mesh_from_file(MPI.COMM_SELF, ROOT / "meshes" / "round_bar_quarter.geo",
                                       {"cells_radial": 6, "cells_axial": 36}, gdim=3)
    assert m.topology.cell_type == CellType.hexahedron and m.geometry.dim == 3
    assert m.topology.index_map(3).size_global == 972
    assert {n: d for n, (d, _) in groups.items()} == dict(bar=3, bottom=2, top=2, outer=2, symmetry_x=2,
                                                          symmetry_y=2)
    # refine 2 multiplies both counts: 8x the cells
    m2 = mesh_from_file(MPI.COMM_SELF, ROOT / "meshes" / "round_bar_quarter.geo",
                        {"cells_radial": 6, "cells_axial": 36}, refine=2, gdim=3)[0]
    assert m2.topology.index_map(3).size_global == 8 * 972


@pytest.mark.parametrize("sets,key", [
    (("outputs.x_at_rim.point=[1.5, 0.0]",), "outputs.x_at_rim.point"),
    (("boundary.plane_x.type=axis",), "boundary.plane_x.type"),
    (("boundary.grip.components=['r']",), "boundary.grip.components"),
    (("outputs.force.component=r",), "outputs.force.component"),
    (("tools.ball.shape=circle", "tools.ball.center=[0.0, 0.0, 9.0]", "tools.ball.radius=1.0"),
     "tools.ball.shape"),
    (("tools.ball.shape=cylinder", "tools.ball.center=[0.0, 0.0, 9.0]", "tools.ball.radius=1.0"),
     "tools.ball.axis"),
    (("tools.p.shape=plane", "tools.p.point=[0.0, 9.0]", "tools.p.normal=[0.0, 0.0, -1.0]"), "tools.p.point"),
    (("outputs.t.quantity=thickness", "outputs.t.group=top", "outputs.t.opposite=bottom"), "outputs.t.quantity"),
    (("plots.s.type=shape",), "plots.s.type"),
])
def test_bad_3d_input_names_the_key(sets, key):
    with pytest.raises(SceneError) as e:
        load_problem(SCENE, sets)
    assert key in str(e.value), str(e.value)


@pytest.mark.parametrize("sets,key", [
    (("tools.ball.shape=sphere", "tools.ball.center=[0.0, 5.0]", "tools.ball.radius=1.0"), "tools.ball.shape"),
    (("tools.ball.shape=circle", "tools.ball.center=[0.0, 5.0, 1.0]", "tools.ball.radius=1.0"),
     "tools.ball.center"),
    (("tools.pr.shape=profile", "tools.pr.segments=[{line = [[0.0, 1.0], [1.0, 1.0]]}]",
      "tools.pr.axis=[0.0, 1.0]"), "tools.pr.axis"),
    (("outputs.r.quantity=extent", "outputs.r.component=radial", "mesh.geometry=plane_strain"),
     "outputs.r.component"),
])
def test_bad_2d_input_names_the_key(sets, key):
    with pytest.raises(SceneError) as e:
        load_problem(ROOT / "tests" / "scenes" / "bar.toml", sets)
    assert key in str(e.value), str(e.value)


def test_cli_refuses_a_2_vector_in_3d_with_exit_2(tmp_path):
    env = dict(os.environ, FENICS_PLAST_PROGRESS="off")
    p = subprocess.run([sys.executable, "-m", "fenics_plast.cli", "run", str(SCENE), "--out", str(tmp_path / "o"),
                        "--set", "outputs.x_at_rim.point=[1.5, 0.0]"], capture_output=True, text=True, env=env,
                       cwd=ROOT, timeout=120)
    assert p.returncode == 2, p.stderr
    assert "outputs.x_at_rim.point" in p.stderr and "3 ([x, y, z])" in p.stderr
    assert not (tmp_path / "o").exists()


def test_3d_tool_keys_validate():
    """The 3-D tool shapes and a revolved profile are accepted (the classes are helper C's)."""
    p = load_problem(SCENE, ["tools.ball.shape=sphere", "tools.ball.center=[0.0, 0.0, 6.0]", "tools.ball.radius=2.0",
                             "tools.ball.path={t = [0.0, 1.0], z = [0.0, -1.0]}",
                             "tools.roll.shape=torus", "tools.roll.center=[0.0, 0.0, 6.0]",
                             "tools.roll.axis=[0.0, 0.0, 1.0]", "tools.roll.ring_radius=3.0", "tools.roll.radius=1.0",
                             "tools.die.shape=profile", "tools.die.center=[0.0, 0.0, 0.0]",
                             "tools.die.axis=[0.0, 0.0, 1.0]",
                             "tools.die.segments=[{line = [[2.0, 0.0], [2.0, 5.0]]}]"])
    assert p.tools["ball"].path["z"].evaluate(t=1.0) == -1.0
    assert p.tools["roll"].ring_radius == 3.0 and p.tools["die"].axis == (0.0, 0.0, 1.0)
