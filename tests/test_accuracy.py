"""Accuracy on demand (fenics_plast.accuracy, ``run --accuracy``).

(a) The estimate on closed forms: f(h) = f_ext + A h^p through three or more levels gives p and f_ext
back, a bar that brackets the error, the mesh size whose bar meets a tolerance; an order above the
theoretical one gives the bar at that order; an oscillating or slowly converging ladder is refused or
given the range rule; a probe's bound on a first-order source, and its own ladder where measured.
(b) The plan: the tolerance split where the run costs least, factors rounded to whole cell counts, an
explicit run's time step inside the mesh's error.
(c) The axes of the shipped scenes, read from the schema's declarations.
(d) The command on the thick cylinder (static, fast): met, the reaction within its bar of a finer run
and near Hill's closed form, runs reused when asked again, a final run over the time budget refused,
bad input refused (exit 2, nothing written), serial = 2 ranks; a post-neck force refused with the
table; the Taylor bar against Foulk et al.'s converged radius (slow).
"""
import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from fenics_plast.accuracy import (THEORETICAL_ORDER, AccuracyError, ProbeEstimate, mesh_estimate,
                                   parse_tolerance, probe_estimate)
from fenics_plast.accuracy.axes import scene_axes
from fenics_plast.accuracy.ladder import ladder_settings
from fenics_plast.accuracy.plan import Need, bar_parts, final_factors, need, predicted_cost, round_up
from fenics_plast.accuracy.estimate import SAFETY
from fenics_plast.problem import load_problem
from scene_runs import needs_mpirun

REPO = Path(__file__).resolve().parents[1]


# ----------------------------------------------------------------------------------------------
# (a) the estimate


@pytest.mark.parametrize("p", [0.8, 1.0, 1.7, 2.0])
def test_three_levels_give_the_order_and_the_limit_back(p):
    h = [1.0, 0.75, 0.5]
    f = [7.0 - 0.2 * x ** p for x in h]
    e = mesh_estimate(h, f)
    assert e.kind == "monotone" and abs(e.order - p) < 1e-9 and abs(e.value - 7.0) < 1e-12
    # the bar at the finest level is SAFETY x its true error (the model is exact here)
    assert abs(e.bar - SAFETY * 0.2 * 0.5 ** p) < 1e-12
    # the size whose bar is 1e-3: its true error is 1e-3 / SAFETY
    hs = e.size_for(1e-3)
    assert abs(0.2 * hs ** p - 1e-3 / SAFETY) < 1e-12


def test_more_levels_fit_by_least_squares_with_the_scatter_in_the_bar():
    """Four levels of f_ext + A h^p plus a small alternating disturbance: the order within 0.05, the
    limit within the bar, and the fit's standard deviation added to the bar."""
    h = [1.0, 0.75, 0.5, 0.375]
    f = [3.0 + 0.1 * x ** 1.2 + d for x, d in zip(h, (1e-4, -1e-4, 1e-4, -1e-4))]
    e = mesh_estimate(h, f)
    assert e.kind == "monotone" and abs(e.order - 1.2) < 0.05, e
    assert e.sigma > 0 and abs(f[-1] - 3.0) <= e.bar_at(h[-1])
    exact = mesh_estimate(h, [3.0 + 0.1 * x ** 1.2 for x in h])
    assert abs(exact.order - 1.2) < 1e-4 and exact.sigma < 1e-9


def test_an_order_above_the_theoretical_one_takes_the_bar_at_it():
    """p = 6 observed on a smooth problem: the bar uses order 2 through the two finest levels; p = 1.7 on a
    plastic one (first order): the bar at order 1, larger than the true error in both."""
    h = [1.0, 0.75, 0.5]
    f = [1.0 + 0.1 * x ** 6 for x in h]
    e = mesh_estimate(h, f)
    assert e.order > 5.9 and e.used_order == 2.0 and e.bar > 0.1 * 0.5 ** 6 * SAFETY
    f = [1.0 + 0.1 * x ** 1.7 for x in h]
    e = mesh_estimate(h, f, order_cap=THEORETICAL_ORDER["plastic or contact"])
    assert abs(e.order - 1.7) < 1e-9 and e.used_order == 1.0
    d2 = f[1] - f[2]
    assert abs(e.bar - SAFETY * d2 / (0.75 - 0.5) * 0.5) < 1e-12 and e.bar > SAFETY * 0.1 * 0.5 ** 1.7


