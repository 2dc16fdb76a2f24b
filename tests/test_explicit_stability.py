"""Time-step collapse and selective mass scaling of the explicit solver (issue 13).

(a) The Taylor bar at 400 m/s: the stable step collapses near 25 us (the axis cells flatten) and the
run stops through the time-step floor within seconds, exit 1, with the message naming the cell and the
remedies, and a complete summary.json (outputs at the stop, statistics, where and why), history row,
fields and checkpoint at the stop. (b) Selective mass scaling: the cells that get mass are those whose
own stable step, computed here independently from the deformed vertices, is below the target; mass
goes to their nodes only, each reaches the target, the added mass equals the mass increase and the
cells' share computed by dolfinx, nothing is removed; the energy balance closes with the kinetic energy
the added mass brought in (and not without it); fused = ufl route, serial = 2 ranks, and a run killed
and resumed from its checkpoint carries the added mass. (c) The element step of ``stable_step =
"element"`` against a closed case. (d) ``--vary`` lists of vectors (the velocity sweep).
"""
import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI

from fenics_plast import cli
from fenics_plast import dolfinx_compat as dc
from fenics_plast.problem import load_problem
from fenics_plast.runner_explicit import build_explicit
from fenics_plast.study.plan import parse_vary
from scene_runs import needs_mpirun, serial_and_two_ranks

REPO = Path(__file__).resolve().parent.parent
TOML = REPO / "demos" / "taylor_bar.toml"
SERIAL = MPI.COMM_WORLD.size == 1
E, NU, RHO = 117e3, 0.35, 8930.0e-12          # the scene's copper [MPa, -, tonne/mm^3]
LAM, MU = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))
C = math.sqrt((LAM + 2 * MU) / RHO)           # dilatational wave speed [mm/s]
sys.path.insert(0, str(Path(__file__).resolve().parent))


def build(*sets):
    problem = load_problem(TOML, ["output.history_points=3", *sets])
    return build_explicit(problem, MPI.COMM_WORLD)


def cells_cyclic(s):
    """Owned cells' nodes (basix order) and the same in cyclic order."""
    nodes = dc.cell_dofs(s.V)[: s.n_cells_own]
    return nodes, nodes[:, [0, 1, 3, 2]]


def size_dt(s):
    """h / c of every owned cell from its deformed vertices (smallest edge or distance of a vertex
    from the line of an edge it is not on), written here without the solver's kernel."""
    x = s.V.tabulate_dof_coordinates()[:, :2] + s.u.x.array.reshape(-1, 2)
    P = x[cells_cyclic(s)[1]]
    h = np.full(len(P), np.inf)
    for k in range(4):
        a, e = P[:, k], P[:, (k + 1) % 4] - P[:, k]
        le = np.linalg.norm(e, axis=1)
        h = np.minimum(h, le)
        for m in (2, 3):
            d = P[:, (k + m) % 4] - a
            h = np.minimum(h, np.abs(e[:, 0] * d[:, 1] - e[:, 1] * d[:, 0]) / le)
    return h / C


def cell_masses(s):
    """Mass of each owned cell, int rho 2 pi r dA, assembled by dolfinx on a DG0 space [tonne]."""
    D0 = dc.function_space(s.mesh, "DG", 0)
    b = fem_petsc.assemble_vector(fem.form(RHO * ufl.TestFunction(D0) * s.kin.weight * s.kin.dx))
    vals = b.array.copy()
    b.destroy()
    return vals[dc.cell_dofs(D0).reshape(-1)[: s.n_cells_own]]


# ----------------------------------------------------------------------------------------------
# (a) the floor


