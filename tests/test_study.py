"""Parameter studies (fenics_plast.study, ``fenics-plast study``).

(a) The Richardson extrapolation recovers the exact order and limit of manufactured sequences
(constant and varying refinement ratio) and refuses non-monotone ones; (b) the references of a
study: finest run, Richardson, fallback, first run; the ordered keys (fnmatch patterns); the key results, info columns and published references come from the runs'
summary.json, and the published ones are left out when a non-discretisation key is varied or set;
(c) a real, short Taylor study through the CLI: study.csv/md/png exist, the numbers in study.csv
are the runs' summary.json values, the finest run's error is 0 and the others' errors are
(value - ref)/|ref|, an invalid value and a time step above the stable limit are rows with their
reasons; --reuse reruns nothing; (d) a subprocess that exits 2 becomes an "invalid" row; bad study
arguments exit 2; ``python -m fenics_plast.study`` runs.
"""
import csv
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from fenics_plast import study as st

REPO = Path(__file__).resolve().parent.parent
TAYLOR = REPO / "demos" / "taylor_bar.toml"
SERIAL = int(os.environ.get("OMPI_COMM_WORLD_SIZE", "1")) == 1
needs_serial = pytest.mark.skipif(not SERIAL, reason="starts its own processes")
#: What demos/taylor_bar.toml declares in summary.json (key_results, info_results).
TAYLOR_KEYS = ["length_mm", "radius_mm", "max_eqps"]
TAYLOR_INFO = ["kinetic_energy_J", "max_kinetic_energy_J", "elastic_energy_J", "max_elastic_energy_J",
               "plastic_dissipation_J", "max_plastic_dissipation_J", "external_work_J", "max_external_work_J",
               "energy_balance_error", "max_energy_balance_error", "wall_energy_J"]
#: the Taylor bar to 5 us
SHORT = ["analysis.end_time=5", "output.history_points=3"]


# -- (a) Richardson -----------------------------------------------------------------------------

@pytest.mark.parametrize("refine, p", [((1, 2, 4), 1.7), ((1, 2, 4), 2.0), ((2, 3, 5), 1.3), ((1, 3, 4), 0.8)])
def test_richardson_manufactured(refine, p):
    """f(h) = 2.5 - 3 h^p with h = 1/refine: the observed order is p and the limit is 2.5."""
    h = [1.0 / r for r in refine]
    f = [2.5 - 3.0 * x ** p for x in h]
    res = st.richardson(h, f)
    assert res.ok
    assert res.order == pytest.approx(p, rel=1e-9)
    assert res.value == pytest.approx(2.5, rel=1e-9)


def test_richardson_refuses_non_monotone_and_out_of_range():
    h = [1.0, 0.5, 0.25]
    res = st.richardson(h, [1.0, 1.2, 1.1])          # up then down
    assert not res.ok and "not monotone" in res.note
    res = st.richardson(h, [1.0, 1.5, 1.5])          # two finest identical
    assert not res.ok and "round-off" in res.note
    res = st.richardson(h, [1.0, 1.5, 1.50001])      # p = ln(5e4)/ln 2 = 15.6: outside [0.3, 8]
    assert not res.ok and res.order == pytest.approx(math.log(0.5 / 1e-5, 2), rel=1e-9)
    with pytest.raises(ValueError):
        st.richardson([0.5, 1.0, 0.25], [1, 2, 3])


# -- (b) references on synthetic runs -------------------------------------------------------------

def _runs(varies, values, key="x"):
    """Fake successful runs of ``varies`` with summary[key] = values[i] (None: a failed run)."""
    runs = []
    for i, combo in enumerate(st.combinations(varies)):
        r = st.Run(name=st.run_name(i, combo, varies), label=st.run_label(combo, varies), settings=combo)
        if values[i] is None:
            r.status, r.reason = "failed", "boom"
        else:
            r.status, r.summary = "ok", {key: values[i], "wall_time_s": float(i + 1)}
        runs.append(r)
    return runs


