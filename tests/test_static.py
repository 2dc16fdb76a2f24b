"""Quasi-static finite-strain solver (issue 3): meshes, kinematics, quadrature map, SNES solver.

The problems are scene files built in-process (tests/static_cases.py): the necking bar of
demos/bar_tension.toml, the homogeneous bar tests/scenes/bar.toml and the thick cylinder
tests/scenes/ring.toml, with --set overrides."""
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from static_cases import homogeneous_bar, limit_pressure, necking_bar, solve_ring, top_force

ROOT = Path(__file__).resolve().parent.parent
COMM = MPI.COMM_WORLD


def uniaxial_reference(material, stretches):
    """Material-point uniaxial Kirchhoff stress tau_zz along the given axial stretch path.

    Lateral stretch found by Newton (finite differences) so that tau_rr = tau_tt = 0; the state is
    committed at each stretch (same increments as the FE run).
    """
    binv = np.eye(3)[None].copy()
    eqps = np.zeros(1)
    lz_n, lr_n = 1.0, 1.0
    out = []
    for lz in stretches:
        def trr(lr):
            Fu = np.diag([lr / lr_n, lz / lz_n, lr / lr_n])[None]
            tau, b, e, _ = material.update(Fu, binv, eqps, tangent=False)
            return tau[0, 0, 0], tau, b, e
        lr = lr_n * (lz / lz_n) ** -0.5
        for _ in range(50):
            f, tau, b, e = trr(lr)
            h = 1e-7 * lr
            df = (trr(lr + h)[0] - trr(lr - h)[0]) / (2 * h)
            step = f / df
            lr -= step
            if abs(step) < 1e-15:
                break
        f, tau, b, e = trr(lr)
        binv, eqps, lz_n, lr_n = b, e, lz, lr
        out.append(tau[0, 1, 1])
    return np.array(out)


@pytest.mark.parametrize("element", ["q1p0", "q1"])
def test_homogeneous_uniaxial_bar_matches_material_point(element):
    """(a) Homogeneous bar: FE force-elongation = material-point uniaxial stress, 1e-6 relative."""
    R, L, d = 1.5, 4.0, 1.2          # 30 % elongation, well into the plastic range
    b = homogeneous_bar(d, dict(law="linear", yield_stress=250.0, modulus=2000.0), element=element,
                        radius=R, half_length=L)
    s, mat = b.solver, b.material
    forces = []
    s.run(increments=8, max_increment=0.2, callback=lambda sv: forces.append(top_force(b)) and False)
    lams = np.array([r["load_factor"] for r in s.increments])
    stretch = 1 + lams * d / L
    tau_zz = uniaxial_reference(mat, stretch)
    ref = tau_zz * math.pi * R ** 2 / stretch      # sigma_zz * current area = tau_zz * A0 / lambda_z
    forces = np.array(forces)
    assert s.qmap.eqps.max() > 0.1
    np.testing.assert_allclose(forces, ref, rtol=1e-6)


def test_thick_cylinder_limit_pressure_and_locking():
    """(b) Plane strain, elastic-perfectly plastic, nu = 0.49, b/a = 2: Q1/P0 limit within 1 %,
    plain Q1 locks (overshoots by more than the Q1/P0 error)."""
    sy = 20.0
    exact = limit_pressure(sy, 1.0, 2.0)
    res = {}
    for element in ("q1p0", "q1"):
        r = solve_ring(1.0, 2.0, 6, 12, nu=0.49, yield_stress=sy, element=element, increments=10,
                       max_increment=0.1)
        assert r["converged"]
        res[element] = r["limit_pressure_MPa"] / exact - 1
    print(f"limit pressure errors: q1p0 {res['q1p0']:+.4%}, q1 {res['q1']:+.4%}")
    assert abs(res["q1p0"]) < 0.01
    assert res["q1"] > abs(res["q1p0"])
    assert res["q1"] > 0.05


def test_newton_quadratic_in_plastic_increment():
    """(c) Plastic increments of the necking bar converge quadratically (consistent tangent).

    Residual norms below 1e-12 x the largest norm of the run are round-off (about 2e-8 N here) and
    are left out. Asserted: r_{k+1} <= 1e-3 r_k^2 [1/N] for every step that starts below 100 N
    (the quadratic constant of this problem is about 2e-5 to 1e-4), and the best final convergence
    order log(r_{k+1}/r_k) / log(r_k/r_{k-1}) of the increments is >= 1.8.
    """
    s = necking_bar(4, 12, 3.0, rtol=1e-11, atol=1e-9, max_iterations=30).solver
    s.run(increments=5, max_increment=0.2, lam_end=0.6)
    floor = 1e-12 * max(max(rec["norms"]) for rec in s.increments)
    orders, checked = [], 0
    for rec in s.increments:
        assert s.qmap.eqps.max() > 0
        r = [x for x in rec["norms"] if x > floor]
        for k in range(len(r) - 1):
            if r[k] < 100.0:
                assert r[k + 1] <= 1e-3 * r[k] ** 2, rec["norms"]
                checked += 1
        if len(r) >= 3:
            orders.append(math.log(r[-1] / r[-2]) / math.log(r[-2] / r[-3]))
    print("final convergence orders per increment:", ["%.2f" % o for o in orders])
    print("norms:", [["%.2e" % n for n in rec["norms"]] for rec in s.increments])
    assert checked >= 3
    assert max(orders) >= 1.8