def test_oscillating_ladder_gets_three_times_its_range():
    e = mesh_estimate([1.0, 0.75, 0.5], [10.0, 10.02, 10.01])
    assert e.kind == "oscillating" and abs(e.bar - 0.06) < 1e-12
    assert e.size_for(0.1) == 1.0 and e.size_for(0.05) is None


def test_slow_or_diverging_ladders_are_refused():
    assert mesh_estimate([1.0, 0.75, 0.5], [1.0, 1.1, 1.3]).kind == "refused"        # no order fits
    slow = mesh_estimate([1.0, 0.75, 0.5], [1.0, 1.1, 1.235])                         # p ~ 0.1
    assert slow.kind == "refused" and "asymptotic" in slow.note
    assert mesh_estimate([1.0, 0.75, 0.5], [1.0, float("nan"), 1.2]).kind == "refused"


def test_a_probe_bounds_a_first_order_error():
    """f(tau) = f0 + B tau: the probe at tau/2 bounds the error at tau exactly (order 1), and a factor s
    divides it by s; probes at 1, 2, 4 of f0 + B tau^1.5 measure the order (capped at 1 for the bar) and
    hold from their coarsest level on; a measured ratio of 1.5 (adaptive increments) is taken as such."""
    p = probe_estimate("time", [1.0, 2.0], [5.0 + 0.3, 5.0 + 0.15])
    assert abs(p.bound - 0.3) < 1e-12 and abs(p.bound_at(3.0) - 0.1) < 1e-12
    assert abs(p.factor_for(0.05) - 6.0) < 1e-12 and p.factor_for(1.0) == 1.0
    pen = probe_estimate("contact", [1.0, 4.0], [2.0 + 0.08, 2.0 + 0.02])      # u = p / penalty: order 1
    assert abs(pen.bound - 0.08) < 1e-12
    assert abs(probe_estimate("time", [1.0, 1.5], [1.3, 1.2]).bound - 0.3) < 1e-12
    f = [5.0 + 0.3 * t ** 1.5 for t in (1.0, 0.5, 0.25, 0.125)]
    p = probe_estimate("time", [1.0, 2.0, 4.0, 8.0], f)
    assert p.min_factor == 2.0 and abs(p.ladder.order - 1.5) < 1e-9 and p.ladder.used_order == 1.0
    assert p.bound_at(8.0) >= 0.3 * 0.125 ** 1.5 and p.factor_for(1e-3) > 8.0
    assert probe_estimate("time", [1, 2, 4], [1.0, 1.1, 1.2]).factor_for(1e-3) == math.inf   # no order fits


def test_tolerances_parse_and_refuse():
    t = parse_tolerance("radius_mm=0.5%")
    assert t.key == "radius_mm" and t.relative and abs(t.value - 0.005) < 1e-15
    assert abs(t.absolute(-8.0) - 0.04) < 1e-15
    t = parse_tolerance("radius_mm=0.02")
    assert not t.relative and t.absolute(100.0) == 0.02
    assert parse_tolerance("1%").key is None
    for bad in ("radius_mm=", "radius_mm=-1%", "radius_mm=0", "radius_mm=abc", "0.02", "x=100%", "x=nan"):
        with pytest.raises(AccuracyError):
            parse_tolerance(bad)


# ----------------------------------------------------------------------------------------------
# (b) the plan


