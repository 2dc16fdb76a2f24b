"""The output folder cannot be used to reach outside it (issue 34, item 2).

One test per defect found by the probes (each fails on the code before the fix):
a history.csv link in a results folder (``run`` overwrote its target), a PNG link (``plot`` overwrote
its target), a study's ``runs`` link (``study`` deleted a file in the folder it points to), ``study
--out`` on a folder of the user's (overwritten), an output named ``history`` (overwrote history.csv),
stale fields/PNGs of an earlier run beside a new summary (``--overwrite``, fewer outputs), and
``point --out`` on a folder or a table with a non-finite row.

Then the family: each kind of link (to a file, to a folder, dangling, a chain of two links) at each
place a file is written or deleted (history.csv, summary.json, other CSVs, PNGs, fields.xdmf/.h5, the
marker, checkpoint/ and its files, study.csv/md/png, runs/ and a run's folder, point --out): the
target outside is never modified, created or deleted. In process where the writers can be called
directly (fast), through the CLI in a subprocess for one kind per place; and a Hypothesis test that
plants random links under the names a run writes and runs the writers.
"""
from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as hs

from fenics_plast import cli
from fenics_plast import study as st
from fenics_plast.checkpoint import Checkpointer, remove_own, write_atomic as ck_write_atomic
from fenics_plast.errors import SceneError
from fenics_plast.out_files import LinkRefused, make_dir, open_write, write_atomic
from fenics_plast.output import (MARKER, OutputDirError, RunOutput, check_out_dir,
                                 mark_results_folder, remove_listed)
from fenics_plast.plots import PlotError, draw_declared
from fenics_plast.problem import load_problem
from fenics_plast.study.execute import Run, execute
from fenics_plast.study.report import write_csv as study_csv, write_markdown, write_plot
from fenics_plast.study.table import Study

ROOT = Path(__file__).resolve().parent.parent
BAR = ROOT / "tests" / "scenes" / "bar.toml"
GEO = ROOT / "meshes" / "round_bar.geo"
KINDS = ("file", "folder", "dangling", "chain")

#: a bar that writes every kind of file: plots (history, profile, shape), a thickness profile, fields, checkpoints
FULL = '''
[outputs.thick]
quantity = "thickness"
group = "axis"
opposite = "outer"

[plots.ok]
type = "history"
x = "time"
y = ["force_N"]

[plots.prof]
type = "profile"
output = "thick"

[plots.shape]
type = "shape"
'''


def fp(*args, cwd=ROOT):
    """``fenics-plast ARGS`` in a subprocess: (exit status, stdout, stderr)."""
    env = dict(os.environ, FENICS_PLAST_PROGRESS="off")
    p = subprocess.run([sys.executable, "-m", "fenics_plast.cli", *map(str, args)], capture_output=True, text=True,
                       cwd=cwd, env=env, timeout=300)
    return p.returncode, p.stdout, p.stderr


def bar_scene(folder: Path, extra: str = "", full: bool = False, name: str = "bar.toml") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    text = BAR.read_text().replace('"../../meshes/round_bar.geo"', json.dumps(str(GEO)))
    if full:
        text = text.replace("[output]\nxdmf = false\nplots = false\ncheckpoint_every = 0",
                            "[output]\nxdmf = true\nplots = true\ncheckpoint_every = 2") + FULL
    path = folder / name
    path.write_text(text + "\n" + extra)
    return path