@pytest.mark.parametrize("case", ["bar", "ring"])
def test_serial_and_mpi_agree(tmp_path, case):
    """(d) Serial vs mpirun -n 2: displacements and reactions agree to 1e-8 relative."""
    if COMM.size > 1:
        pytest.skip("spawns its own runs")
    script = ROOT / "tests" / "mpi_static_run.py"
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    subprocess.run([sys.executable, str(script), str(tmp_path / "s.json"), case], check=True, env=env,
                   cwd=tmp_path, capture_output=True, timeout=300)
    subprocess.run(["/usr/bin/mpirun", "--allow-run-as-root", "-n", "2", sys.executable, str(script),
                    str(tmp_path / "p.json"), case], check=True, env=env, cwd=tmp_path, capture_output=True,
                   timeout=300)
    a = json.loads((tmp_path / "s.json").read_text())
    b = json.loads((tmp_path / "p.json").read_text())
    assert a["load_factors"] == pytest.approx(b["load_factors"], rel=1e-12)
    np.testing.assert_allclose(b["reactions"], a["reactions"], rtol=1e-8)
    assert set(a["nodes"]) == set(b["nodes"])
    ua = np.array([a["nodes"][k] for k in sorted(a["nodes"])])
    ub = np.array([b["nodes"][k] for k in sorted(a["nodes"])])
    assert np.abs(ua - ub).max() <= 1e-8 * np.abs(ua).max()


def test_too_large_first_increment_is_cut_back():
    """(e) One increment of the whole (strongly plastic) load is cut back and the run finishes."""
    s = necking_bar(4, 12, 7.0, max_iterations=8).solver
    assert s.run(increments=1, max_increment=1.0, min_increment=1e-4)
    assert len(s.cutbacks) >= 1
    assert s.cutbacks[0]["load_factor"] == pytest.approx(1.0)
    assert s.lam_converged == pytest.approx(1.0)
    assert s.increments[0]["load_factor"] < 1.0


def test_cutbacks_count_cut_backs_only():
    """A failed attempt retried at the same step with the other line search is a line-search retry, not
    a cut-back (summary.json's ``cutbacks`` counted both); a cut-back halves the step."""
    s = necking_bar(4, 12, 7.0, max_iterations=8).solver
    assert s.run(increments=1, max_increment=1.0, min_increment=1e-4)
    assert s.linesearch_retries and all("retry" in r for r in s.linesearch_retries)
    assert s.cutbacks and all("retry" not in c for c in s.cutbacks)
    converged = {round(i["load_factor"], 12) for i in s.increments}
    cut = {round(c["load_factor"], 12) for c in s.cutbacks}
    assert {round(r["load_factor"], 12) for r in s.linesearch_retries} <= converged | cut


def test_min_increment_raises_run_error():
    from fenics_plast.errors import RunError
    s = necking_bar(2, 6, 7.0, max_iterations=2).solver
    with pytest.raises(RunError, match="no convergence"):
        s.run(increments=1, max_increment=1.0, min_increment=0.2)


RING_SCENE = ROOT / "tests" / "scenes" / "ring.toml"


def test_thick_cylinder_runner(tmp_path):
    """tests/scenes/ring.toml at nu = 0.49, sigma_y = 20 MPa on 4 x 8 cells through run(problem, output):
    the declared pressure output plateaus at the small-strain limit pressure (within 2 %)."""
    if COMM.size > 1:
        pytest.skip("tmp_path differs per rank under mpirun (collective XDMF open); see test_serial_and_mpi_agree")
    from fenics_plast.output import RunOutput
    from fenics_plast.problem import load_problem
    from fenics_plast.runner import run
    from static_cases import full_plastic_displacement
    delta = 3.0 * full_plastic_displacement(200e3, 0.49, 20.0, 10.0, 20.0)
    sets = ["mesh.parameters.cells_circumferential=8", "materials.steel.nu=0.49",
            "materials.steel.hardening.yield_stress=20.0", "analysis.increments=6", "analysis.max_increment=0.2",
            f'boundary.inner.value=["{delta!r} * t * x / 10", "{delta!r} * t * y / 10"]',
            # the corner factor 0.5 (1 + cos dphi) of 8 cells (see ring.toml)
            "outputs.pressure_MPa.expression=\"(inner_rx + inner_ry) / (2 * (10 + inner_displacement) * 0.5 * "
            "(1 + cos(pi / 16)))\"",
            "outputs.pressure_MPa.reference=" + repr(limit_pressure(20.0, 10.0, 20.0))]
    problem = load_problem(RING_SCENE, sets)
    res = run(problem, RunOutput(tmp_path / "out", COMM))
    exact = limit_pressure(20.0, 10.0, 20.0)
    assert res["converged"] and res["final_time"] == pytest.approx(1.0)
    assert res["references"]["max_pressure_MPa"]["value"] == pytest.approx(exact)
    assert abs(res["max_pressure_MPa"] / exact - 1) < 0.02
    assert res["inner_displacement_mm"] == pytest.approx(delta, rel=1e-12)
    assert res["cells"] == 32