def test_need_splits_the_tolerance_where_the_run_costs_least():
    """Static, mesh bar 2.5 h (first order) and a time probe bounding 0.3 at the scene's increments,
    tolerance 1: the split of TARGET between them is the one of SHARES whose run costs least (mesh
    factor^3 x time factor), and the two parts add up to TARGET. Explicit: the time step is neither
    refined nor added."""
    from fenics_plast.accuracy.plan import SHARES, TARGET
    mesh = mesh_estimate([1.0, 0.75, 0.5], [10.0 - 2.0 * x for x in (1.0, 0.75, 0.5)],
                         order_cap=THEORETICAL_ORDER["plastic or contact"])
    probe = ProbeEstimate("time", 2.0, 0.15, 1.0)

    def cost(share):                              # closed form of the split: time factor 0.3/share
        f_t = max(1.0, 0.3 / share)
        return (SAFETY * 2.0 / (TARGET - 0.3 / f_t)) ** 3 * f_t
    best = min(SHARES, key=cost)
    n = need(1.0, mesh, {"time": probe}, explicit=False, cost_exponent=3.0)
    assert abs(n.factors["time"] - max(1.0, 0.3 / best)) < 1e-12, (n.factors, best)
    assert abs(SAFETY * 2.0 / n.factors["mesh"] + 0.3 / n.factors["time"] - TARGET) < 1e-12
    n = need(1.0, mesh, {"time": probe}, explicit=True)
    assert "time" not in n.factors and abs(SAFETY * 2.0 / n.factors["mesh"] - TARGET) < 1e-12
    total, parts = bar_parts(0.1, {"time": probe}, {"mesh": 2.0}, explicit=True, h=0.5)
    assert total == 0.1 and abs(parts["time_in_mesh"] - 0.15) < 1e-12
    total, parts = bar_parts(0.1, {"time": probe}, {"mesh": 2.0, "time": 3.0}, explicit=False, h=0.5)
    assert abs(total - 0.2) < 1e-12


def test_final_factors_round_up_to_whole_cells():
    def exact(f, up=False):                    # 6 cells: multiples of 1/6
        return (math.ceil(6 * f - 1e-9) if up else round(6 * f)) / 6
    out = final_factors([Need({"mesh": 2.1, "time": 1.02}), Need({"mesh": 1.5, "contact": 2.37})], 2.0, exact)
    assert out == {"mesh": 13 / 6, "time": 1.0, "contact": 2.4}
    assert final_factors([Need({"mesh": 1.2})], 2.0, exact) == {"mesh": 2.0}
    assert round_up(2.27) == 2.3 and round_up(0.0123) == 0.013


def test_predicted_cost_follows_the_measured_exponent():
    wall, k = predicted_cost((2.0, 16.0), (1.0, 2.0), 4.0, 1.0)
    assert abs(k - 3.0) < 1e-12 and abs(wall - 128.0) < 1e-9


# ----------------------------------------------------------------------------------------------
# (c) the axes of shipped scenes


def test_axes_of_shipped_scenes():
    """The Taylor bar: mesh (6 radial cells: the ladder at 1, 4/3, 2) and its explicit step; the punch:
    its steps' increments and its set penalties; the thick cylinder: increments and max_increment."""
    taylor = scene_axes(load_problem(REPO / "demos" / "taylor_bar.toml"))
    assert set(taylor) == {"mesh", "time"} and taylor["time"].overrides(2.0) == ["analysis.dt_safety=0.4"]
    levels, probes = ladder_settings(taylor)
    assert [s.factor("mesh") for s in levels] == [1.0, 8 / 6, 2.0] and set(probes) == {"time"}
    punch = scene_axes(load_problem(REPO / "demos" / "punch_stretching.toml"))
    assert set(punch) == {"mesh", "time", "contact"}
    assert sorted(punch["contact"].overrides(4.0)) == ["contact.die.penalty=82800", "contact.punch.penalty=82800"]
    assert "steps.to_20mm.increments=40" in punch["time"].overrides(2.0)
    assert [s.factor("mesh") for s in ladder_settings(punch)[0]] == [1.0, 1.5, 2.0]
    cyl = scene_axes(load_problem(REPO / "demos" / "thick_cylinder.toml"))
    assert cyl["time"].overrides(2.0) == ["analysis.increments=40", "analysis.max_increment=0.05"]
    assert cyl["mesh"].overrides(1.375) == ["mesh.refine=1.375"]


# ----------------------------------------------------------------------------------------------
# (d) the command