def test_references_richardson_and_groups():
    varies = [st.parse_vary("materials.copper.model=seed,isochoric"), st.parse_vary("mesh.refine=1,2,4")]
    f = lambda c, r: c - 0.4 * (1.0 / r) ** 2          # noqa: E731  order 2, limit c
    vals = [f(7.0, 1), f(7.0, 2), f(7.0, 4), f(7.2, 1), f(7.2, 2), f(7.2, 4)]
    runs = _runs(varies, vals)
    refs = st.references(runs, varies, ["x"])
    assert [ref.group for ref in refs] == [(("materials.copper.model", "seed"),),
                                           (("materials.copper.model", "isochoric"),)]
    for ref, limit in zip(refs, (7.0, 7.2)):
        assert ref.values["x"] == pytest.approx(limit, rel=1e-12)
        assert ref.orders["x"] == pytest.approx(2.0, rel=1e-9)
        assert "Richardson" in ref.kind["x"]
    # the error of refine = 1 (seed) against the extrapolation: -0.4 / 7
    assert st.relative_error(runs[0].summary["x"], refs[0].values["x"]) == pytest.approx(-0.4 / 7.0, rel=1e-9)


def test_references_fallbacks():
    varies = [st.parse_vary("mesh.refine=1,2,3")]
    refs = st.references(_runs(varies, [1.0, 1.2, 1.1]), varies, ["x"])     # not monotone
    assert refs[0].values["x"] == 1.1 and refs[0].orders["x"] is None
    assert any("not monotone" in n for n in refs[0].notes)
    refs = st.references(_runs(varies, [1.0, 1.2, None]), varies, ["x"])    # finest failed
    assert refs[0].values["x"] == 1.2 and refs[0].run.name == "02_refine-2"
    assert any("failed" in n for n in refs[0].notes)
    # max_increment: smaller is finer
    varies = [st.parse_vary("analysis.max_increment=0.1,0.025,0.05")]
    refs = st.references(_runs(varies, [3.0, 1.0, 2.0]), varies, ["x"])
    assert refs[0].values["x"] == 1.0 and refs[0].run.settings["analysis.max_increment"] == "0.025"
    # no ordered key: the first successful run
    varies = [st.parse_vary("contact.punch.law=coulomb,quasi-coulomb")]
    refs = st.references(_runs(varies, [None, 5.0]), varies, ["x"])
    assert refs[0].values["x"] == 5.0 and "first run" in refs[0].kind["x"]


def test_cheapest_within():
    """f = 1.0, 1.1, 1.11 at refine 1, 2, 4 (wall times 1, 2, 3 s): Richardson gives p = log2(10) and
    the limit 1.11 + 0.01/9; the errors are -10 %, -1 %, -0.1 %."""
    varies = [st.parse_vary("mesh.refine=1,2,4")]
    runs = _runs(varies, [1.0, 1.1, 1.11])
    study = st.Study(scene=TAYLOR, scene_name="x", varies=varies, sets=[], keys=["x"], info=[],
                     out=Path("."), runs=runs)
    study.refs = st.references(runs, varies, ["x"])
    assert study.refs[0].values["x"] == pytest.approx(1.11 + 0.01 / 9, rel=1e-12)
    assert study.refs[0].orders["x"] == pytest.approx(math.log2(10), rel=1e-12)
    assert st.cheapest_within(study, "x", 0.2) is runs[0]
    assert st.cheapest_within(study, "x", 0.02) is runs[1]
    assert st.cheapest_within(study, "x", 0.005) is runs[2]
    assert st.cheapest_within(study, "x", 1e-4) is None


def test_ordered_keys():
    """Discretisation keys of the scene format (fnmatch patterns); the keys of the removed per-kind
    format (mesh.cells_radial, solver.*) are no longer ordered."""
    finer_if_larger = ["mesh.refine", "mesh.parameters.cells_radial", "mesh.parameters.cells", "analysis.time_steps",
                       "analysis.increments", "steps.load.increments", "contact.punch.penalty",
                       "contact.punch.tangential_penalty"]
    finer_if_smaller = ["analysis.dt_safety", "analysis.max_increment", "steps.unload.max_increment",
                        "analysis.min_increment", "analysis.rtol", "analysis.atol"]
    assert all(st.order_sign(k) == +1 for k in finer_if_larger)
    assert all(st.order_sign(k) == -1 for k in finer_if_smaller)
    for k in ("initial_velocity.bar.value", "materials.copper.model", "contact.punch.law", "contact.punch.friction",
              "mesh.parameters.radius", "steps.load.end", "mesh.cells_radial", "solver.dt_safety"):
        assert st.order_sign(k) is None, k
    varies = [st.parse_vary("analysis.dt_safety=1.0,0.5,0.8")]
    refs = st.references(_runs(varies, [3.0, 1.0, 2.0]), varies, ["x"])
    assert refs[0].values["x"] == 1.0 and refs[0].run.settings["analysis.dt_safety"] == "0.5"


