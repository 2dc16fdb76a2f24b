"""Never a non-finite number in a result file of the explicit solver (issue 21, item 3).

The Taylor bar above 300 m/s folds a cell: a quadrature point's Jacobian goes through zero within
one step (at 1.2-66 % of the initial stable step, far above the time-step floor, which therefore
never fires), and the material update has no answer there. Before, the compiled loop ran on with
NaN for up to 10 steps, wrote ``nan`` rows into history.csv and ``null`` into summary.json. Now the
force pass checks the new displacement's point Jacobians first, writes nothing for a folding step,
the step is undone and the run stops at the last finite state with the cell and the remedies named.

(a) The velocity sweep at the defaults (300, 600, 1000, 2000, 5000 m/s): exit 0 and a complete run,
or exit 1 through the fold guard (cell, shape, remedies named; history, fields and summary at the
stop), and no non-finite number in history.csv, summary.json, final_shape.csv or the fields
(fields.h5 read back). (b) The stop is the last finite state, bit for bit the state of a run
stopped one step earlier by ``max_steps``; fused = ufl route; fixed steps name analysis.time_steps.
(c) The force pass writes no state, stress or force for a folding cell (quadrilaterals,
hexahedra, the ufl route). (d) The runner's last-line guard. (e) Serial = 2 ranks (plain and
contact kernels).
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
from mpi4py import MPI

from fenics_plast import cli
from fenics_plast.errors import RunError
from fenics_plast.problem import load_problem
from fenics_plast.runner_explicit import SCENE_TERMS, build_explicit, fields_guard, nonfinite_guard
from fenics_plast.solvers import fused_force
from fenics_plast.solvers.collapse import CellFold
from fenics_plast.solvers.integrator import STEP_FOLDS

sys.path.insert(0, str(Path(__file__).resolve().parent))
from conftest import nonfinite_problems  # noqa: E402
from scene_runs import MPIRUN, needs_mpirun  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
TAYLOR = REPO / "demos" / "taylor_bar.toml"
TAYLOR_WALL = REPO / "demos" / "taylor_bar_wall.toml"
COMM = MPI.COMM_WORLD
SERIAL = COMM.size == 1
US = 1e-6


def velocity(v):
    return f"initial_velocity.bar.value=[0.0,-{float(v)}]"


def field_values(out):
    """{dataset: values} of every function written to fields.h5 (read with PETSc's HDF5 viewer),
    or None when this PETSc cannot read HDF5."""
    from petsc4py import PETSc
    if not hasattr(PETSc, "ViewerHDF5"):
        return None
    names = re.findall(r"fields\.h5:(/Function/[^<\s]+)", (Path(out) / "fields.xdmf").read_text())
    values = {}
    for name in names:
        group, key = name.rsplit("/", 1)
        viewer = PETSc.ViewerHDF5().create(str(Path(out) / "fields.h5"), "r", comm=PETSc.COMM_SELF)
        viewer.pushGroup(group)
        x = PETSc.Vec().create(PETSc.COMM_SELF)
        x.setName(key)
        x.load(viewer)
        values[name] = x.getArray().copy()
        x.destroy()
        viewer.destroy()
    return values


# ----------------------------------------------------------------------------------------------
# (a) the velocity sweep at the defaults


@pytest.mark.skipif(not SERIAL, reason="CLI runs, serial (2 ranks: test_serial_and_two_ranks_stop_alike)")
@pytest.mark.parametrize("v", [300, 600, 1000, 2000, 5000])
def test_velocity_sweep_ends_cleanly(tmp_path, v):
    out = tmp_path / f"v{v}"
    rc = cli.main(["run", str(TAYLOR), "--out", str(out), "--set", velocity(v), "--set", "output.plots=false"])
    s = json.loads((out / "summary.json").read_text())
    # no non-finite number anywhere: history, summary, final shape, fields
    written = [p for p in out.rglob("*") if p.suffix in (".csv", ".json")]
    assert {"history.csv", "summary.json", "final_shape.csv"} <= {p.name for p in written}
    for p in written:
        assert nonfinite_problems(p) == [], p
    fields = field_values(out)
    if fields is not None:
        assert len(fields) >= 4
        for name, a in fields.items():
            assert a.size and np.isfinite(a).all(), name
    rows = np.genfromtxt(out / "history.csv", delimiter=",", names=True)
    if v == 300:                                      # completes (wall + floor: issue 13)
        assert rc == 0 and s["converged"] is True and "stop_reason" not in s
        assert rows["time_us"][-1] == pytest.approx(80.0)
        return
    assert rc == 1 and s["converged"] is False and s["stop_reason"] == "cell_fold"
    msg = s["error"]
    for part in (f"cell {s['fold_cell']} (the mesh file's cell order) folded in the step to t = ",
                 "The run stops at the last finite state, t = ", "at (r, z) = (", "corner angles",
                 "above analysis.dt_floor = 0.001: a fold is not a collapse of the time step",
                 "analysis.erosion_ratio", "mesh.refine", "boundary type 'wall'", "analysis.dt_safety"):
        assert part in msg, part
    # a fold over many steps (600, 1000 m/s) or within one (2000, 5000: the step is long for the motion)
    one_step = s["fold_cell_min_point_volume_ratio"] - s["fold_cell_next_point_volume_ratio"] > 0.05
    assert one_step == (v >= 2000)
    assert ("follows the crushing further" in msg) == one_step
    assert ("The cell flattened over many steps" in msg) == (not one_step)
    assert 0.0 < s["fold_cell_min_point_volume_ratio"] and s["fold_cell_next_point_volume_ratio"] <= 0.0
    assert s["dt_collapse_ratio"] > 1e-3                 # the floor could not have caught it
    # the outputs, history row and fields at the stop, as at a time-step floor stop
    t = s["stopped_at_us"]
    assert 0.0 < t < {600: 20.0, 1000: 12.0, 2000: 3.0, 5000: 0.5}[v]
    assert rows["time_us"][-1] == pytest.approx(t, rel=1e-12)
    times = re.findall(r'Time Value="([^"]+)"', (out / "fields.xdmf").read_text())
    assert float(times[-1]) == pytest.approx(t, rel=1e-12)
    for k in s["key_results"] + s["info_results"] + ["steps", "dt_min_s", "energy_balance_error"]:
        assert isinstance(s[k], (int, float)) and math.isfinite(s[k]), k


@pytest.mark.skipif(not SERIAL, reason="CLI run, serial")
def test_fold_in_the_first_step(tmp_path):
    """1e6 m/s with the step at the limit (dt_safety = 1) and no floor: the first step folds; the
    run stops at t = 0 (its row and fields written once), exit 1, nothing non-finite."""
    out = tmp_path / "v1e6"
    rc = cli.main(["run", str(TAYLOR), "--out", str(out), "--set", velocity(1e6), "--set", "analysis.dt_safety=1",
                   "--set", "analysis.dt_floor=0", "--set", "output.plots=false"])
    s = json.loads((out / "summary.json").read_text())
    assert rc == 1 and s["stop_reason"] == "cell_fold" and s["stopped_at_us"] == 0.0 and s["steps"] == 0
    assert "folded in the step to t = " in s["error"] and "analysis.dt_safety, now 1" in s["error"]
    assert len(np.atleast_1d(np.genfromtxt(out / "history.csv", delimiter=",", names=True)["time_us"])) == 1
    for p in out.rglob("*"):
        if p.suffix in (".csv", ".json"):
            assert nonfinite_problems(p) == [], p


# ----------------------------------------------------------------------------------------------
# (b) the stop is the last finite state


def _stop(*sets):
    b = build_explicit(load_problem(TAYLOR, ["output.history_points=9", *sets]), COMM)
    with pytest.raises(CellFold) as e:
        b.solver.run(80 * US, rows=9, progress=0)
    return b.solver, e.value


def _state(s):
    q = s.qmap
    return [s.u.x.array, s.v.x.array, s.a, np.asarray(s.f), q.binv, q.eqps, q.tau_values]


def test_fold_stops_at_the_last_finite_state():
    s, e = _stop(velocity(1000))
    state = [a.copy() for a in _state(s)]
    assert all(np.isfinite(a).all() for a in state)
    assert e.stats["steps"] == s.step_count and e.results["stopped_at_us"] == pytest.approx(s.t / US)
    assert s.guard.folded_cells() == -1                       # the state kept has no folded cell
    # bit for bit the state of a run stopped before that step by max_steps (steps grouped otherwise)
    b2 = build_explicit(load_problem(TAYLOR, ["output.history_points=9", velocity(1000)]), COMM)
    b2.solver.run(80 * US, rows=9, progress=0, max_steps=s.step_count)
    assert b2.solver.step_count == s.step_count and b2.solver.t == s.t
    for a, b in zip(state, _state(b2.solver)):
        np.testing.assert_array_equal(a, b)
    # the step from there folds the cell named
    s.step(e.stats["dt_max"])
    assert s.guard.pending_fold is not None and s.step_count == b2.solver.step_count


def test_ufl_route_and_fixed_steps_stop_alike():
    s_f, e_f = _stop(velocity(2000))
    s_u, e_u = _stop(velocity(2000), "analysis.internal_force=ufl")
    assert s_u.internal_force_route == "ufl"
    assert e_u.results["fold_cell"] == e_f.results["fold_cell"] and s_u.step_count == s_f.step_count
    assert all(np.isfinite(a).all() for a in _state(s_u))
    # fixed steps: the remedy names the solver's steps, which the driver words as analysis.time_steps
    b = build_explicit(load_problem(TAYLOR, ["output.history_points=9", velocity(2000)]), COMM)
    with pytest.raises(CellFold) as e:
        b.solver.run(4 * US, steps=600, rows=9, progress=0)
    assert "more steps than 600" in str(e.value)
    assert "more analysis.time_steps than 600" in e.value.worded(SCENE_TERMS)
    assert all(np.isfinite(a).all() for a in _state(b.solver))


@pytest.mark.parametrize("route", ["fused", "ufl"])
def test_nonfinite_stress_stops_at_once(route):
    """A stress that is not finite for another reason than a fold (here a committed state spoilt on
    purpose) stops the run in that step, not at the next check 10 steps on, u and v as before it."""
    b = build_explicit(load_problem(TAYLOR, ["output.history_points=3", f"analysis.internal_force={route}"]), COMM)
    s = b.solver
    s.run(1 * US, rows=3, progress=0)
    n0 = s.step_count
    u0, v0 = s.u.x.array.copy(), s.v.x.array.copy()
    s.qmap.binv[-1] = np.nan
    with pytest.raises(RunError, match=r"went unstable .*step " + str(n0 + 1)) as e:
        s.run(10 * US, rows=3, progress=0)
    assert not isinstance(e.value, CellFold)
    assert s.step_count == n0
    np.testing.assert_array_equal(s.u.x.array, u0)
    np.testing.assert_array_equal(s.v.x.array, v0)


# ----------------------------------------------------------------------------------------------
# (c) the force pass writes nothing for a folding cell


def _point_jacobians(s, cell):
    """J at the quadrature points of ``cell`` (hoop stretch included), from the reference gradients."""
    g = s.geometry
    ue = s.u.x.array.reshape(-1, s.bs)[s.cell_nodes[cell]]
    J = np.linalg.det(np.eye(s.bs) + np.einsum("ai,qaj->qij", ue, g.dNdX[cell]))
    return J if s.three_d else J * (1.0 + g.Rinv[cell] * (g.N @ ue[:, 0]))


@pytest.mark.parametrize("case", ["quadrilaterals", "hexahedra", "ufl"])
def test_force_pass_writes_nothing_for_a_folding_cell(case):
    if case == "hexahedra":
        import explicit_3d_cases
        s = explicit_3d_cases.taylor_3d(COMM, n_r=2, n_z=4)
    else:
        sets = ["analysis.internal_force=ufl"] if case == "ufl" else []
        s = build_explicit(load_problem(TAYLOR, sets), COMM).solver
    s.initialize()
    s.run(2 * US, rows=2, progress=0)                     # a plastic state to keep
    cell = 0 if s.n_cells_own else None
    if cell is not None:                                  # push the last vertex past the opposite one
        nodes = s.cell_nodes[cell]
        a, X = nodes[-1], s.reference_positions[nodes]
        s.u.x.array[a * s.bs:(a + 1) * s.bs] += 1.5 * (X[0] - X[-1])
        assert _point_jacobians(s, cell).min() < 0.0
    s.u.x.scatter_forward()
    before = [x.copy() for x in _state(s)[3:]]
    if case == "ufl":
        assert s.internal_force() == STEP_FOLDS
    else:
        assert fused_force.internal_force(s.force_args) is False or cell is None
        if cell is not None:
            assert fused_force.folded_cell(s.force_args) >= 0
    for x, y in zip(before, _state(s)[3:]):               # f, binv, eqps, tau as they were
        np.testing.assert_array_equal(x, y)


# ----------------------------------------------------------------------------------------------
# (d) the runner's last line


def test_runner_refuses_to_write_a_nonfinite_value():
    nonfinite_guard({"radius_mm": 7.0, "note": "text", "steps": 3}, "x")
    with pytest.raises(RunError, match=r"row at t = 3 us: length_mm, max_eqps not finite, not written"):
        nonfinite_guard({"length_mm": math.nan, "radius_mm": 7.0, "max_eqps": math.inf},
                        "taylor_bar: history row at t = 3 us")
    s = build_explicit(load_problem(TAYLOR, []), COMM).solver
    fields_guard(s, "x")
    s.qmap.eqps[-1] = math.nan
    with pytest.raises(RunError, match="a field value is not finite"):
        fields_guard(s, "x")


# ----------------------------------------------------------------------------------------------
# (e) serial = 2 ranks


def _cli(scene, out, sets, ranks):
    cmd = [sys.executable, "-m", "fenics_plast.cli", "run", str(scene), "--out", str(out)]
    for x in sets:
        cmd += ["--set", x]
    if ranks > 1:
        cmd = [MPIRUN, "--allow-run-as-root", "--oversubscribe", "-n", str(ranks)] + cmd
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_", "OPAL_"))}
    env["FENICS_PLAST_PROGRESS"] = "off"
    p = subprocess.run(cmd, cwd=REPO, env=env, capture_output=True, text=True, timeout=600)
    assert "Traceback" not in p.stderr, p.stderr[-3000:]
    return p.returncode, json.loads((Path(out) / "summary.json").read_text())


@needs_mpirun
@pytest.mark.parametrize("scene, v", [(TAYLOR, 1000), (TAYLOR_WALL, 5000)], ids=["step", "contact"])
def test_serial_and_two_ranks_stop_alike(tmp_path, scene, v):
    """The plain step (1000 m/s) and the general one with contact (taylor_bar_wall, 5000 m/s): the
    same cell, step, time and message on 1 and 2 ranks."""
    sets = [velocity(v), "output.plots=false", "output.xdmf=false"]
    rc1, s1 = _cli(scene, tmp_path / "serial", sets, 1)
    rc2, s2 = _cli(scene, tmp_path / "mpi", sets, 2)
    assert rc1 == rc2 == 1 and s1["stop_reason"] == s2["stop_reason"] == "cell_fold"
    assert s2["mpi_ranks"] == 2
    assert s1["fold_cell"] == s2["fold_cell"] and s1["steps"] == s2["steps"]
    assert s1["stopped_at_us"] == pytest.approx(s2["stopped_at_us"], rel=1e-12)
    assert s1["radius_mm"] == pytest.approx(s2["radius_mm"], rel=1e-9)
    assert s1["error"].split(" would go from")[0] == s2["error"].split(" would go from")[0]