def test_collapse_stops_through_the_floor(tmp_path):
    out = tmp_path / "v400"
    # the size estimate h / c collapses here (the element step takes the bar on to the fold at 26 us)
    rc = cli.main(["run", str(TOML), "--out", str(out), "--set", "initial_velocity.bar.value=[0.0,-400.0]",
                   "--set", "analysis.stable_step=size", "--set", "analysis.end_time=40",
                   "--set", "output.history_points=81",
                   "--set", "output.checkpoint_every=5000", "--set", "output.plots=false"])
    assert rc == 1
    s = json.loads((out / "summary.json").read_text())
    assert s["converged"] is False
    msg = s["error"]
    for part in ("time step collapsed at t = ", "below analysis.dt_floor = 0.001", "It is set by cell ",
                 "at (r, z) = (", "aspect ratio", "volume ratio J = ", "corner angles", "Remedies:",
                 "--set analysis.mass_scaling_dt=", "mesh.refine", "--set analysis.stable_step=element"):
        assert part in msg, part
    # where, when and how much: the case (93 ns -> below 1e-10 ns at 25.26 us)
    assert 24.0 < s["stopped_at_us"] < 26.0
    assert s["dt_collapse_ratio"] < 1e-3 and s["dt_stable_final_s"] < 1e-3 * s["dt_stable_initial_s"]
    assert s["collapse_cell_size_mm"] / (s["wave_speed_m_s"] * 1e3) == pytest.approx(s["dt_stable_final_s"],
                                                                                        rel=1e-9)
    assert s["collapse_cell_reference_mm"][0] < 0.6          # the innermost column, along the axis
    assert s["collapse_cell_max_angle_deg"] > 150.0            # a wedge
    assert s["collapse_cell_dt_element_s"] > 10 * s["dt_stable_final_s"]
    assert s["step_loop_time_s"] < 30.0                     # stopped within seconds, not crawling
    # every declared output at the stop, and the run statistics
    for k in s["key_results"] + s["info_results"] + ["steps", "dt_min_s", "dt_stable_initial_s", "cells"]:
        assert isinstance(s[k], (int, float)) and math.isfinite(s[k]), k
    assert s["max_eqps"] > 4.0 and s["radius_mm"] > 9.0
    # history, fields and checkpoint at the stop
    rows = (out / "history.csv").read_text().splitlines()
    assert float(rows[-1].split(",")[0]) == pytest.approx(s["stopped_at_us"], rel=1e-12)
    assert float(rows[-2].split(",")[0]) < s["stopped_at_us"]
    times = re.findall(r'Time Value="([^"]+)"', (out / "fields.xdmf").read_text())
    assert float(times[-1]) == pytest.approx(s["stopped_at_us"], rel=1e-12)
    manifests = sorted((out / "checkpoint").glob("ckpt_*.json"))
    assert manifests and json.loads(manifests[-1].read_text())["counter"] == s["steps"]


def test_no_floor_without_collapse():
    """A run whose step does not collapse is untouched by the floor (the default scene's first 10 us)."""
    b = build("analysis.end_time=10")
    stats = b.solver.run(10e-6, rows=3, progress=0, dt_floor=0.01)
    assert stats["dt_stable_final"] > 0.01 * stats["dt_stable_initial"]


# ----------------------------------------------------------------------------------------------
# (b) selective mass scaling


@pytest.mark.skipif(not SERIAL, reason="serial bookkeeping (2 ranks: test_serial_vs_mpi_mass_scaling)")
def test_mass_goes_to_the_cells_below_the_target():
    s = build("analysis.end_time=6", "analysis.stable_step=size").solver     # the cells' h / c: size_dt
    s.run(6e-6, rows=3, progress=0)                  # deformed, no mass scaling yet
    d = size_dt(s)
    target = float(np.sort(d)[12]) * (1 + 1e-9)     # a dozen cells below it
    below = np.flatnonzero(d < target)
    assert 5 <= below.size < s.n_cells_own // 4
    m0 = s.mass.copy()
    v = s.v.x.array[: s.n_own].copy()
    assert s.scale_mass(target) == below.size
    # the cells scaled, and by how much: each reaches the target
    assert np.array_equal(np.flatnonzero(s.cell_steps.cell_scale > 1.0), below)
    np.testing.assert_allclose(d[below] * np.sqrt(s.cell_steps.cell_scale[below]), target, rtol=1e-12)
    assert s.stable_dt() == pytest.approx(target, rel=1e-12)
    # the nodes that got mass: exactly those of the scaled cells (both components alike)
    nodes = cells_cyclic(s)[0]
    dm = s.mass - m0
    assert np.array_equal(np.flatnonzero(dm[0::2] > 0), np.unique(nodes[below]))
    assert np.array_equal(dm[0::2], dm[1::2]) and (dm >= 0).all()
    # how much: the mass increase, the reported added mass and the cells' share (dolfinx) agree
    stats = s.cell_steps.mass_scaling_stats()
    cm = cell_masses(s)
    assert stats["added_mass"] == pytest.approx(dm[0::2].sum(), rel=1e-12)
    assert stats["added_mass"] == pytest.approx(float(((s.cell_steps.cell_scale - 1.0) * cm).sum()), rel=1e-12)
    assert stats["body_mass"] == pytest.approx(float(cm.sum()), rel=1e-12)
    assert stats["body_mass"] == pytest.approx(RHO * math.pi * 3.2 ** 2 * 32.4, rel=1e-12)
    assert stats["cells"] == below.size and stats["fraction"] == stats["added_mass"] / stats["body_mass"]
    # the added mass keeps the nodes' velocity: the kinetic energy it brought in
    assert stats["energy"] == pytest.approx(0.5 * float(np.dot(dm * v, v)), rel=1e-12)
    assert stats["kinetic"] == pytest.approx(stats["energy"], rel=1e-12)
    # never removed, never counted twice
    m1, f1 = s.mass.copy(), s.cell_steps.cell_scale.copy()
    assert s.scale_mass(target) == 0 and s.scale_mass(0.5 * target) == 0
    assert np.array_equal(s.mass, m1) and np.array_equal(s.cell_steps.cell_scale, f1)


