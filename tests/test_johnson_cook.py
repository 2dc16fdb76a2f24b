"""Johnson-Cook flow stress with adiabatic heating (fenics_plast/material/hardening.py, kernels.py).

    sigma_y = (A + B eqps^n)(1 + C ln(max(rate, rate_0) / rate_0))(1 - T*^m),  dT = chi sigma_y d eqps,
    chi = beta / (rho c_p),  T* = (T - T_room) / (T_melt - T_room) clamped to [0, 1]

Checked here:

* the material-point driver at a constant log-strain rate against the adiabatic curve of the
  continuous model, an ODE in eqps integrated independently (scipy Radau): the return map is
  backward Euler in time (rate over the increment, T at its end), first order; the error halves
  when the increments double, and at 2000 increments it is below 2e-5 of the stress;
* without rate term and heating (C = 0, beta = 0, T = T_room) the law is the power law
  A + B eqps^n: the driver meets it to 1e-10 in both models, and matches the linear law for n = 1;
  the static convention (no physical time) and rates below the reference rate give the same;
* the heating is the plastic work: T - T_0 = chi sum(tau d eqps) of the driver to round-off;
* the consistent tangent (rate term C / dg, implicit T) against central differences, both models;
* the fused explicit pass against the UFL route with temperature, the temperature in checkpoints,
  the scene keys and the CLI's --rate.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from fenics_plast.errors import SceneError
from fenics_plast.material import Hardening, Material, MaterialRegions
from fenics_plast.material.hardening import JC_CHI
from fenics_plast.material.point import simple_shear, uniaxial_stress

REPO = Path(__file__).resolve().parent.parent
MODELS = ["seed", "isochoric"]
E, NU = 124e3, 0.34
# OFHC copper, Johnson & Cook (1983); density 8960 kg/m^3 = 8.96e-9 tonne/mm^3
OFHC = dict(A=90.0, B=292.0, n=0.31, C=0.025, reference_strain_rate=1.0, m=1.09, melting_temperature=1356.0,
            room_temperature=294.0, specific_heat=383.0, taylor_quinney=0.9, density=8.96e-9)


def jc(**changes):
    return Hardening("johnson_cook", **{**OFHC, **changes})


def flow_stress(p, eps, rate, T):
    """The Johnson-Cook formula, written out directly."""
    ts = min(max((T - p["room_temperature"]) / (p["melting_temperature"] - p["room_temperature"]), 0.0), 1.0)
    r = max(rate, p["reference_strain_rate"]) / p["reference_strain_rate"]
    return (p["A"] + p["B"] * eps ** p["n"]) * (1.0 + p["C"] * np.log(r)) * (1.0 - ts ** p["m"])


def test_flow_stress_formula_and_clamps():
    p = {**OFHC, "initial_temperature": 500.0}
    h = jc(initial_temperature=500.0)
    for eps, rate, T in [(0.3, 1e3, 500.0), (0.0, 10.0, 294.0), (1.2, 0.5, 800.0), (0.5, 1e5, 250.0),
                         (0.5, 1e3, 1356.0), (0.5, 1e3, 1500.0)]:
        assert h.johnson_cook(eps, rate, T) == pytest.approx(flow_stress(p, eps, rate, T), rel=1e-14, abs=1e-12)
    assert h.johnson_cook(0.5, 1e3, 250.0) == h.johnson_cook(0.5, 1e3, 294.0)     # no strengthening below room
    assert h.johnson_cook(0.5, 0.2, 400.0) == h.johnson_cook(0.5, 1.0, 400.0)     # nor below the reference rate
    assert h.johnson_cook(0.5, 1e3, 1400.0) == 0.0                                 # no strength above melting
    # the quasi-static isothermal curve at the initial temperature
    assert h(0.25)[0] == pytest.approx(flow_stress(p, 0.25, 0.0, 500.0), rel=1e-14)
    assert h.initial_temperature == 500.0 and h.thermal
    # chi = beta / (rho c_p): rho c_p = 8.96e-9 t/mm^3 x 383 J/(kg K) = 3.43168 MPa/K
    assert h.params[JC_CHI] == pytest.approx(0.9 / 3.43168, rel=1e-12)


# ----------------------------------------------------------------------------------------------
# the adiabatic curve at constant strain rate


def adiabatic_ode(h: Hardening, E: float, rate: float, eps_end: float):
    """Uniaxial stress at the constant axial log-strain rate ``rate``, isochoric model (Hencky: the
    axial log strain is tau / E + eqps exactly), rate-dependent flow tau = S(eqps, d eqps/dt, T):

        d t / d eqps = 1 / r,   r = rate_0 exp((tau / (G1 theta(T)) - 1) / C),   tau = E (rate t - eqps)
        d T / d eqps = chi tau

    (G1 = A + B eqps^n), integrated in eqps with scipy's Radau (the system is stiff: the rate
    follows the stress exponentially). It starts where the plastic rate reaches rate_0: before,
    the flow is rate independent (tau = G1 theta, the plastic rate rate / (1 + G1'/E) below
    rate_0 while G1' > E (rate / rate_0 - 1), i.e. eqps < 4e-10 here: T changes by < 1e-7 K there).
    Returns the dense solution y(eqps) = (t, T) and the function tau(eqps, y)."""
    from scipy.integrate import solve_ivp
    A, B, n, C, r0, m, Tm, Tr, chi, T0 = h.params

    def theta(T):
        ts = min(max((T - Tr) / (Tm - Tr), 0.0), 1.0)
        return 1.0 - ts ** m

    eps_s = (E * (rate / r0 - 1.0) / (B * n * theta(T0))) ** (1.0 / (n - 1.0))
    t_s = (eps_s + (A + B * eps_s ** n) * theta(T0) / E) / rate

    def rhs(ep, y):
        t, T = y
        tau = E * (rate * t - ep)
        r = r0 * np.exp((tau / ((A + B * ep ** n) * theta(T)) - 1.0) / C)
        return [1.0 / r, chi * tau]

    sol = solve_ivp(rhs, (eps_s, eps_end), [t_s, T0], method="Radau", rtol=1e-11, atol=[1e-16, 1e-9],
                    dense_output=True)
    assert sol.status == 0
    return sol.sol, lambda ep, y: E * (rate * y[0] - ep)


def test_point_driver_follows_the_adiabatic_curve():
    """Copper from 400 K at 2000/s to log strain 1: stress and temperature rise along eqps against
    the ODE. Backward Euler in time is first order: the error halves from 1000 to 2000 increments
    (ratio 1.9-2.1), is below 2e-5 of the stress and 2.5e-4 of the temperature rise at 2000, and
    the Richardson extrapolation 2 x(2000) - x(1000) leaves the second-order remainder, below 1e-6
    and 1e-5 (the ODE is solved to 1e-11)."""
    h = jc(initial_temperature=400.0)
    mat = Material(E, NU, h, "isochoric")
    rate = 2000.0
    y, tau_of = adiabatic_ode(h, E, rate, 1.0)
    errs = {}
    for steps in (1000, 2000):
        d = uniaxial_stress(mat, 1.0, steps, rate=rate)
        assert d["time_s"][-1] == pytest.approx(1.0 / rate, rel=1e-14)
        ep, tau, T = d["eqps"], d["kirchhoff_axial_MPa"], d["temperature_K"]
        sel = ep > 0.05
        ode = y(ep[sel])
        tau_ode = tau_of(ep[sel], ode)
        rise = ode[1].max() - 400.0
        errs[steps] = ((tau[sel] - tau_ode) / tau_ode.max(), (T[sel] - ode[1]) / rise)
        print(f"\n{steps} increments: final tau {tau[-1]:.6f} MPa (ODE {tau_ode[-1]:.6f}), T {T[-1]:.4f} K (ODE "
              f"{ode[1][-1]:.4f}), eqps {ep[-1]:.6f}; max error tau {np.abs(errs[steps][0]).max():.3e}, "
              f"T rise {np.abs(errs[steps][1]).max():.3e}")
    assert 80.0 < rise < 100.0          # heating matters: ~ 90 K, 7 % of strength
    for k in (0, 1):
        e1, e2 = errs[1000][k][-1], errs[2000][k][-1]        # at the end of the path (log strain 1)
        assert 1.9 < e1 / e2 < 2.1, (k, e1, e2)
    assert np.abs(errs[2000][0]).max() < 2e-5 and np.abs(errs[2000][1]).max() < 2.5e-4
    rich_tau = abs(2 * errs[2000][0][-1] - errs[1000][0][-1])
    rich_T = abs(2 * errs[2000][1][-1] - errs[1000][1][-1])
    print(f"Richardson (end of path): tau {rich_tau:.2e}, T rise {rich_T:.2e}")
    assert rich_tau < 1e-6 and rich_T < 1e-5


@pytest.mark.parametrize("model", MODELS)
def test_heating_is_the_plastic_work(model):
    """Implicit heating: T_k = T_{k-1} + chi q_k (eqps_k - eqps_{k-1}) at every increment, q the von
    Mises stress at the end of the increment; in uniaxial stress q = |tau_11| up to the lateral stress
    the driver's Newton leaves (1e-12 E = 1.2e-7 MPa, 3e-10 of q): T - T_0 = chi sum tau d eqps to 1e-9."""
    h = jc()
    d = uniaxial_stress(Material(E, NU, h, model), 0.8, 200, rate=5e3)
    tau, ep, T = d["kirchhoff_axial_MPa"], d["eqps"], d["temperature_K"]
    work = h.params[JC_CHI] * np.cumsum(np.abs(tau[1:]) * np.diff(ep))
    np.testing.assert_allclose(T[1:] - T[0], work, rtol=1e-9, atol=1e-12)
    assert T[-1] - T[0] > 50.0


# ----------------------------------------------------------------------------------------------
# the power law: no rate term, no heating


@pytest.mark.parametrize("model", MODELS)
def test_without_rate_and_heating_is_the_power_law(model):
    """T* = 0, C = 0, beta = 0: at every plastic increment the uniaxial stress is A + B eqps^n (the
    radial return meets the flow stress) to 1e-10, driven in time (the JC path with dt > 0), without
    time (static convention) and, with C != 0, below the reference rate (max(rate, rate_0))."""
    runs = {"rate-free": (dict(C=0.0, taylor_quinney=0.0), 1e3),
            "static": (dict(taylor_quinney=0.0), None),
            "slow": (dict(taylor_quinney=0.0), 0.5)}
    for name, (kw, rate) in runs.items():
        d = uniaxial_stress(Material(E, NU, jc(**kw), model), 0.6, 60, rate=rate)
        ep, tau = d["eqps"], d["kirchhoff_axial_MPa"]
        plastic = ep > 0
        assert plastic.sum() >= 59
        np.testing.assert_allclose(tau[plastic], 90.0 + 292.0 * ep[plastic] ** 0.31, rtol=1e-10, err_msg=name)
        if rate is not None:
            assert np.all(d["temperature_K"] == 294.0)


@pytest.mark.parametrize("model", MODELS)
def test_linear_exponent_matches_the_linear_law(model):
    """n = 1, C = 0, beta = 0: Johnson-Cook is the linear law sigma_0 + H eqps; every column of the
    driver (uniaxial and simple shear) agrees to 1e-10."""
    a = Material(E, NU, jc(n=1.0, C=0.0, taylor_quinney=0.0), model)
    b = Material(E, NU, Hardening("linear", yield_stress=90.0, modulus=292.0), model)
    for da, db in [(uniaxial_stress(a, 0.5, 50, rate=1e3), uniaxial_stress(b, 0.5, 50)),
                   (simple_shear(a, 1.0, 50, rate=1e3), simple_shear(b, 1.0, 50))]:
        assert da["eqps"][-1] > 0.3
        for k, v in db.items():
            np.testing.assert_allclose(da[k], v, rtol=1e-10, atol=1e-10 * max(np.abs(v).max(), 1.0), err_msg=k)


# ----------------------------------------------------------------------------------------------
# consistent tangent


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("dt", [1e-6, 1e-8, 0.0], ids=["rate_1e4", "rate_1e6", "static"])
def test_consistent_tangent_matches_central_differences(model, dt):
    """delta tau = a : (delta F F^-1) against central differences of the update, h = 1e-6, with the
    rate term (plastic rates ~1e2-1e4/s or ~1e4-1e6/s, above the reference rate) and implicit heating
    from 294-700 K, and the static convention (dt = 0); virgin and hardened points, elastic points."""
    rng = np.random.default_rng(4)
    mat = Material(E, NU, jc(), model)
    n = 30
    Fu = np.eye(3) + 0.01 * rng.standard_normal((n, 3, 3))
    binv_n = np.eye(3) + 0.001 * rng.standard_normal((n, 3, 3))
    binv_n = 0.5 * (binv_n + binv_n.transpose(0, 2, 1))
    eqps_n = 0.5 * rng.random(n)
    eqps_n[5:10] = 0.0                                        # virgin points: eps^n at eps = 0
    T_n = 294.0 + 400.0 * rng.random(n)
    Fu[:5] = np.eye(3) + 1e-7 * rng.standard_normal((5, 3, 3))
    binv_n[:5] = np.eye(3)
    tau, _, eqps, T, a = mat.update_thermal(Fu, binv_n, eqps_n, T_n, dt)
    plastic = eqps > eqps_n
    assert plastic[5:].all() and not plastic[:5].any()
    if dt > 0:
        assert (T[5:] > T_n[5:]).all() and (T[:5] == T_n[:5]).all()
        rates = (eqps - eqps_n)[5:] / dt
        assert rates.min() > 10.0
    else:
        assert (T == T_n).all()
    h = 1e-6
    a_fd = np.zeros_like(a)
    for k in range(3):
        for l in range(3):
            dF = np.zeros((3, 3))
            dF[k, l] = h
            tp = mat.update_thermal((np.eye(3) + dF) @ Fu, binv_n, eqps_n, T_n, dt, tangent=False)[0]
            tm = mat.update_thermal((np.eye(3) - dF) @ Fu, binv_n, eqps_n, T_n, dt, tangent=False)[0]
            a_fd[..., k, l] = (tp - tm) / (2 * h)
    err = np.linalg.norm((a - a_fd).reshape(n, -1), axis=1) / np.linalg.norm(a.reshape(n, -1), axis=1)
    assert err.max() < 1e-6, err.max()


def test_regions_heat_only_johnson_cook_points():
    """MaterialRegions: a Johnson-Cook part heats, a linear part keeps the temperature it is given;
    each point as in a body of its own material."""
    hot = Material(E, NU, jc(), "isochoric")
    cold = Material(E, NU, Hardening("linear", yield_stress=90.0, modulus=292.0), "isochoric")
    regions = MaterialRegions([(hot, [0, 2]), (cold, [1])], 3)
    assert regions.thermal
    T0 = regions.initial_temperatures(12)
    assert np.array_equal(T0, np.repeat([294.0, 0.0, 294.0], 4))
    Fu = np.repeat(np.diag([1.02, 0.99, 0.99])[None], 12, 0)
    tau, binv, eqps, T, _ = regions.update_thermal(Fu, np.repeat(np.eye(3)[None], 12, 0), np.zeros(12), T0, 1e-6)
    ref = hot.update_thermal(Fu[:4], np.repeat(np.eye(3)[None], 4, 0), np.zeros(4), T0[:4], 1e-6)
    assert np.array_equal(T[:4], ref[3]) and np.array_equal(tau[:4], ref[0]) and (T[:4] > 294.0).all()
    assert (T[4:8] == 0.0).all() and (eqps[4:8] > 0).all()


# ----------------------------------------------------------------------------------------------
# explicit: fused pass against the UFL route, checkpoints


def _solver(route, model):
    from fenics_plast.kinematics import Kinematics
    from fenics_plast.meshing import bar_mesh
    from fenics_plast.solvers.explicit import ExplicitDynamics
    mesh, _, _, _ = bar_mesh(MPI.COMM_SELF, 3.0, 8.0, 3, 5)
    kin = Kinematics(mesh, "axisymmetric")
    mat = Material(117e3, 0.35, jc(initial_temperature=350.0), model=model)
    return ExplicitDynamics(mesh, kin, mat, 8.96e-9, (), element="q1p0", internal_force=route, log=lambda m: None)


def _two_increments(s):
    """Two increments of a smooth, non-homogeneous field (as tests/test_fused_force.py), each over
    dt = 1 us: plastic rates 1e3-1e5/s, heating."""
    r, z = s.reference_positions[:, 0], s.reference_positions[:, 1]
    for scale in (1.0, 1.04):
        u = np.empty((len(r), 2))
        u[:, 0] = scale * (0.08 * r * (1.0 + 0.3 * z / 8.0) + 0.01 * z)
        u[:, 1] = scale * (-0.06 * z - 0.004 * z * z / 8.0 + 0.02 * r)
        s.u_n.x.array[:] = s.u.x.array
        if s.theta is not None:
            s.theta_n.x.array[:] = s.theta.x.array
        s.u.x.array[:] = u.reshape(-1)
        s.qmap.dt[0] = 1e-6
        s.internal_force()
    return s


@pytest.mark.parametrize("model", MODELS)
def test_fused_force_equals_ufl_route(model):
    fused = _two_increments(_solver("fused", model))
    ufl = _two_increments(_solver("ufl", model))
    assert fused.qmap.eqps.max() > 0.02 and fused.qmap.temperature.max() > 355.0
    assert np.abs(fused.f - ufl.f).max() <= 1e-12 * np.abs(ufl.f).max()
    for name in ("tau_values", "binv", "eqps", "temperature"):
        a, b = getattr(fused.qmap, name), getattr(ufl.qmap, name)
        assert np.abs(a - b).max() <= 1e-12 * max(np.abs(b).max(), 1.0), name


def test_taylor_scene_same_with_either_route_and_checkpoint_round_trip():
    """5 us of demos/taylor_bar_jc.toml by both routes: same displacements, eqps and temperatures to
    1e-10; the heat is 0.9 of the plastic dissipation; the temperature goes into the solver's
    checkpoint state and comes back."""
    from fenics_plast.problem import load_problem
    from fenics_plast.runner_explicit import build_explicit
    out = {}
    for route in ("fused", "ufl"):
        problem = load_problem(REPO / "demos" / "taylor_bar_jc.toml",
                               [f"analysis.internal_force={route}", "analysis.end_time=5"])
        s = build_explicit(problem, MPI.COMM_SELF).solver
        s.run(5e-6, rows=2, progress=0)
        out[route] = s
    f, u = out["fused"], out["ufl"]
    assert f.step_count == u.step_count and f.max_eqps() > 0.5
    assert f.qmap.temperature.max() > 320.0
    assert np.abs(f.u.x.array - u.u.x.array).max() <= 1e-10 * np.abs(u.u.x.array).max()
    np.testing.assert_allclose(f.qmap.temperature, u.qmap.temperature, rtol=1e-10)
    np.testing.assert_allclose(f.qmap.eqps, u.qmap.eqps, rtol=1e-10, atol=1e-12)
    # the heat rho c_p int (T - T0) dV is the Taylor-Quinney share of the plastic dissipation (W_int -
    # elastic energy, trapezoidal in time, while the heating is backward Euler: 0.920 at 5 us, 0.902
    # over the whole 80 us run)
    heat = float(np.dot(8.96e-9 * 383.0 * 1e6 * (f.qmap.temperature - 294.0), f._wq))
    assert heat / f.energies()["plastic"] == pytest.approx(0.9, rel=0.03)
    # checkpoint state: the temperature is keyed per point and restored (trial state too)
    from fenics_plast.checkpoint import KeyedTable
    d = f.restart.state_dict()
    assert "temperature" in d
    tables = {k: (KeyedTable(k, v.values, v.keys) if hasattr(v, "keys") and hasattr(v, "values") else v)
              for k, v in d.items()}
    T = f.qmap.temperature.copy()
    f.qmap.temperature[:] = 0.0
    f.qmap.temperature_trial[:] = 0.0
    f.restart.load_state(tables)
    assert np.array_equal(f.qmap.temperature, T) and np.array_equal(f.qmap.temperature_trial, T)


def test_kill_and_resume_keeps_the_temperature(tmp_path):
    """The JC Taylor scene killed at its 2nd checkpoint and resumed: the summary (max temperature
    included) matches an uninterrupted run to 1e-10. The run writes the temperature to fields.xdmf
    and final_shape.csv."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import checkpoint_driver
    args = [str(REPO / "demos" / "taylor_bar_jc.toml"), "--set", "analysis.end_time=4", "--set",
            "output.history_points=9", "--set", "output.checkpoint_every=10", "--set", "output.plots=false",
            "--set", "output.every=4"]
    ref, res = tmp_path / "ref", tmp_path / "res"
    assert checkpoint_driver.run_job(["run", *args, "--out", ref], tmp_path / "ref.npz") == 0
    env = dict(os.environ, FENICS_PLAST_KILL_AFTER_CHECKPOINTS="2", FENICS_PLAST_KILL_POINT="after")
    r = subprocess.run([sys.executable, "-m", "fenics_plast.cli", "run", *args, "--out", str(res)],
                       capture_output=True, text=True, cwd=REPO, timeout=300, env=env)
    assert r.returncode == 137, r.stdout[-2000:] + r.stderr[-2000:]
    assert checkpoint_driver.run_job(["run", *args, "--resume", res], tmp_path / "res.npz") == 0
    a = json.loads((ref / "summary.json").read_text())
    b = json.loads((res / "summary.json").read_text())
    assert b["resumed_from_checkpoint"] == 20       # the step of the 2nd checkpoint
    assert a["max_temperature_K"] > 300.0
    for k in ("max_temperature_K", "max_eqps", "radius_mm", "length_mm"):
        assert b[k] == pytest.approx(a[k], rel=1e-10), k
    # the temperature field: fields.xdmf (rows 0, 4, 8) and the final shape's cells
    assert (ref / "fields.xdmf").read_text().count('Attribute Name="temperature"') == 3
    header = (ref / "final_shape.csv").read_text().splitlines()[0].split(",")
    assert header[-2:] == ["eqps", "temperature"]


# ----------------------------------------------------------------------------------------------
# scene keys and the command line


def _scene(tmp_path, hardening: str, extra: str = "", density: str = "density = 8960.0") -> Path:
    f = tmp_path / "jc.toml"
    f.write_text(f"""
[scene]
name = "jc"
[analysis]
type = "explicit"
end_time = 1.0
[mesh]
file = "{REPO / 'meshes' / 'round_bar.geo'}"
[materials.cu]
E = 117e3
nu = 0.35
{density}
[materials.cu.hardening]
{hardening}
{extra}
""")
    return f


JC_KEYS = """law = "johnson_cook"
A = 90.0
B = 292.0
n = 0.31
C = 0.025
m = 1.09
melting_temperature = 1356.0
room_temperature = 294.0
specific_heat = 383.0"""


def test_scene_keys_are_validated(tmp_path):
    from fenics_plast.problem import load_problem
    from fenics_plast.build import material_of
    p = load_problem(_scene(tmp_path, JC_KEYS), [])
    mat = material_of(p.materials["cu"])
    assert mat.thermal and mat.initial_temperature == 294.0
    assert mat.hardening.params[JC_CHI] == pytest.approx(0.9 / (8.96e-9 * 383.0 * 1e6), rel=1e-12)
    bad = [({}, "density = 8960.0", "initial_temperature = 1400.0", "must be below"),
           ({}, "density = 8960.0", "melting_temperature = 200.0", "must exceed"),
           ({}, "", "", "density is missing"),
           ({}, "density = 8960.0", "taylor_quinney = 1.5", "taylor_quinney"),
           ({}, "density = 8960.0", "yield_stress = 90.0", "not a key of law 'johnson_cook'")]
    for _, dens, extra, msg in bad:
        keys = JC_KEYS if "melting" not in extra else JC_KEYS.replace("melting_temperature = 1356.0\n", "")
        with pytest.raises(SceneError, match=msg):
            load_problem(_scene(tmp_path, keys, extra, dens), [])
    lin = 'law = "linear"\nyield_stress = 90.0'
    with pytest.raises(SceneError, match="needs a material with a temperature"):
        load_problem(_scene(tmp_path, lin, '[outputs.hot]\nquantity = "field"\nfield = "temperature"'), [])


def test_cli_point_rate(tmp_path, capsys):
    from fenics_plast import cli
    out = tmp_path / "p.csv"
    assert cli.main(["point", str(REPO / "demos" / "taylor_bar_jc.toml"), "--path", "uniaxial", "--to", "0.5",
                     "--rate", "1000", "--steps", "50", "--out", str(out)]) == 0
    header = out.read_text().splitlines()[0].split(",")
    assert "time_s" in header and "temperature_K" in header
    rows = np.loadtxt(out, delimiter=",", skiprows=1)
    assert rows[-1, header.index("time_s")] == pytest.approx(5e-4)
    assert rows[-1, header.index("temperature_K")] > 310.0
    assert cli.main(["point", str(REPO / "demos" / "taylor_bar_jc.toml"), "--path", "uniaxial", "--to", "0.5",
                     "--rate", "-1"]) == 2
    assert "--rate must be a positive number" in capsys.readouterr().err