def _fake_execute(run, scene, sets, run_dir, **kwargs):
    """Stand-in for a run process: a summary that declares its outputs (refine r: R = 7.2 - 0.4/r^2)."""
    settings = dict(s.split("=", 1) for s in sets)
    r = float(settings.get("mesh.refine", 1))
    run.status = "ok"
    run.summary = {"final_radius_mm": 7.2 - 0.4 / r ** 2, "max_eqps": 3.0 + 0.1 * r, "dt_s": 1e-8,
                   "energy_balance_error": 1e-5, "wall_time_s": r, "cells": int(216 * r * r),
                   "key_results": ["final_radius_mm", "max_eqps"], "info_results": ["dt_s", "max_eqps"],
                   "references": {"final_radius_mm": {"value": 7.11, "source": "seed paper, Table 3"},
                                  "not_a_key": {"value": 1.0, "source": "x"}}}
    return run


def test_declared_outputs_and_published_references(tmp_path, monkeypatch):
    """Key results, info columns and published references come from the runs' summary.json; the
    published ones are compared with only when the study changes discretisation keys alone."""
    monkeypatch.setattr("fenics_plast.study.driver.execute", _fake_execute)
    quiet = dict(log=lambda m: None)
    s = st.run_study(TAYLOR, [st.parse_vary("mesh.refine=1,2,4")], tmp_path / "a", ["analysis.dt_safety=0.5"], **quiet)
    assert s.keys == ["final_radius_mm", "max_eqps"] and s.info == ["dt_s"]
    assert s.paper == {"final_radius_mm": 7.11} and s.paper_sources == {"final_radius_mm": "seed paper, Table 3"}
    rows = _read_csv(tmp_path / "a" / "study.csv")
    assert float(rows[0]["err_paper_final_radius_mm"]) == pytest.approx((6.8 - 7.11) / 7.11, rel=1e-12)
    assert "err_paper_max_eqps" not in rows[0] and "err_paper_not_a_key" not in rows[0]
    assert float(rows[2]["ref_final_radius_mm"]) == pytest.approx(7.2, rel=1e-12)     # Richardson, p = 2
    md = (tmp_path / "a" / "study.md").read_text()
    assert "## Against the published references" in md and "`final_radius_mm` = 7.11: seed paper, Table 3" in md
    # a physical key varied or set: the published problem is not the one run
    for varies, sets, key in (([st.parse_vary("mesh.refine=1,2"),
                                st.parse_vary("initial_velocity.bar.value=[0.0, -200.0],[0.0, -227.0]")], [],
                               "initial_velocity.bar.value"),
                              ([st.parse_vary("mesh.refine=1,2")], ["analysis.end_time=5"], "analysis.end_time")):
        out = tmp_path / f"b{len(sets)}"
        s = st.run_study(TAYLOR, varies, out, sets, **quiet)
        assert s.paper == {} and key in s.paper_note
        assert not any(c.startswith("err_paper_") for c in _read_csv(out / "study.csv")[0])
        md = (out / "study.md").read_text()
        assert "Published references (`final_radius_mm`) not compared" in md and "## Against" not in md
    # a mesh's grading and the stable-step estimate are discretisation keys too (they order nothing)
    s = st.run_study(TAYLOR, [st.parse_vary("mesh.parameters.axial_grading=1,1.05")], tmp_path / "d",
                     ["analysis.stable_step=element"], **quiet)
    assert s.paper == {"final_radius_mm": 7.11} and not s.paper_note
    assert st.non_discretisation_keys([st.parse_vary("mesh.parameters.radial_size_ratio=1,4")],
                                      ["analysis.stable_step=size", "mesh.parameters.radius=3"]) == ["mesh.parameters.radius"]
    # --results overrides the declared key results
    s = st.run_study(TAYLOR, [st.parse_vary("mesh.refine=1,2")], tmp_path / "c", results=["cells"], **quiet)
    assert s.keys == ["cells"] and s.info == ["dt_s", "max_eqps"] and s.paper == {}


def test_no_declared_key_results(tmp_path, monkeypatch):
    """Runs that declare nothing: a table without key results and a hint, not a failure."""
    def bare(run, *args, **kwargs):
        run.status, run.summary = "ok", {"final_radius_mm": 7.0, "wall_time_s": 1.0}
        return run
    monkeypatch.setattr("fenics_plast.study.driver.execute", bare)
    said = []
    s = st.run_study(TAYLOR, [st.parse_vary("mesh.refine=1,2")], tmp_path, log=said.append)
    assert s.keys == [] and s.info == [] and all(r.ok for r in s.runs)
    assert any("--results" in m for m in said)
    assert "--results k1,k2" in (tmp_path / "study.md").read_text()
    assert _read_csv(tmp_path / "study.csv")[0]["status"] == "ok"