def test_bar_tension_runner_outputs(tmp_path):
    """The demo scene on a coarse mesh through run(problem, output): history, XDMF, plots, summary."""
    if COMM.size > 1:
        pytest.skip("hangs under mpirun -n 2 inside pytest (tmp_path differs per rank); "
                    "the CLI run of this scene on 2 ranks works")
    from fenics_plast.output import RunOutput
    from fenics_plast.problem import load_problem
    from fenics_plast.runner import run
    problem = load_problem(ROOT / "demos" / "bar_tension.toml",
                           ["mesh.parameters.cells_radial=3", "mesh.parameters.cells_axial=8",
                            'boundary.grip.value="1.0 * t"'])
    out = RunOutput(tmp_path / "out", COMM)
    res = run(problem, out)
    out.finish(res)
    for key in ("max_force_kN", "elongation_mm_at_max_force_kN", "min_neck_radius_mm", "cells", "dofs",
                "converged", "increments", "newton_iterations"):
        assert key in res
    assert res["converged"] and res["cells"] == 24
    assert res["elongation_mm"] == pytest.approx(2.0)
    assert 50.0 < res["max_force_kN"] < 100.0
    if COMM.rank == 0:
        header = (tmp_path / "out" / "history.csv").read_text().splitlines()[0].split(",")
        assert "elongation_mm" in header and "force_kN" in header and "neck_radius_mm" in header
        assert (tmp_path / "out" / "fields.xdmf").exists()
        assert (tmp_path / "out" / "force.png").exists() and (tmp_path / "out" / "neck.png").exists()
        xdmf = (tmp_path / "out" / "fields.xdmf").read_text()
        for name in ("displacement", "eqps", "von_mises_stress"):
            assert f'Attribute Name="{name}"' in xdmf


def test_solver_options_are_removed_from_petsc_database():
    """Each StaticSolver keeps its SNES/KSP/MUMPS settings under its own prefix in PETSc's global options
    database, which holds at most 512 entries: they must go with the solver (a long test session or
    study creates hundreds of solvers)."""
    import gc

    from petsc4py import PETSc
    before = len(PETSc.Options().getAll())
    for _ in range(3):
        b = necking_bar(2, 3, 0.05)
        s = b.solver
        s.setup()
        prefix = s.prefix
        assert any(k.startswith(prefix) for k in PETSc.Options().getAll())
        del s, b
        gc.collect()
        assert not any(k.startswith(prefix) for k in PETSc.Options().getAll())
    assert len(PETSc.Options().getAll()) <= before      # no growth (earlier tests may still free theirs)


def test_modified_newton_reuses_the_factorisation_and_reaches_the_same_state():
    """analysis.jacobian_every: full Newton assembles a Jacobian at every iteration; modified Newton
    (a new one every 4th iteration or when an iteration reduces |R| by less than 0.5) assembles fewer
    Jacobians than iterations, and each increment ends on the same state as full Newton to the Newton
    tolerance (increments fixed: no growth, so both take the same steps)."""
    runs = {}
    for every in (1, 4):
        b = necking_bar(4, 12, 3.0, rtol=1e-11, atol=1e-9, max_iterations=40, jacobian_every=every,
                        jacobian_rate=0.5)
        s = b.solver
        s.run(increments=4, max_increment=0.1, lam_end=0.4, growth=1.0)
        runs[every] = (s, top_force(b), s.w.x.array.copy())
        times = s.times
        assert all(v >= 0.0 for v in times.values()) and times["material"] > 0 and times["linear"] > 0
    full, modified = runs[1][0], runs[4][0]
    assert [r["load_factor"] for r in full.increments] == [r["load_factor"] for r in modified.increments]
    assert full.jacobians >= full.total_iterations
    assert modified.jacobians < modified.total_iterations
    assert modified.total_iterations > full.total_iterations      # linear, not quadratic, convergence
    assert abs(runs[4][1] - runs[1][1]) <= 1e-8 * abs(runs[1][1])
    u1, u4 = runs[1][2], runs[4][2]
    assert np.abs(u4 - u1).max() <= 1e-8 * np.abs(u1).max()