def run_cli(*args, cwd=REPO):
    return subprocess.run([sys.executable, "-m", "fenics_plast.cli", "run", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True)


def hill_reaction(summary):
    """The reaction on the quarter bore of a fully plastic incompressible cylinder (Hill 1950) in the
    current radii: p a with p = (2 / sqrt 3) sigma_y ln(b / a), b^2 = a^2 + b0^2 - a0^2 [N per mm]. It
    leaves out the elastic strains (sigma_y / E = 1.25e-3; the annulus's elastic change of area moves
    ln(b / a) by a few 1e-4)."""
    a = 10.0 + summary["inner_displacement_mm"]
    b = math.sqrt(a * a + 20.0 ** 2 - 10.0 ** 2)
    return 2.0 / math.sqrt(3.0) * 250.0 * math.log(b / a) * a


def test_thick_cylinder_accuracy_met_bracketed_and_reused(tmp_path):
    """0.1 % on the bore's reaction: the ladder (3 meshes and the time probe) and the final run; the
    reaction within its bar of a run twice finer in space and four times in time (refine 4, 80
    increments), and within 5e-4 of Hill's closed form; asked again at 0.05 %, the ladder's runs are
    reused."""
    out = tmp_path / "acc"
    r = run_cli(REPO / "demos" / "thick_cylinder.toml", "--accuracy", "inner_rx_N=0.1%", "--out", out)
    assert r.returncode == 0, r.stdout + r.stderr
    acc = json.loads((out / "accuracy.json").read_text())
    res = acc["results"]["inner_rx_N"]
    fine = tmp_path / "fine"
    r = run_cli(REPO / "demos" / "thick_cylinder.toml", "--out", fine, "--set", "mesh.refine=4", "--set",
                "analysis.increments=80", "--set", "analysis.max_increment=0.025", "--set", "output.xdmf=false",
                "--set", "output.plots=false")
    assert r.returncode == 0, r.stderr
    reference = json.loads((fine / "summary.json").read_text())
    hill = hill_reaction(reference)
    print(f"\nthick cylinder: {res['value']:.3f} +- {res['error_bar']:.3f} N (tolerance {res['tolerance_abs']:.3f}), "
          f"fine run {reference['inner_rx_N']:.3f} N, Hill {hill:.3f} N, final run {acc['final_run']}, ladder "
          f"{acc['ladder_s']:.1f} s")
    assert res["met"] and abs(res["value"] - reference["inner_rx_N"]) <= res["error_bar"]
    assert abs(res["value"] / hill - 1) < 5e-4 and abs(reference["inner_rx_N"] / hill - 1) < 5e-4
    assert set(acc["ladder_runs"]) == {"mesh-1", "mesh-1.375", "mesh-2", "mesh-1_time-2"}
    assert "inner_rx_N" in (out / "accuracy.md").read_text()
    r = run_cli(REPO / "demos" / "thick_cylinder.toml", "--accuracy", "inner_rx_N=0.05%", "--out", out)
    assert r.returncode == 0, r.stdout + r.stderr
    again = json.loads((out / "accuracy.json").read_text())
    assert all(again["runs"][n]["reused"] for n in acc["ladder_runs"]), again["runs"]
    assert again["results"]["inner_rx_N"]["error_bar"] <= 0.0005 * abs(again["results"]["inner_rx_N"]["value"])
    # a final run predicted beyond the time budget is not started: refused, exit 1, the finest ladder
    # run's value and bar reported
    r = run_cli(REPO / "demos" / "thick_cylinder.toml", "--accuracy", "inner_rx_N=0.001%", "--time-budget",
                "0.01", "--out", out)
    assert r.returncode == 1 and "predicted to take about" in r.stdout and "--time-budget 0.01 s" in r.stdout, r.stdout
    budget = json.loads((out / "accuracy.json").read_text())
    assert budget["status"] == "refused" and budget["results"]["inner_rx_N"]["value"] == res["value"]
    assert budget["final_runs"] == []


@pytest.mark.parametrize("args, words", [
    (["--accuracy", "nonsense_kN=1%"], "no such result"),
    (["--accuracy", "inner_rx_N=-1%"], "must be > 0"),
    (["--accuracy", "1%", "--resume", "x"], "--resume does not go with --accuracy"),
    (["--time-budget", "10"], "--time-budget goes with --accuracy"),
])
def test_bad_accuracy_arguments_exit_2_and_write_nothing(tmp_path, args, words):
    out = tmp_path / "acc"
    r = run_cli(REPO / "demos" / "thick_cylinder.toml", *args, "--out", out)
    assert r.returncode == 2 and words in r.stderr, r.stderr
    assert not out.exists()


def test_a_mesh_without_cell_counts_has_no_mesh_axis(tmp_path):
    """A scene whose mesh.refine refines nothing (no cell count among its [mesh.parameters]) is refused
    before any run (AccuracyError: exit 2), and nothing is written."""
    from fenics_plast.accuracy import run_accuracy
    from fenics_plast.quantities.registry import study_keys
    scene = (REPO / "tests" / "scenes" / "bar.toml").read_text()
    text = "\n".join(line for line in scene.splitlines() if not line.strip().startswith("cells"))
    path = tmp_path / "bar.toml"
    path.write_text(text.replace('"../../meshes/', f'"{REPO}/meshes/'))
    key = study_keys(load_problem(path).outputs)["info_results"][0]
    with pytest.raises(AccuracyError, match="mesh.refine"):
        run_accuracy(path, [parse_tolerance(f"{key}=1%")], tmp_path / "a", log=lambda m: None)
    assert not (tmp_path / "a").exists()


def test_post_neck_force_is_refused_with_the_table(tmp_path):
    """The necking bar's force at the end (past the neck) falls by 11 % from each mesh to the next:
    no order fits it, so no bar is given: exit 1, the refusal and what to do in the printed lines and
    accuracy.md, each ladder run's value shown (about 20 s)."""
    out = tmp_path / "acc"
    r = run_cli(REPO / "demos" / "bar_tension.toml", "--accuracy", "force_kN=0.5%", "--out", out)
    assert r.returncode == 1, r.stdout + r.stderr
    text = r.stdout + r.stderr
    assert "accuracy refused" in text and "not in the asymptotic range" in text and "what to do" in text
    assert "does not converge with the mesh" in text and "mesh-1.4: force_kN" in text
    acc = json.loads((out / "accuracy.json").read_text())
    assert acc["status"] == "refused" and acc["results"] == {}
    values = [acc["runs"][n]["results"]["force_kN"] for n in ("mesh-1", "mesh-1.4", "mesh-2")]
    assert values[0] > values[1] > values[2] and values[2] < 0.9 * values[0], values
    assert "**Refused**" in (out / "accuracy.md").read_text()


@pytest.mark.slow
def test_taylor_bar_radius_within_one_percent_of_the_converged_answer(tmp_path):
    """The Taylor bar at 1 % on the radius (explicit: the time step inside the mesh's error): the final
    run's radius within its bar of Foulk et al.'s converged 7.2259 mm and within 1 % of it; the ladder
    and the final together under 2.5 times the final alone (about 50 s)."""
    out = tmp_path / "acc"
    r = run_cli(REPO / "demos" / "taylor_bar.toml", "--accuracy", "radius_mm=1%", "--out", out)
    assert r.returncode == 0, r.stdout + r.stderr
    acc = json.loads((out / "accuracy.json").read_text())
    res = acc["results"]["radius_mm"]
    print(f"\nTaylor radius {res['value']:.5f} +- {res['error_bar']:.4f} mm, run {acc['final_run']}, cost ratio "
          f"{acc['cost_ratio']:.2f}")
    assert abs(res["value"] - 7.2259) <= res["error_bar"] and abs(res["value"] / 7.2259 - 1) < 0.01
    assert "time_in_mesh" in res["parts"] and acc["cost_ratio"] < 2.5


@needs_mpirun
def test_two_ranks_give_the_serial_values_and_bars(tmp_path):
    """--np 2: every run of the ladder on two ranks; the value and the bar of the bore's reaction as the
    serial request's to 1e-6 (the runs agree to the Newton tolerance)."""
    values = {}
    for np_ranks in (1, 2):
        out = tmp_path / f"np{np_ranks}"
        r = run_cli(REPO / "demos" / "thick_cylinder.toml", "--accuracy", "inner_rx_N=1%", "--np", np_ranks,
                    "--out", out)
        assert r.returncode == 0, r.stdout + r.stderr
        res = json.loads((out / "accuracy.json").read_text())["results"]["inner_rx_N"]
        values[np_ranks] = (res["value"], res["error_bar"])
    (v1, b1), (v2, b2) = values[1], values[2]
    assert abs(v2 / v1 - 1) < 1e-6 and abs(b2 / b1 - 1) < 1e-6, values