def test_parse_vary():
    v = st.parse_vary("mesh.refine = 1, 2,4")
    assert (v.key, v.values) == ("mesh.refine", ["1", "2", "4"])
    assert st.parse_vary("material.hardening.strain=[0, 0.1],[0, 0.2]").values == ["[0, 0.1]", "[0, 0.2]"]
    for bad in ("mesh.refine", "refine=1,2", "mesh.refine=1,,2", "mesh.refine=1,1"):
        with pytest.raises(st.StudyError):
            st.parse_vary(bad)


# -- (c) a real study ---------------------------------------------------------------------------------

def _read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@needs_serial
def test_short_taylor_study(tmp_path):
    """Taylor bar to 5 us: refine 0 (invalid), 1, 2 x a fixed step count of 1 (above the stable limit)
    and 200. Four processes, about 15 s."""
    out = tmp_path / "study"
    args = ["study", str(TAYLOR), "--vary", "mesh.refine=0,1,2", "--vary", "analysis.time_steps=1,200",
            "--set", SHORT[0], "--set", SHORT[1], "--out", str(out)]
    r = subprocess.run([sys.executable, "-m", "fenics_plast.cli", *args], capture_output=True, text=True,
                       cwd=REPO, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    for name in ("study.csv", "study.md", "study.png"):
        assert (out / name).stat().st_size > 0
    rows = _read_csv(out / "study.csv")
    assert [row["run"] for row in rows] == ["01_refine-0_time_steps-1", "02_refine-0_time_steps-200",
                                            "03_refine-1_time_steps-1", "04_refine-1_time_steps-200",
                                            "05_refine-2_time_steps-1", "06_refine-2_time_steps-200"]
    by = {row["run"]: row for row in rows}
    # invalid value: the validator's message, no run directory
    for name in ("01_refine-0_time_steps-1", "02_refine-0_time_steps-200"):
        assert by[name]["status"] == "invalid"
        assert "mesh.refine" in by[name]["reason"] and "refine > 0" in by[name]["reason"]
        assert not (out / "runs" / name).exists()
    # step above the stable limit: refused by the run before it writes anything (exit 2, issue 21)
    for name in ("03_refine-1_time_steps-1", "05_refine-2_time_steps-1"):
        assert by[name]["status"] == "invalid"
        assert "analysis.time_steps = 1" in by[name]["reason"] and "exceeds the stable limit" in by[name]["reason"]
        assert not (out / "runs" / name / "summary.json").exists()
        assert by[name]["err_radius_mm"] == ""
    # the successful runs: every number is the summary's
    keys = TAYLOR_KEYS
    for name in ("04_refine-1_time_steps-200", "06_refine-2_time_steps-200"):
        row = by[name]
        assert row["status"] == "ok" and row["reason"] == ""
        summary = json.loads((out / "runs" / name / "summary.json").read_text())
        for c in ["wall_time_s", "cells", "dofs", "steps", "mpi_ranks"] + keys + TAYLOR_INFO:
            assert float(row[c]) == summary[c], c
        assert summary["overrides"][-2:] == [f"mesh.refine={row['mesh.refine']}", "analysis.time_steps=200"]
        assert summary["steps"] == 200
        assert summary["key_results"] == keys and summary["info_results"] == TAYLOR_INFO
    fine, coarse = by["06_refine-2_time_steps-200"], by["04_refine-1_time_steps-200"]
    assert int(fine["cells"]) == 4 * int(coarse["cells"]) == 864
    for k in keys:
        assert float(fine[f"err_{k}"]) == 0.0
        assert float(coarse[f"ref_{k}"]) == float(fine[k])
        e = (float(coarse[k]) - float(fine[k])) / abs(float(fine[k]))
        assert float(coarse[f"err_{k}"]) == pytest.approx(e, rel=1e-12, abs=1e-15)
    # the radius grows with refinement at 5 us (measured: 4.33 -> 4.43 mm): a real difference
    assert float(coarse["err_radius_mm"]) < -0.01
    # 5 us (--set analysis.end_time) is not the paper's 80 us scene: no paper columns
    assert "err_paper_radius_mm" not in rows[0]
    md = (out / "study.md").read_text()
    assert "exceeds the stable limit" in md and "| 06_refine-2_time_steps-200 | 2 | 200 | ok |" in md
    assert md.count("\n| 0") == 6

    # --reuse: nothing runs again, same table
    before = (out / "study.csv").read_text()
    s = st.run_study(TAYLOR, [st.parse_vary("mesh.refine=0,1,2"), st.parse_vary("analysis.time_steps=1,200")], out,
                     SHORT, reuse=True, log=lambda m: None)
    assert [r.reused for r in s.runs] == [False, False, True, True, True, True]
    assert (out / "study.csv").read_text() == before      # process_time_s too: the recorded one


# -- (d) failure plumbing and bad arguments ------------------------------------------------------------

@needs_serial
def test_exit_2_subprocess_becomes_invalid_row(tmp_path):
    run = st.Run(name="01_x", label="x", settings={})
    st.execute(run, TAYLOR, ["mesh.refine=zero"], tmp_path / "01_x")
    assert run.status == "invalid" and run.returncode == 2
    assert "mesh.refine" in run.reason and not (tmp_path / "01_x" / "summary.json").exists()


def test_bad_study_arguments_exit_2(tmp_path, capsys):
    out = tmp_path / "o"
    assert st.main([str(TAYLOR), "--vary", "mesh.refine", "--out", str(out)]) == 2
    assert "must have the form" in capsys.readouterr().err
    assert st.main([str(TAYLOR), "--vary", "mesh.refine=1,2", "--set", "materials.copper.nu=0.7",
                    "--out", str(out)]) == 2
    assert "materials.copper.nu" in capsys.readouterr().err
    assert st.main([str(TAYLOR), "--vary", "mesh.refine=1,2", "--vary", "mesh.refine=3", "--out", str(out)]) == 2
    assert not (out / "study.csv").exists()
    r = subprocess.run([sys.executable, "-m", "fenics_plast.study", str(TAYLOR), "--vary", "mesh.refine",
                        "--out", str(out)], capture_output=True, text=True, cwd=REPO, timeout=120)
    assert r.returncode == 2 and r.stderr.startswith("error: ") and "must have the form" in r.stderr


@needs_serial
@pytest.mark.slow
def test_study_under_mpirun_matches_serial(tmp_path):
    """--np 2: each run under mpirun -n 2 reports 2 ranks and the serial run's results (Taylor to 5 us)."""
    varies = [st.parse_vary("mesh.refine=1")]
    s1 = st.run_study(TAYLOR, varies, tmp_path / "np1", SHORT, log=lambda m: None)
    s2 = st.run_study(TAYLOR, varies, tmp_path / "np2", SHORT, np_ranks=2, log=lambda m: None)
    r1, r2 = s1.runs[0], s2.runs[0]
    assert r1.ok and r2.ok, (r1.reason, r2.reason)
    assert r1.summary["mpi_ranks"] == 1 and r2.summary["mpi_ranks"] == 2
    assert r2.summary["steps"] == r1.summary["steps"]
    for k in TAYLOR_KEYS:
        assert r2.summary[k] == pytest.approx(r1.summary[k], rel=1e-9), k


def test_a_folder_held_by_another_run_is_refused(tmp_path, monkeypatch):
    """A study takes its folder's lock as a run does: a live holder refuses it before anything runs
    (StudyError: exit 2), a stale one (its PID has ended) is taken over with a warning; the study releases
    the lock at its end."""
    import socket
    from fenics_plast.output import LOCK
    monkeypatch.setattr("fenics_plast.study.driver.execute", _fake_execute)
    out = tmp_path / "s"
    out.mkdir()
    lock = out / LOCK
    lock.write_text(json.dumps({"pid": os.getpid(), "host": socket.gethostname()}))
    with pytest.raises(st.StudyError, match="another run holds the folder"):
        st.run_study(TAYLOR, [st.parse_vary("mesh.refine=1,2")], out, log=lambda m: None)
    assert not (out / "runs").exists() and lock.exists()
    ended = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    lock.write_text(json.dumps({"pid": int(ended.stdout), "host": socket.gethostname()}))
    said = []
    st.run_study(TAYLOR, [st.parse_vary("mesh.refine=1,2")], out, log=said.append)
    assert any("taken over" in m for m in said)
    assert (out / "study.csv").exists() and not lock.exists()