def test_energy_balance_with_mass_scaling():
    """30 us at a target of 0.1 us (86 % of the initial step): 70 % mass added to 40-odd cells; the
    balance closes with the kinetic energy the mass brought in (12 % of KE0), not without it."""
    b = build("analysis.end_time=30")
    s = b.solver
    s.run(30e-6, rows=3, progress=0, mass_scaling_dt=0.1e-6)
    e, m = s.energies(), s.cell_steps.mass_scaling_stats()
    assert 20 < m["cells"] < s.cells_global and m["fraction"] > 0.3
    assert e["mass_scaling"] == m["energy"] > 0.05 * s.KE0
    assert e["balance_error"] < 0.01
    without = abs(e["kinetic"] + e["internal_work"] - s.KE0) / s.KE0
    assert without > 5 * e["balance_error"]
    s.scale_mass(0.1e-6)                            # (the run ends between two checks)
    assert s.stable_dt() >= 0.1e-6 * (1 - 1e-11)


def test_fused_equals_ufl_with_mass_scaling(tmp_path):
    """Same run, both internal-force routes (the ufl route step by step): same mass, same motion."""
    res = {}
    for route in ("fused", "ufl"):
        s = build("analysis.end_time=5", f"analysis.internal_force={route}").solver
        s.run(5e-6, rows=3, progress=0, mass_scaling_dt=0.1e-6)
        res[route] = (s.step_count, s.mass.copy(), s.u.x.array.copy(), s.cell_steps.mass_scaling_stats())
    (na, ma, ua, sa), (nb, mb, ub, sb) = res["fused"], res["ufl"]
    assert na == nb and sa["cells"] == sb["cells"] > 0
    np.testing.assert_allclose(mb, ma, rtol=1e-10)
    assert np.abs(ub - ua).max() <= 1e-10 * np.abs(ua).max()
    assert sb["energy"] == pytest.approx(sa["energy"], rel=1e-8)


@needs_mpirun
def test_serial_vs_mpi_mass_scaling(tmp_path):
    a, b = serial_and_two_ranks(REPO / "tests" / "mpi_mass_scaling.py", ["8", "0.1"], tmp_path)
    assert int(b["ranks"]) == 2 and int(a["steps"]) == int(b["steps"])
    assert int(a["cells"]) == int(b["cells"]) > 0
    np.testing.assert_allclose(a["X"], b["X"], atol=1e-12)
    np.testing.assert_allclose(b["mass"], a["mass"], rtol=1e-10)       # assembled over the ranks
    assert np.abs(a["u"] - b["u"]).max() <= 1e-8 * np.abs(a["u"]).max()
    for k in ("added_mass", "energy", "kinetic_added", "kinetic"):
        assert float(b[k]) == pytest.approx(float(a[k]), rel=1e-8), k