def snapshot(folder: Path) -> dict:
    """Everything under ``folder`` (not following links): path -> sha256 of a file, 'dir', or 'link:target'."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(folder):
        for n in dirnames + filenames:
            p = Path(dirpath) / n
            rel = str(p.relative_to(folder))
            if p.is_symlink():
                out[rel] = "link:" + os.readlink(p)
            elif p.is_dir():
                out[rel] = "dir"
            else:
                out[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


class Outside:
    """A sentinel tree outside the output folder that links point into."""

    def __init__(self, base: Path):
        self.root = base / "outside"
        (self.root / "dir" / "sub").mkdir(parents=True)
        (self.root / "target.txt").write_text("precious\n")
        (self.root / "dir" / "inner.txt").write_text("inner\n")
        (self.root / "dir" / "sub" / "deep.txt").write_text("deep\n")
        (self.root / "hop").symlink_to(self.root / "target.txt")      # the second link of a chain
        self.before = snapshot(self.root)

    def plant(self, path: Path, kind: str) -> Path:
        """A link of ``kind`` at ``path`` (its parent folder is created)."""
        path.parent.mkdir(parents=True, exist_ok=True)
        target = {"file": self.root / "target.txt", "folder": self.root / "dir",
                  "dangling": self.root / "missing.txt", "chain": self.root / "hop"}[kind]
        path.symlink_to(target)
        return path

    def unchanged(self) -> bool:
        return snapshot(self.root) == self.before


@pytest.fixture
def outside(tmp_path):
    return Outside(tmp_path)


# ----------------------------------------------------------------------------------------------
# one test per defect


def test_run_refuses_a_history_link(tmp_path, outside):
    out = tmp_path / "res"
    out.mkdir()
    mark_results_folder(out, "bar")
    outside.plant(out / "history.csv", "file")
    rc, _, err = fp("run", BAR, "--out", out)
    assert rc == 2, err
    assert f"{out / 'history.csv'} is a symbolic link" in err and "Traceback" not in err
    assert outside.unchanged() and (outside.root / "target.txt").read_text() == "precious\n"


def test_plot_refuses_a_png_link(tmp_path, outside):
    out = tmp_path / "res"
    scene = bar_scene(tmp_path, '[plots.ok]\ntype = "history"\nx = "time"\ny = ["force_N"]\n')
    assert fp("run", scene, "--out", out, "--set", "output.plots=true")[0] == 0
    (out / "ok.png").unlink()
    outside.plant(out / "ok.png", "file")
    rc, _, err = fp("plot", out)
    assert rc == 2 and f"{out / 'ok.png'}: is a symbolic link" in err, err
    assert outside.unchanged()


def test_study_does_not_delete_through_a_runs_link(tmp_path, outside):
    varies = [st.parse_vary("analysis.increments=4")]
    name = st.run_name(0, st.combinations(varies)[0], varies)
    other = outside.root / "dir"
    (other / name).mkdir()
    (other / name / "precious.txt").write_text("keep")
    outside.before = snapshot(outside.root)
    sf = tmp_path / "sf"
    sf.mkdir()
    mark_results_folder(sf, "bar", kind="study")
    (sf / "runs").symlink_to(other)
    rc, _, err = fp("study", BAR, "--vary", "analysis.increments=4", "--out", sf)
    assert rc == 2 and f"{sf / 'runs'} is a symbolic link" in err, err
    assert outside.unchanged() and (other / name / "precious.txt").read_text() == "keep"


def test_study_out_follows_the_rules_of_run_out(tmp_path):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "study.csv").write_text("my own table\n")
    (mine / "thesis.tex").write_text("chapter 1")
    before = snapshot(mine)
    for extra in ([], ["--overwrite"]):
        rc, _, err = fp("study", BAR, "--vary", "analysis.increments=4", "--out", mine, *extra)
        assert rc == 2 and "is not empty and is not a fenics-plast results folder" in err, err
        assert snapshot(mine) == before
    # a run's results folder is not a study's: --overwrite
    res = tmp_path / "res"
    assert fp("run", BAR, "--out", res)[0] == 0
    with pytest.raises(st.StudyError, match="results of a run, not of a study"):
        st.run_study(BAR, [st.parse_vary("analysis.increments=4")], res, log=lambda m: None)
    # a new folder: marked as a study's; the same study again is fine
    sf = tmp_path / "sf"
    for _ in range(2):
        s = st.run_study(BAR, [st.parse_vary("analysis.increments=4")], sf, log=lambda m: None)
        assert [r.status for r in s.runs] == ["ok"]
    assert json.loads((sf / MARKER).read_text())["kind"] == "study"
    # and a run into the study's folder needs --overwrite
    rc, _, err = fp("run", BAR, "--out", sf)
    assert rc == 2 and "results of a study, not of a run" in err, err


@pytest.mark.parametrize("name", ["history", "summary", "fields", "final_shape", "checkpoint", "History",
                                  "fields_part1", "point_uniaxial", "study"])
def test_reserved_output_and_plot_names_are_refused(tmp_path, name):
    out_scene = bar_scene(tmp_path / "o", f'[outputs.{name}]\nquantity = "thickness"\ngroup = "axis"\n'
                                          f'opposite = "outer"\n')
    with pytest.raises(SceneError, match=f"outputs.{name}: the output's name is reserved"):
        load_problem(out_scene)
    plot_scene = bar_scene(tmp_path / "p", f'[plots.{name}]\ntype = "history"\nx = "time"\ny = ["force_N"]\n')
    with pytest.raises(SceneError, match=f"plots.{name}: the plot's name is reserved"):
        load_problem(plot_scene)


def test_an_output_named_history_is_refused_by_the_cli(tmp_path):
    scene = bar_scene(tmp_path, '[outputs.history]\nquantity = "thickness"\ngroup = "axis"\nopposite = "outer"\n')
    out = tmp_path / "out"
    rc, _, err = fp("run", scene, "--out", out)
    assert rc == 2 and "outputs.history: the output's name is reserved" in err and "Traceback" not in err, err
    assert not out.exists()


def test_a_new_run_removes_the_files_of_the_earlier_one(tmp_path):
    out = tmp_path / "out"
    scene = bar_scene(tmp_path, full=True)
    assert fp("run", scene, "--out", out)[0] == 0
    full = {"fields.xdmf", "fields.h5", "ok.png", "prof.png", "shape.png", "thick.csv", "final_shape.csv"}
    assert full <= {p.name for p in out.iterdir()}
    (out / "notes.txt").write_text("mine")                  # a file of the user's: not the run's, kept
    rc, _, err = fp("run", scene, "--out", out, "--set", "output.xdmf=false", "--set", "output.plots=false",
                    "--set", "output.checkpoint_every=0")
    assert rc == 0, err
    names = {p.name for p in out.iterdir()}
    assert not names & {"fields.xdmf", "fields.h5", "ok.png", "prof.png", "shape.png"}, names
    assert (out / "notes.txt").read_text() == "mine"
    # --overwrite onto another scene's results: none of its fields or figures stay
    assert fp("run", scene, "--out", out, "--set", 'scene.name="other"', "--overwrite")[0] == 0
    assert full <= {p.name for p in out.iterdir()}
    rc, _, err = fp("run", BAR, "--out", out, "--overwrite")
    assert rc == 0, err
    assert {p.name for p in out.iterdir()} == {MARKER, "history.csv", "summary.json", "notes.txt"}
    assert json.loads((out / MARKER).read_text())["files"] == ["history.csv", "summary.json"]


def test_a_results_folder_of_an_older_version_is_cleaned_by_its_summary(tmp_path):
    """No list in the marker (older fenics-plast): the files a run writes and those its summary names."""
    out = tmp_path / "old"
    out.mkdir()
    for n in ("fields.xdmf", "fields.h5", "fields_part1.xdmf", "ok.png", "history.csv", "notes.txt"):
        (out / n).write_text("old")
    (out / "summary.json").write_text(json.dumps({"scene": "bar", "scene_settings": {
        "plots": {"ok": {"type": "history"}, "../x": {}}, "outputs": {}}}))
    removed = remove_listed(out)
    assert sorted(removed) == sorted(["fields.xdmf", "fields.h5", "fields_part1.xdmf", "ok.png", "history.csv",
                                      "summary.json"])
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt"]


def test_point_out_a_folder_and_non_finite_rows(tmp_path, capsys):
    d = tmp_path / "d"
    d.mkdir()
    assert cli.main(["point", str(BAR), "--path", "uniaxial", "--to", "0.1", "--steps", "3", "--out", str(d)]) == 2
    assert "is a folder: give the name of the CSV file" in capsys.readouterr().err
    header = "t,F11,F12,F13,F21,F22,F23,F31,F32,F33\n"
    for row, say in (("1,nan,0,0,0,1,0,0,0,1", "F11 = nan is not a finite number"),
                     ("1,1,0,0,0,inf,0,0,0,1", "F22 = inf is not a finite number"),
                     ("1,1e300,0,0,0,1,0,0,0,1", "is not finite in row")):
        table = tmp_path / "F.csv"
        table.write_text(header + "0,1.01,0,0,0,1,0,0,0,1\n" + row + "\n")
        out = tmp_path / "p.csv"
        assert cli.main(["point", str(BAR), "--path", "table", "--table", str(table), "--out", str(out)]) == 2
        assert say in capsys.readouterr().err
        assert not out.exists()


# ----------------------------------------------------------------------------------------------
# the family: every kind of link at every place


@pytest.mark.parametrize("kind", KINDS)
def test_point_out_link(tmp_path, outside, kind, capsys):
    out = outside.plant(tmp_path / "p.csv", kind)
    assert cli.main(["point", str(BAR), "--path", "uniaxial", "--to", "0.1", "--steps", "3", "--out", str(out)]) == 2
    assert "is a symbolic link" in capsys.readouterr().err
    assert outside.unchanged()


RUN_PLACES = ["history.csv", "summary.json", "final_shape.csv", "thick.csv", "ok.png", "fields.xdmf", "fields.h5",
              MARKER, ".fenics-plast.lock", "checkpoint", "checkpoint/ckpt_000000002.json"]


@pytest.mark.parametrize("place", RUN_PLACES)
@pytest.mark.parametrize("kind", KINDS)
def test_check_out_dir_refuses_a_link_where_the_run_writes(tmp_path, outside, place, kind):
    out = tmp_path / "res"
    out.mkdir()
    if place != MARKER:
        mark_results_folder(out, "bar")
    problem = load_problem(bar_scene(tmp_path, full=True))
    from fenics_plast.output import run_file_names
    outside.plant(out / place, kind)
    for resume in (False, True):
        with pytest.raises(OutputDirError, match="is a symbolic link"):
            check_out_dir(out, "bar", resume=resume, names=run_file_names(problem))
    assert outside.unchanged()


@pytest.mark.parametrize("i, place", list(enumerate(RUN_PLACES)))
def test_run_refuses_each_link_end_to_end(tmp_path, outside, i, place):
    """Through the CLI (one kind of link per place, the kinds in turn): exit 2, naming the path."""
    kind = KINDS[i % len(KINDS)]
    scene = bar_scene(tmp_path, full=True)
    out = tmp_path / "res"
    out.mkdir()
    if place != MARKER:
        mark_results_folder(out, "bar")
    outside.plant(out / place, kind)
    rc, _, err = fp("run", scene, "--out", out)
    assert rc == 2 and "is a symbolic link" in err and str(out / place.split("/")[0]) in err, err
    assert outside.unchanged()


@pytest.mark.parametrize("kind", KINDS)
def test_the_run_writers_refuse_links(tmp_path, outside, kind):
    """Without the up-front check: each writer of RunOutput, the plots, the checkpoints refuses the link
    (LinkRefused / PlotError), and the deleters leave it (and its target) alone."""
    out = tmp_path / "res"
    out.mkdir()
    mark_results_folder(out, "bar")
    o = RunOutput(out)
    for name, write in (("history.csv", lambda: o.history(time=0.0, force_N=1.0)),
                        ("history.csv", lambda: o.restore_history([{"time": 0.0}])),
                        ("thick.csv", lambda: o.write_csv("thick", {"a": [1.0]})),
                        ("summary.json", lambda: o.finish({"scene": "bar"})),
                        ("fields_part1.xdmf", lambda: write_atomic(out / "fields_part1.xdmf", "x")),
                        ("checkpoint/ckpt_000000001.json", lambda: ck_write_atomic(
                            out / "checkpoint" / "ckpt_000000001.json", b"{}")),
                        ("checkpoint", lambda: ck_write_atomic(out / "checkpoint" / "ckpt_000000001.json", b"{}")),
                        ("checkpoint", lambda: Checkpointer(out, None, {}, "static", every=1)),
                        ("runs", lambda: make_dir(out / "runs", root=out)),
                        ("runs", lambda: open_write(out / "runs" / "x" / "run.log", root=out))):
        link = outside.plant(out / name, kind)
        with pytest.raises(LinkRefused, match="symbolic link"):
            write()
        assert link.is_symlink() and outside.unchanged(), name
        link.unlink()
        if "/" in name:
            link.parent.rmdir()
        o._hist_header = None
        o.close_history()
    # the marker itself
    (out / MARKER).unlink()
    outside.plant(out / MARKER, kind)
    with pytest.raises(LinkRefused):
        mark_results_folder(out, "bar")
    (out / MARKER).unlink()
    # the deleters: listed files, checkpoint files and folder, summary.json of an earlier run
    mark_results_folder(out, "bar")
    (out / MARKER).write_text(json.dumps({"scene": "bar", "files": ["a.png", "summary.json", "../outside/target.txt"]}))
    for n in ("a.png", "summary.json", "checkpoint/ckpt_000000003.json"):
        outside.plant(out / n, kind)
    remove_listed(out)
    remove_own(out / "checkpoint")
    RunOutput(out)
    assert (out / "a.png").is_symlink() and (out / "summary.json").is_symlink() and outside.unchanged()
    for n in ("a.png", "summary.json", "checkpoint/ckpt_000000003.json"):
        (out / n).unlink()
    (out / "checkpoint").rmdir()
    outside.plant(out / "checkpoint", kind)
    remove_own(out / "checkpoint")
    assert outside.unchanged()
    (out / "checkpoint").unlink()
    # the PNGs: refused before any figure is drawn
    (out / "history.csv").write_text("time,force_N\n0,0\n1,2\n")
    outside.plant(out / "ok.png", kind)
    plots = {"ok": {"type": "history", "x": "time", "y": ["force_N"]}}
    with pytest.raises(PlotError, match="symbolic link"):
        draw_declared(out, {"analysis": {}, "plots": plots}, title="t", render=False)
    assert outside.unchanged()


def test_a_hard_link_is_not_written_into(tmp_path, outside):
    out = tmp_path / "res"
    out.mkdir()
    os.link(outside.root / "target.txt", out / "history.csv")
    outside.before = snapshot(outside.root)
    o = RunOutput(out)
    o.history(time=0.0)
    o.close_history()
    write_atomic(out / "summary.json", "{}")
    assert outside.unchanged() and (out / "history.csv").read_text().startswith("time")


STUDY_PLACES = ["study.csv", "study.md", "study.png", "runs", "RUN", "RUN/run.log", "RUN/study_run.json",
                "RUN/summary.json", MARKER]


@pytest.mark.parametrize("place", STUDY_PLACES)
@pytest.mark.parametrize("kind", KINDS)
def test_study_refuses_a_link_where_it_writes(tmp_path, outside, place, kind):
    varies = [st.parse_vary("analysis.increments=4")]
    run = st.run_name(0, st.combinations(varies)[0], varies)
    sf = tmp_path / "sf"
    (sf / "runs").mkdir(parents=True)
    if place != MARKER:
        mark_results_folder(sf, "bar", kind="study")
    if place.startswith("RUN/"):
        (sf / "runs" / run).mkdir()
        mark_results_folder(sf / "runs" / run, None)
    elif place == "runs":
        (sf / "runs").rmdir()
    outside.plant(sf / place.replace("RUN", f"runs/{run}"), kind)
    with pytest.raises(st.StudyError, match="symbolic link"):
        st.run_study(BAR, varies, sf, log=lambda m: None)
    assert outside.unchanged()
    assert not (sf / "study.csv").exists() or place == "study.csv"


@pytest.mark.parametrize("kind", KINDS)
def test_study_writers_refuse_links(tmp_path, outside, kind):
    sf = tmp_path / "sf"
    (sf / "runs").mkdir(parents=True)
    study = Study(scene=BAR, analysis="static", scene_name="bar", varies=[], sets=[], keys=[], info=[], out=sf,
                  np_ranks=1, command="x")
    for name, write in (("study.csv", study_csv), ("study.md", write_markdown), ("study.png", write_plot)):
        outside.plant(sf / name, kind)
        with pytest.raises(LinkRefused):
            write(study, sf / name)
        assert outside.unchanged(), name
    # a run's folder, or a file in it: refused before the run starts, nothing deleted
    r = Run(name="r0", label="r0", settings={})
    outside.plant(sf / "runs" / "r0", kind)
    with pytest.raises(LinkRefused):
        execute(r, BAR, [], sf / "runs" / "r0", root=sf)
    (sf / "runs" / "r0").unlink()
    (sf / "runs" / "r0").mkdir()
    mark_results_folder(sf / "runs" / "r0", None)
    outside.plant(sf / "runs" / "r0" / "run.log", kind)
    with pytest.raises(LinkRefused):
        execute(r, BAR, [], sf / "runs" / "r0", root=sf)
    assert outside.unchanged()


def test_study_keeps_a_folder_of_the_users_under_runs(tmp_path):
    varies = [st.parse_vary("analysis.increments=4")]
    run = st.run_name(0, st.combinations(varies)[0], varies)
    sf = tmp_path / "sf"
    (sf / "runs" / run).mkdir(parents=True)
    mark_results_folder(sf, "bar", kind="study")
    (sf / "runs" / run / "mine.txt").write_text("keep")
    with pytest.raises(st.StudyError, match="not a results folder of a study run"):
        st.run_study(BAR, varies, sf, log=lambda m: None)
    assert (sf / "runs" / run / "mine.txt").read_text() == "keep"


# ----------------------------------------------------------------------------------------------
# random links under the names a run writes


PLACES = ["history.csv", "summary.json", "thick.csv", "final_shape.csv", "ok.png", "fields.xdmf", "fields.h5",
          "fields_part1.xdmf", "fields_part1.h5", MARKER, ".fenics-plast.lock", "checkpoint",
          "checkpoint/ckpt_000000001.json", "checkpoint/ckpt_000000001.rank0.npz", "checkpoint/.ckpt_000000001.json.tmp1",
          "runs", "study.csv", "study.png", "study.md"]


@settings(derandomize=True, database=None, deadline=None, max_examples=100,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(planted=hs.dictionaries(hs.sampled_from(PLACES), hs.sampled_from(KINDS), min_size=1, max_size=4),
       listed=hs.lists(hs.sampled_from(PLACES), max_size=4), resume=hs.booleans())
def test_random_links_never_reach_outside(tmp_path_factory, planted, listed, resume):
    base = tmp_path_factory.mktemp("fuzz")
    outside = Outside(base)
    out = base / "res"
    out.mkdir()
    if MARKER not in planted:
        (out / MARKER).write_text(json.dumps({"scene": "bar", "files": listed}))
    if "fields.xdmf" not in planted:
        (out / "fields.xdmf").write_text("<Xdmf/>")
    planted = {p: k for p, k in planted.items() if not (p.startswith("checkpoint/") and "checkpoint" in planted)}
    for p, k in planted.items():
        outside.plant(out / p, k)
    # the up-front check refuses every one of these places
    if any(p not in ("runs", "study.csv", "study.png", "study.md", "fields_part1.xdmf", "fields_part1.h5")
           for p in planted):
        with pytest.raises(OutputDirError):
            check_out_dir(out, "bar", names=["thick.csv", "ok.png", "final_shape.csv"], resume=resume)
    # and the writers and deleters, called all the same, never write or delete through a link
    steps = [lambda: mark_results_folder(out, "bar"), lambda: remove_listed(out),
             lambda: remove_own(out / "checkpoint")]
    o = None

    def start():
        nonlocal o
        o = RunOutput(out, resume=resume)

    steps += [start, lambda: o.claim("fields.xdmf", "fields.h5"), lambda: o.history(time=0.0, f=1.0),
              lambda: o.history(time=1.0, f=2.0), lambda: o.restore_history([{"time": 0.0, "f": 1.0}]),
              lambda: o.write_csv("thick", {"s": [0.0, 1.0]}), lambda: o.write_csv("final_shape", {"x": [1.0]}),
              lambda: Checkpointer(out, None, {}, "static", every=1, output=o).save(1, state={"a": 1}),
              lambda: draw_declared(out, {"analysis": {}, "plots": {"ok": {"type": "history", "x": "time",
                                                                             "y": ["f"]}}}, "t", render=False),
              lambda: make_dir(out / "runs", root=out), lambda: write_atomic(out / "study.md", "# s"),
              lambda: o.finish({"scene": "bar"})]
    for step in steps:
        try:
            step()
        except (LinkRefused, PlotError, OutputDirError, AttributeError):
            pass
    if o is not None:
        o.close_history()
    assert outside.unchanged(), planted
    for p in planted:
        assert os.path.islink(out / p), p          # every link is still there: refused, not replaced
