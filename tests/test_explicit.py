"""Explicit dynamics (fenics_plast.solvers.explicit) and the Taylor bar scene (demos/taylor_bar.toml).

(a) 1-D elastic wave against its closed form; (b) a fixed time step above the stable limit is
refused; (c) serial vs mpirun -n 2; (d) a short Taylor run is reproducible and conserves energy;
the full 80 us Taylor bar against the seed paper's ranges (Table 3 and the other codes).
"""
import math
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from fenics_plast.errors import RunError
from fenics_plast.kinematics import Kinematics
from fenics_plast.material import Material
from fenics_plast.meshing import bar_mesh
from fenics_plast.problem import load_problem
from fenics_plast.quantities import Quantities
from fenics_plast.runner_explicit import build_explicit
from fenics_plast.solvers.explicit import ExplicitDynamics
from fenics_plast.solvers.quad_step import quad_min_size
from scene_runs import needs_mpirun, serial_and_two_ranks

REPO = Path(__file__).resolve().parent.parent
TOML = REPO / "demos" / "taylor_bar.toml"


def taylor(*overrides):
    return load_problem(TOML, ["output.history_points=3", *overrides])


def build(problem):
    """The scene's explicit solver: constraints and initial velocity applied, not run."""
    return build_explicit(problem, MPI.COMM_WORLD).solver


def simulate(problem):
    """Run the scene as `fenics-plast run` does, without writing files: (results, solver). The results
    are the scene's outputs at the end time (length_mm, radius_mm, max_eqps, energies) and the run
    statistics (steps, dt_s, element)."""
    b = build_explicit(problem, MPI.COMM_WORLD)
    s, ana = b.solver, problem.analysis
    stats = s.run(ana.end_time, dt_safety=ana.dt_safety, steps=ana.time_steps,
                  rows=problem.output.history_points, progress=0)
    res = Quantities(problem.outputs, b.body, b.facet_tags, b.groups).row(ana.end_time * 1e6)
    res.update(energy_balance_error=s.energies()["balance_error"], steps=stats["steps"], dt_s=stats["dt_max"],
               element=s.element)
    return res, s


def test_quad_min_size():
    P = np.array([[[0, 0], [2, 0], [2, 1], [0, 1]],            # 2 x 1 rectangle
                  [[0, 0], [1, 0], [1.5, 0.1], [0.5, 0.1]]],    # flat parallelogram
                 dtype=float)
    h = quad_min_size(P)
    assert h[0] == pytest.approx(1.0)
    assert h[1] == pytest.approx(0.1)


def test_elastic_wave_speed_and_stress():
    """A nu = 0 bar (so sqrt((lambda+2mu)/rho) = sqrt(E/rho) and no lateral strain: the 1-D theory
    is exact) moving at v0 hits a rigid wall: the front runs at c = sqrt(E/rho) and the
    stress behind it is -rho c v0 (compression)."""
    E, rho, L = 117e3, 8.93e-9, 100.0
    comm = MPI.COMM_WORLD
    mesh, _, ft, tags = bar_mesh(comm, 1.0, L, 1, 400)
    kin = Kinematics(mesh, "axisymmetric")
    mat = Material(E, 0.0, None)
    s = ExplicitDynamics(mesh, kin, mat, rho, [(0, ft.find(tags["axis"])), (1, ft.find(tags["bottom"]))],
                         log=lambda m: None)
    c = math.sqrt(E / rho)
    assert s.c == pytest.approx(c, rel=1e-12)
    v0 = 1e-4 * c                                               # strain 1e-4
    s.set_velocity((0.0, -v0))
    X = s.reference_positions
    n = s.V.dofmap.index_map.size_local
    axis = np.where(np.abs(X[:n, 0]) < 1e-12)[0]
    front = {}

    def on_row(sol, t):
        # the axis nodes of all ranks: a rank's own part of the axis may not hold the front
        z = np.concatenate(comm.allgather(X[axis, 1]))
        vz = np.concatenate(comm.allgather(sol.v.x.array.reshape(-1, 2)[axis, 1]))
        o = np.argsort(z)
        z, vz = z[o], vz[o]
        # first node (from the wall) where the bar still moves faster than v0/2
        k = np.nonzero(vz < -0.5 * v0)[0]
        zf = -np.inf
        if k.size:
            i = k[0]
            if i > 0:
                zf = z[i - 1] + (z[i] - z[i - 1]) * (-0.5 * v0 - vz[i - 1]) / (vz[i] - vz[i - 1])
            else:
                zf = z[0]
        front[t] = zf

    t_end = 0.6 * L / c
    s.run(t_end, dt_safety=0.8, rows=4, on_row=on_row)
    ts = sorted(front)[1:]                                      # skip t = 0
    zs = [front[t] for t in ts]
    c_num = np.polyfit(ts, zs, 1)[0]
    assert c_num == pytest.approx(c, rel=0.01)
    # stress behind the front, away from the front and the wall: cell means of tau_zz
    zf = zs[-1]
    tz = s.qmap.cell_mean(s.qmap.tau_values[:, 1, 1])
    D0 = tz.function_space
    xc = D0.tabulate_dof_coordinates()[: D0.dofmap.index_map.size_local]
    sel = (xc[:, 1] > 0.2 * zf) & (xc[:, 1] < 0.8 * zf)
    num = comm.allreduce(float(tz.x.array[: len(xc)][sel].sum()), op=MPI.SUM)
    cnt = comm.allreduce(int(sel.sum()), op=MPI.SUM)
    assert cnt > 50
    sigma = num / cnt
    assert sigma == pytest.approx(-rho * c * v0, rel=0.01)
    # and the elastic energy balance is near exact
    assert s.energies()["balance_error"] < 1e-3