@pytest.mark.skipif(not SERIAL, reason="starts its own processes")
def test_checkpoint_carries_the_added_mass(tmp_path):
    """Killed while writing its 3rd checkpoint (step 120; mass is added from ~step 55) and resumed from
    the 2nd: the same run as uninterrupted, added mass included."""
    import checkpoint_driver
    args = [str(TOML), "--set", "analysis.end_time=10", "--set", "output.history_points=21",
            "--set", "output.checkpoint_every=40", "--set", "analysis.mass_scaling_dt=0.1",
            "--set", "output.plots=false", "--set", "output.xdmf=false"]
    ref, res = tmp_path / "ref", tmp_path / "res"
    assert checkpoint_driver.run_job(["run", *args, "--out", ref], tmp_path / "ref.npz") == 0
    env = dict(os.environ, FENICS_PLAST_KILL_AFTER_CHECKPOINTS="2", FENICS_PLAST_KILL_POINT="during")
    r = subprocess.run([sys.executable, "-m", "fenics_plast.cli", "run", *args, "--out", str(res)], cwd=REPO,
                       env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 137, r.stdout[-2000:] + r.stderr[-2000:]
    manifest = json.loads(sorted((res / "checkpoint").glob("ckpt_*.json"))[-1].read_text())
    assert manifest["counter"] == 80
    saved = np.load(sorted((res / "checkpoint").glob("ckpt_000000080.rank0.npz"))[0])
    assert "solver.mass" in saved.files and "solver.cell_scale" in saved.files
    assert (saved["solver.cell_scale"] > 1.0).any()            # mass had been added before the checkpoint
    assert checkpoint_driver.run_job(["run", *args, "--resume", res], tmp_path / "res.npz") == 0
    sa, sb = (json.loads((d / "summary.json").read_text()) for d in (ref, res))
    assert sb["resumed_from_checkpoint"] == 80
    for k in ("added_mass_kg", "added_mass_fraction", "mass_scaling_energy_J", "added_mass_kinetic_energy_J",
              "radius_mm", "length_mm", "energy_balance_error", "wall_energy_J"):
        assert sb[k] == pytest.approx(sa[k], rel=1e-10, abs=1e-20), k
    assert sb["mass_scaled_cells"] == sa["mass_scaled_cells"] > 0 and sb["steps"] == sa["steps"]
    a, b = np.load(tmp_path / "ref.npz"), np.load(tmp_path / "res.npz")
    assert np.abs(a["u"] - b["u"]).max() <= 1e-10
    head = (res / "history.csv").read_text().splitlines()[0].split(",")
    assert head[-6:] == ["added_mass_kg", "added_mass_fraction", "mass_scaled_cells",
                         "added_mass_kinetic_energy_J", "mass_scaling_energy_J", "wall_energy_J"]


# ----------------------------------------------------------------------------------------------
# (c) the element step


def test_element_step_of_a_rectangle_and_a_sliver():
    """The element step 2 / omega_max of stable_step = "element" (compiled kernel) against the
    eigenvalues of the element written here with numpy (plane strain, full integration, 2 x 2 Gauss,
    lumped mass): the reference rectangle and a flattened axis cell of the 400 m/s bar, whose size
    estimate h / c (the altitude at its 179.9 degree corner) is 40 x below its element's step."""
    from fenics_plast.solvers.quad_step import quad_eig_dt, quad_min_size

    def element_dt(P):                         # numpy: plane strain, full integration, lumped mass
        g = 1 / math.sqrt(3)
        xn = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], float)
        D = np.array([[LAM + 2 * MU, LAM, 0], [LAM, LAM + 2 * MU, 0], [0, 0, MU]])
        K, m = np.zeros((8, 8)), np.zeros(4)
        for xi in (-g, g):
            for eta in (-g, g):
                N = 0.25 * (1 + xi * xn[:, 0]) * (1 + eta * xn[:, 1])
                dN = 0.25 * np.stack([xn[:, 0] * (1 + eta * xn[:, 1]), xn[:, 1] * (1 + xi * xn[:, 0])], 1)
                J = dN.T @ P
                G = np.linalg.solve(J, dN.T).T
                B = np.zeros((3, 8))
                B[0, 0::2], B[1, 1::2], B[2, 0::2], B[2, 1::2] = G[:, 0], G[:, 1], G[:, 1], G[:, 0]
                K += B.T @ D @ B * np.linalg.det(J)
                m += RHO * N * np.linalg.det(J)
        M = np.repeat(m, 2)
        return 2 / math.sqrt(np.linalg.eigvalsh(K / np.sqrt(np.outer(M, M))).max()), m

    for P in ([[0, 0], [0.533, 0], [0.533, 0.9], [0, 0.9]],
              [[0.0, 0.0779], [3.4152, 0.0396], [2.9942, 0.0528], [0.0, 0.1426]]):   # a 400 m/s axis cell
        P = np.array(P, float)
        ref, m = element_dt(P)
        out = quad_eig_dt(P, np.arange(4).reshape(1, 4), np.array([0]), m[None], np.array([LAM]),
                          np.array([MU]), False, False, np.empty(1))
        assert out[0] == pytest.approx(ref, rel=1e-12)
    assert quad_min_size(P[None])[0] / C < ref / 40


def test_element_policy_takes_the_element_step_where_larger():
    b = build("analysis.end_time=30", "analysis.stable_step=element")
    s = b.solver
    s.run(30e-6, rows=3, progress=0)
    d = size_dt(s)
    s.cell_steps.size_dt()                         # (the node positions of the element steps)
    e = s.cell_steps.element_dt(np.arange(s.n_cells_own))
    assert s.stable_dt() == pytest.approx(float(np.maximum(d, e).min()), rel=1e-12)
    assert s.stable_dt() > d.min()                 # the flattened axis cells: their element is not that thin


# ----------------------------------------------------------------------------------------------
# (d) the sweep's values


def test_vary_lists_of_vectors():
    v = parse_vary("initial_velocity.bar.value=[0.0,-100.0],[0.0, -150.0],[0.0,-227.0]")
    assert v.values == ["[0.0,-100.0]", "[0.0, -150.0]", "[0.0,-227.0]"]
