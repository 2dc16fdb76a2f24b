"""Stability at the extremes (issue 6): each case converges to an answer checked against a closed
form or a reference run, or stops with a clear message; never a NaN.

=====================================  ==========================================================
extreme                                test
=====================================  ==========================================================
nu = 0.4999, 0.49999 (static, Q1/P0)   test_nearly_incompressible_ring (elastic Lame pressure,
                                       limit pressure; both perfectly plastic, H = 0)
MUMPS out of workspace                 test_mumps_workspace_is_raised,
                                       test_mumps_workspace_gives_up_with_a_clear_message
H = 0 (perfect plasticity)             test_perfectly_plastic_compression_beyond_eqps_3 (force =
                                       -sigma_y A0 / lambda); the ring above; and
                                       test_static.py::test_thick_cylinder_limit_pressure_and_locking
eqps beyond 3                          test_material_point_beyond_eqps_3 (both models, tension,
                                       compression, shear), the compression test above (mesh)
penalty 1e-2 ... 1e4 x default         test_punch_penalty_extremes (+ slow: every decade)
dt_safety 1e-9, penalty 1e12 x        test_a_step_count_beyond_1e7_is_announced (a warning before the
                                       run, naming what sets the step)
time step above the stable limit       test_explicit.py::test_fixed_step_above_stable_limit_is_refused
                                       (1.5 x, the message names the limit) and
                                       ::test_fixed_step_stopped_when_the_mesh_crushes_below_it
first load increment far too large     test_static.py::test_too_large_first_increment_is_cut_back,
                                       ::test_min_increment_raises_run_error (clear RunError)
elastic only (huge sigma_y)            test_huge_yield_stress_is_hyperelastic (closed forms)
zero impact velocity                   test_taylor_bar_at_rest_solver; test_taylor_bar_at_rest_cli
no NaN/inf in any output               tests/conftest.py (every test), test_nonfinite_output_check
=====================================  ==========================================================
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

from fenics_plast.material import Hardening, Material
from fenics_plast.material.point import deformation_table, uniaxial_stress
from fenics_plast.quadrature import von_mises
from fenics_plast.solvers import static
from static_cases import PUNCH_PENALTY, homogeneous_bar, limit_pressure, punch, solve_ring, top_force

ROOT = Path(__file__).resolve().parent.parent
COMM = MPI.COMM_WORLD
SERIAL = COMM.size == 1


def finite(*arrays):
    return all(np.all(np.isfinite(np.asarray(a, dtype=float))) for a in arrays)


# ----------------------------------------------------------------------------------------------
# nearly incompressible (static solver, Q1/P0) and the MUMPS workspace


def lame_ring_pressure(material, a, b, delta):
    """Small-strain plane-strain Lame solution: internal pressure [MPa] for an inner radial
    displacement delta [mm] of the ring a <= r <= b with a free outer surface (u = A r + B / r)."""
    lam, mu = material.lame
    B = delta / (mu * a / ((lam + mu) * b * b) + 1.0 / a)
    return 2.0 * mu * B * (1.0 / a ** 2 - 1.0 / b ** 2)


@pytest.mark.parametrize("nu", [0.4999, 0.49999])
def test_nearly_incompressible_ring(nu):
    """Plane-strain thick cylinder b/a = 2, elastic-perfectly plastic, Q1/P0, nu -> 0.5: the elastic
    pressure matches Lame (no locking) and the limit pressure (2/sqrt 3) sigma_y ln(b/a) is reached
    (+0.29 % at both nu, as at nu = 0.49). Before the round-off floor of the Newton tolerance
    (StaticSolver.roundoff_floor) Newton stalled at |R| ~ 1.5e-7 N (0.4999) / 1.5e-6 N (0.49999),
    above atol = 1e-8 N, and both runs failed at the first increment. Now the stall is recognised at
    once: 21 Newton iterations for the 10 increments (19 at nu = 0.49)."""
    sy = 20.0
    # elastic: one increment to an inner displacement at ~40 % of the first-yield pressure
    delta = 3e-5
    r = solve_ring(1.0, 2.0, 6, 12, nu=nu, yield_stress=sy, delta=delta, increments=1, max_increment=1.0)
    assert r["converged"], r.get("error")
    mat = r["material"]
    p_el = r["history"]["pressure_MPa"][-1]
    p_first_yield = sy / math.sqrt(3.0) * (1 - 0.25)
    assert 0.2 * p_first_yield < p_el < 0.8 * p_first_yield
    assert p_el == pytest.approx(lame_ring_pressure(mat, 1.0, 2.0, delta), rel=5e-3)
    assert r["solver"].qmap.eqps.max() == 0.0
    # plastic: up to the limit load
    r = solve_ring(1.0, 2.0, 6, 12, nu=nu, yield_stress=sy, increments=10, max_increment=0.1)
    assert r["converged"], r.get("error")
    h = r["history"]
    assert finite(h["pressure_MPa"], h["inner_displacement_mm"], r["solver"].qmap.tau_values)
    assert abs(r["limit_pressure_MPa"] / limit_pressure(sy, 1.0, 2.0) - 1) < 0.01
    assert len(r["solver"].cutbacks) == 0 and r["solver"].total_iterations <= 30


def _force_icntl14(monkeypatch, value):
    """Start every StaticSolver with MUMPS ICNTL(14) = value (% extra workspace over MUMPS's estimate,
    negative: less than the estimate; the solver uses 100)."""
    orig = static.StaticSolver.setup

    def setup(self):
        orig(self)
        PETSc.Options()[self.prefix + "mat_mumps_icntl_14"] = value
        self.snes.getKSP().setFromOptions()

    monkeypatch.setattr(static.StaticSolver, "setup", setup)


def _ring_49999(**kw):
    return solve_ring(1.0, 2.0, 6, 12, nu=0.49999, yield_stress=20.0, increments=4, max_increment=0.25, **kw)


@pytest.mark.skipif(not SERIAL, reason="MUMPS workspace estimates differ between partitions")
def test_mumps_workspace_is_raised(monkeypatch):
    """With half the estimated workspace (ICNTL(14) = -50 %) MUMPS fails on the nu = 0.49999 system
    with INFOG(1) = -9; the solver raises ICNTL(14) (to 20 %) and solves the same step again: same
    answer as with the default 100 %, no cut-back. (Before: ten pointless cut-backs, then a RunError.)
    A negative ICNTL(14) makes the premise hold on both MUMPS versions: MUMPS 5.5 (Debian 12) also
    fails with ICNTL(14) = 0 to 5 here, MUMPS 5.7 (Debian 13) estimates generously enough that 0 works."""
    ref = _ring_49999()
    assert ref["converged"] and not ref["solver"].mumps_workspace_raises
    _force_icntl14(monkeypatch, -50)
    r = _ring_49999()
    assert r["converged"], r.get("error")
    raises = r["solver"].mumps_workspace_raises
    assert raises and raises[0]["infog1"] in static.MUMPS_WORKSPACE_ERRORS and raises[0]["icntl14"] == 20
    assert not r["solver"].cutbacks
    # equal to the round-off floor of the residual (observed 2.4e-8)
    np.testing.assert_allclose(r["history"]["pressure_MPa"], ref["history"]["pressure_MPa"], rtol=1e-6)


@pytest.mark.skipif(not SERIAL, reason="MUMPS workspace estimates differ between partitions")
def test_mumps_workspace_gives_up_with_a_clear_message(monkeypatch):
    _force_icntl14(monkeypatch, -50)
    monkeypatch.setattr(static, "MUMPS_MAX_ICNTL14", 10)
    r = _ring_49999()
    assert not r["converged"]
    msg = str(r["error"])
    assert "MUMPS ran out of workspace" in msg and "ICNTL(14) = -50" in msg and "INFOG(1) = -9" in msg
    assert not r["solver"].cutbacks          # no pointless cut-backs first
    assert finite(r["history"]["pressure_MPa"])


# ----------------------------------------------------------------------------------------------
# perfect plasticity and equivalent plastic strain beyond 3


def homogeneous_cylinder(hardening, log_strain, increments, model="isochoric", cells=(2, 3), R=1.5, L=4.0):
    """Axisymmetric cylinder (radius R, half length L, ends free to slide radially; tests/scenes/bar.toml,
    E = 200 GPa, nu = 0.3, ``hardening``: its [materials.steel.hardening] keys, None: elastic) stretched
    homogeneously to the axial log strain; returns (solver, stretches, end forces [N], build)."""
    d = L * (math.exp(log_strain) - 1.0)
    b = homogeneous_bar(d, hardening, model=model, cells=cells, radius=R, half_length=L)
    s = b.solver
    forces = []
    s.run(increments=increments, max_increment=1.0 / increments,
          callback=lambda sv: forces.append(top_force(b)) and False)
    lam = np.array([rec["load_factor"] for rec in s.increments])
    return s, 1.0 + lam * d / L, np.array(forces), b


def test_perfectly_plastic_compression_beyond_eqps_3():
    """H = 0, homogeneous compression to ln(l/l0) = -3.2 (the cylinder ends 25 x shorter; uniaxial
    compression is stable where tension would neck): the force is -sigma_y A0 / lambda at every
    plastic increment (Kirchhoff stress on the yield surface, exact for the homogeneous state),
    von Mises(tau) = sigma_y at every point, eqps 3.19875 everywhere, no NaN."""
    sy, R = 250.0, 1.5
    s, stretch, F, _ = homogeneous_cylinder(dict(law="linear", yield_stress=sy, modulus=0.0), -3.2, 20, R=R)
    assert stretch[-1] == pytest.approx(math.exp(-3.2))
    assert finite(F, s.qmap.tau_values, s.qmap.eqps)
    eq = s.qmap.eqps
    assert eq.min() == pytest.approx(3.2 - sy / 200e3, abs=1e-7) and eq.max() - eq.min() < 1e-7
    np.testing.assert_allclose(von_mises(s.qmap.tau_values), sy, rtol=1e-10)
    ref = -sy * math.pi * R ** 2 / stretch
    np.testing.assert_allclose(F, ref, rtol=1e-6)


@pytest.mark.parametrize("model", ["isochoric", "seed"])
@pytest.mark.parametrize("H", [0.0, 500.0])
def test_material_point_beyond_eqps_3(model, H):
    """Uniaxial tension and compression to |ln l/l0| = 4 and simple shear to gamma = 10 (eqps 3.9 to
    6.1): finite everywhere, and the stress on the yield surface, von Mises(tau) = sigma_y(eqps),
    at every plastic step to 1e-9."""
    sy = 250.0
    mat = Material(200e3, 0.3, Hardening("linear", yield_stress=sy, modulus=H), model=model)
    for to in (4.0, -4.0):
        u = uniaxial_stress(mat, to, 400)
        assert finite(*u.values())
        assert u["eqps"][-1] > 3.5
        p = u["eqps"] > 0
        np.testing.assert_allclose(np.abs(u["kirchhoff_axial_MPa"][p]), sy + H * u["eqps"][p], rtol=1e-9)
    g = np.linspace(0.0, 10.0, 501)[1:]
    F = np.repeat(np.eye(3)[None], len(g), axis=0)
    F[:, 0, 1] = g
    t = deformation_table(mat, F)
    assert finite(*t.values())
    assert t["eqps"][-1] > 5.5
    sig = np.zeros((len(t["J"]), 3, 3))
    for i, j in [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)]:
        sig[:, i, j] = sig[:, j, i] = t[f"cauchy_{i + 1}{j + 1}_MPa"]
    p = t["eqps"] > 0
    tau = sig * t["J"][:, None, None]                  # J = 1 in simple shear
    np.testing.assert_allclose(von_mises(tau[p]), sy + H * t["eqps"][p], rtol=1e-9)


# ----------------------------------------------------------------------------------------------
# elastic only: a huge yield stress gives the hyperelastic response


def uniaxial_closed_form(model, E, nu, stretch):
    """Uniaxial-stress Kirchhoff stress [MPa] and lateral stretch of the elastic law:
    isochoric (Hencky): tau = E ln l, lateral l^-nu; seed (Almansi e = (1 - l^-2)/2, psi quadratic
    in e): tau = E e, lateral e_t = -nu e."""
    if model == "isochoric":
        return E * np.log(stretch), stretch ** -nu
    e = 0.5 * (1.0 - stretch ** -2.0)
    return E * e, (1.0 + 2.0 * nu * e) ** -0.5


@pytest.mark.parametrize("model", ["isochoric", "seed"])
def test_huge_yield_stress_is_hyperelastic(model):
    """sigma_y = 1e12 MPa: a homogeneous cylinder stretched by 50 % stays elastic (eqps exactly 0),
    its force equals the elastic-only material (no hardening law) to 1e-12 and the closed form
    tau(l) A0 / l to 1e-8; the radius follows the closed-form lateral stretch."""
    E, nu, R = 200e3, 0.3, 1.5
    huge = dict(law="linear", yield_stress=1e12)
    s, stretch, F, _ = homogeneous_cylinder(huge, math.log(1.5), 5, model=model, R=R)
    s0, stretch0, F0, _ = homogeneous_cylinder(None, math.log(1.5), 5, model=model, R=R)
    assert finite(F, s.qmap.tau_values)
    assert s.qmap.eqps.max() == 0.0
    np.testing.assert_array_equal(stretch, stretch0)
    np.testing.assert_allclose(F, F0, rtol=1e-12)
    tau, lateral = uniaxial_closed_form(model, E, nu, stretch)
    np.testing.assert_allclose(F, tau * math.pi * R ** 2 / stretch, rtol=1e-8)
    u = s.displacement_function()
    X = u.function_space.tabulate_dof_coordinates()
    outer = np.isclose(X[:, 0], R)
    r_now = X[outer, 0] + u.x.array.reshape(-1, 2)[outer, 0]
    np.testing.assert_allclose(r_now, R * lateral[-1], rtol=1e-8)


# ----------------------------------------------------------------------------------------------
# contact penalty from 1e-2 to 1e4 times the default


def punch_run(penalty_factor, travel=8.0):
    """Coarse frictionless punch (demos/punch_stretching.toml on 30 x 1 cells, aluminium, 8 mm of
    travel); returns (force [N], max penetration [mm], increments, solver)."""
    b = punch(friction=0.0, penalty=PUNCH_PENALTY * penalty_factor, travel=travel)
    s, c = b.solver, b.contact
    pen = []

    def cb(sol):
        c.commit()
        pen.append(c.max_penetration())
        return False

    s.run(increments=8, max_increment=0.125, callback=cb)
    assert s.lam_converged == pytest.approx(1.0)
    return b.pairs["punch"].force()[1], max(pen), len(s.increments), s


def check_penalty_sweep(factors):
    res = {f: punch_run(f) for f in factors}
    F = {f: r[0] for f, r in res.items()}
    pen = {f: r[1] for f, r in res.items()}
    print({f: (round(F[f], 1), f"{pen[f]:.3g}", res[f][2]) for f in factors})
    assert finite(list(F.values()), list(pen.values()))
    for f in factors:
        assert finite(res[f][3].qmap.tau_values)
    # penetration falls with the penalty, roughly in proportion (the contact pressure hardly changes)
    fs = sorted(factors)
    for lo, hi in zip(fs, fs[1:]):
        ratio = pen[lo] / pen[hi]
        assert 0.25 * hi / lo < ratio < 2.0 * hi / lo, (lo, hi, pen[lo], pen[hi])
    assert pen[fs[-1]] < 1e-6
    # the force converges: within 0.5 % of the default penalty's from the default up, 2 % below it
    for f in fs:
        assert abs(F[f] / F[1.0] - 1) < (0.005 if f >= 1.0 else 0.02), (f, F[f], F[1.0])
    return res


def test_punch_penalty_extremes():
    """Penalty 1e-2, 1 and 1e4 x the default (0.3 E / t): all reach 8 mm of travel. Measured: force
    5275 / 5335 / 5356 N, max penetration 0.061 / 1.1e-3 / 1.3e-7 mm. At 1e4 the residual floor is
    ~2e-6 N, above atol: without StaticSolver.roundoff_floor the run failed at 0.13 mm of travel."""
    check_penalty_sweep([1e-2, 1.0, 1e4])


@pytest.mark.slow
def test_punch_penalty_every_decade():
    check_penalty_sweep([1e-2, 1e-1, 1.0, 1e1, 1e2, 1e3, 1e4])


# ----------------------------------------------------------------------------------------------
# zero impact velocity


AT_REST_ENERGIES = ("kinetic_energy_J", "max_kinetic_energy_J", "elastic_energy_J", "max_elastic_energy_J",
                    "plastic_dissipation_J", "external_work_J", "energy_balance_error")
AT_REST_SETS = ["initial_velocity.bar.value=[0.0, 0.0]", "analysis.end_time=2", "output.history_points=3"]


def check_at_rest(res):
    """The Taylor bar with no impact velocity stays as it was: length 32.4 mm, radius 3.2 mm,
    max eqps 0, every energy 0 (the largest kinetic energy, at t = 0, too), nothing non-finite."""
    assert res["converged"] is True
    assert res["length_mm"] == pytest.approx(32.4, abs=1e-12)
    assert res["radius_mm"] == pytest.approx(3.2, abs=1e-12)
    assert res["max_eqps"] == 0.0
    for k in AT_REST_ENERGIES:
        assert res[k] == 0.0, k
    assert finite(*(v for v in res.values() if isinstance(v, float)))


def test_taylor_bar_at_rest_solver():
    """Zero impact velocity at the solver level: demos/taylor_bar.toml with initial velocity (0, 0),
    built in-process (runner_explicit.build_explicit); the explicit solver runs the 2 us and the bar
    stays at rest. The declared outputs are measured as the runner does (Quantities)."""
    from fenics_plast.problem import load_problem
    from fenics_plast.quantities import Quantities
    from fenics_plast.runner_explicit import build_explicit
    problem = load_problem(ROOT / "demos" / "taylor_bar.toml", AT_REST_SETS)
    b = build_explicit(problem, COMM)
    solver = b.solver
    q = Quantities(problem.outputs, b.body, b.facet_tags, b.groups)
    stats = solver.run(problem.analysis.end_time, dt_safety=problem.analysis.dt_safety, rows=3,
                       on_row=lambda s, t: q.row(t * 1e6))
    res = q.summary("time_us")
    res.update(converged=True, steps=stats["steps"])
    check_at_rest(res)
    assert len(q.times) == 3 and q.times[-1] == pytest.approx(2.0)
    assert res["steps"] > 10
    assert np.abs(solver.u.x.array).max() == 0.0


@pytest.mark.skipif(not SERIAL, reason="tmp_path differs per rank")
def test_taylor_bar_at_rest_cli(tmp_path):
    """`fenics-plast run taylor_bar.toml --set initial_velocity.bar.value=[0.0, 0.0]`: exit status 0,
    the bar at rest in summary.json (no NaN or null: see tests/conftest.py) and a finite history.csv."""
    from fenics_plast import cli
    out = tmp_path / "out"
    args = ["run", str(ROOT / "demos" / "taylor_bar.toml"), "--out", str(out)]
    for s in AT_REST_SETS + ["output.xdmf=false", "output.plots=false"]:
        args += ["--set", s]
    assert cli.main(args) == 0
    check_at_rest(json.loads((out / "summary.json").read_text()))
    hist = np.genfromtxt(out / "history.csv", delimiter=",", names=True)
    assert finite(*(hist[n] for n in hist.dtype.names))


# ----------------------------------------------------------------------------------------------
# the suite-wide output check of tests/conftest.py


@pytest.mark.allow_nonfinite("writes bad files to test the check itself")
def test_nonfinite_output_check(tmp_path):
    """The parser behind the suite-wide check flags nan/inf cells, NaN/Infinity JSON tokens and
    nulls in summary.json results, and passes text cells, empty cells and null scene settings."""
    from conftest import nonfinite_problems
    ok = tmp_path / "ok.csv"
    ok.write_text("t,force_kN,reason\n0.0,1.5,\n1.0,2e3,min det Fu = nan\n")
    assert nonfinite_problems(ok) == []
    for cell in ("nan", "NaN", "inf", "-inf", "+Infinity"):
        bad = tmp_path / "bad.csv"
        bad.write_text(f"t,force_kN\n0.0,1.0\n1.0,{cell}\n")
        assert nonfinite_problems(bad) == [f"line 3, force_kN: {cell!r}"]
    j = tmp_path / "x.json"
    j.write_text(json.dumps({"a": [1.0, float("nan")], "b": float("-inf")}))
    assert len(nonfinite_problems(j)) == 2
    summary = tmp_path / "summary.json"
    summary.write_text(json.dumps({"final_radius_mm": None, "scene_settings": {"contact": None}}))
    assert nonfinite_problems(summary) == ["null at final_radius_mm (a non-finite float written as null?)"]
    md = tmp_path / "study.md"
    md.write_text("| run | error |\n|---|---|\n| a | 0.01 |\n| b | nan |\n")
    assert nonfinite_problems(md) == ["line 4: 'nan'"]


@pytest.mark.parametrize("scene, sets, cause", [
    ("taylor_bar", ["analysis.dt_safety=1e-9"], "analysis.dt_safety = 1e-09"),
    ("taylor_bar_wall", ["contact.*.penalty=1e16"], "the contact penalties' springs"),
    ("taylor_bar", [], None), ("taylor_bar_wall", [], None)])
def test_a_step_count_beyond_1e7_is_announced(capsys, scene, sets, cause):
    """Settings that imply more than 1e7 explicit steps are announced before the run (it went on for
    days without a word), with the estimated count and what sets the step; the shipped scene is not."""
    from fenics_plast import runner
    from fenics_plast.problem import load_problem
    from fenics_plast.runner_explicit import MANY_STEPS, estimated_steps
    problem = load_problem(ROOT / "demos" / f"{scene}.toml", sets)
    built = runner.prepare(problem, MPI.COMM_WORLD, runner.read_mesh(problem, MPI.COMM_WORLD))
    err = capsys.readouterr().err
    steps = estimated_steps(problem, built.solver)
    if cause is None:
        assert steps < 1e4 and "warning" not in err
        return
    assert steps > MANY_STEPS
    if MPI.COMM_WORLD.rank == 0:
        assert f"about {steps:.3g} time steps to analysis.end_time (" in err and cause in err