def test_fixed_step_above_stable_limit_is_refused():
    s = build(taylor())
    dt_stable = s.stable_dt()
    assert dt_stable == pytest.approx((3.2 / 6) / s.c, rel=1e-9)       # radial cell 0.533 mm
    steps = int(80e-6 / (1.5 * dt_stable))
    with pytest.raises(RunError) as err:
        simulate(taylor(f"analysis.time_steps={steps}"))
    msg = str(err.value)
    assert f"{dt_stable:.4g}" in msg and "stable limit" in msg


def test_fixed_steps_below_limit_runs():
    res, _ = simulate(taylor("analysis.end_time=2", "analysis.time_steps=40"))
    assert res["steps"] == 40
    assert res["dt_s"] == pytest.approx(2e-6 / 40)


def test_short_taylor_reproducible_and_conservative():
    r1, _ = simulate(taylor("analysis.end_time=10"))
    r2, _ = simulate(taylor("analysis.end_time=10"))
    for k in ("length_mm", "radius_mm", "max_eqps", "energy_balance_error", "steps"):
        assert r1[k] == r2[k], k
    assert r1["energy_balance_error"] < 0.01
    assert r1["max_eqps"] > 0.5                       # plastic flow at the impact face
    assert r1["radius_mm"] > 3.2 and r1["length_mm"] < 32.4


def test_q1_element_runs():
    res, _ = simulate(taylor("analysis.end_time=5", "mesh.element=q1"))
    assert res["element"] == "q1" and res["energy_balance_error"] < 0.01


@needs_mpirun
def test_serial_vs_mpi(tmp_path):
    a, b = serial_and_two_ranks(REPO / "tests" / "mpi_explicit_taylor.py", ["5"], tmp_path)
    assert int(b["ranks"]) == 2
    assert int(a["steps"]) == int(b["steps"])
    np.testing.assert_allclose(a["X"], b["X"], atol=1e-12)
    scale = np.abs(a["u"]).max()
    assert np.abs(a["u"] - b["u"]).max() <= 1e-8 * scale
    for k in ("length_mm", "radius_mm", "max_eqps", "kinetic", "internal_work", "elastic"):
        assert float(b[k]) == pytest.approx(float(a[k]), rel=1e-8), k


def test_taylor_bar_80us_against_seed():
    """The default scene (6 x 36 Q1/P0, isochoric model): the seed paper's Table 3 ranges."""
    res, _ = simulate(taylor())
    assert 7.03 <= res["radius_mm"] <= 7.30
    assert 21.38 <= res["length_mm"] <= 21.50
    assert 2.8 <= res["max_eqps"] <= 3.3
    assert res["energy_balance_error"] < 0.01


def test_fixed_step_stopped_when_the_mesh_crushes_below_it():
    """A fixed step just below the initial limit becomes too large as the impact face crushes:
    the run stops with a RunError naming the limit instead of blowing up."""
    s = build(taylor())
    steps = int(math.ceil(80e-6 / (0.95 * s.stable_dt())))
    with pytest.raises(RunError, match="stable limit"):
        simulate(taylor(f"analysis.time_steps={steps}"))
