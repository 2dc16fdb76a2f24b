"""Nothing is written outside ``--out``, and nothing of the user's is deleted (issue 21, item 2).

One test per defect found by the probes: plot and output names that would escape the output folder
(in a scene, and in a crafted results folder given to ``fenics-plast plot``); ``--out`` on a folder
that is not a results folder, on another scene's results, on a file, on a path that cannot be
created; a user's ``checkpoint/`` subfolder; a 300-character scene name; two runs on one folder
(the lock). The runs are the 3 x 2-cell bar of tests/scenes/bar.toml through the CLI in a
subprocess (about a second each).
"""
from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from fenics_plast import cli
from fenics_plast.checkpoint import Checkpointer
from fenics_plast.output import LOCK, MARKER, OutputDirError, file_name_problem
from fenics_plast.run_lock import RunLock, this_process

ROOT = Path(__file__).resolve().parent.parent
BAR = ROOT / "tests" / "scenes" / "bar.toml"
GEO = ROOT / "meshes" / "round_bar.geo"


def fp(*args, cwd=ROOT):
    """``fenics-plast ARGS`` in a subprocess: (exit status, stdout, stderr)."""
    env = dict(os.environ, FENICS_PLAST_PROGRESS="off")
    p = subprocess.run([sys.executable, "-m", "fenics_plast.cli", *map(str, args)], capture_output=True, text=True,
                       cwd=cwd, env=env, timeout=300)
    return p.returncode, p.stdout, p.stderr


def bar_scene(folder: Path, extra: str = "", name: str = "bar.toml") -> Path:
    """tests/scenes/bar.toml in ``folder`` (mesh file by absolute path) with ``extra`` TOML appended."""
    folder.mkdir(parents=True, exist_ok=True)
    text = BAR.read_text().replace('"../../meshes/round_bar.geo"', json.dumps(str(GEO)))
    path = folder / name
    path.write_text(text + "\n" + extra)
    return path


def tree(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` and its bytes."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_file_name_rules():
    for ok in ("force", "max_eqps", "Taylor bar 1", "a.b", "x" * 100):
        assert file_name_problem(ok) is None, ok
    for bad in ("", " ", "../../x", "a/b", "a\\b", ".hidden", "..", ".", "x" * 101, "a\0b", "a\nb", "a:b", " a",
                "a*", "a?b", "<a>", "a|b", 'a"b'):
        assert file_name_problem(bad), bad


# ----------------------------------------------------------------------------------------------
# names used as file names


def test_plot_name_with_a_path_is_refused(tmp_path):
    scene = bar_scene(tmp_path / "a" / "b", '[plots."../../x"]\ntype = "history"\nx = "time"\ny = ["force_N"]\n')
    out = tmp_path / "a" / "b" / "out"
    rc, _, err = fp("run", scene, "--out", out, "--set", "output.plots=true")
    assert rc == 2, err
    assert "plots.../../x: the plot's name must not contain /" in err and "Traceback" not in err
    assert not out.exists()
    assert not [p for p in tmp_path.rglob("x.*")]          # nothing two folders up (the old code wrote a/x.png)


def test_thickness_output_name_with_a_path_is_refused(tmp_path):
    scene = bar_scene(tmp_path / "a" / "b", '[outputs."../../x"]\nquantity = "thickness"\ngroup = "axis"\n'
                                            'opposite = "outer"\n')
    out = tmp_path / "a" / "b" / "out"
    rc, _, err = fp("run", scene, "--out", out)
    assert rc == 2, err
    assert "outputs.../../x: the output's name must not contain /" in err and "Traceback" not in err
    assert not out.exists()
    assert not [p for p in tmp_path.rglob("x.*")]          # the old code wrote a/x.csv


def test_plot_command_refuses_names_from_a_crafted_summary(tmp_path):
    results = tmp_path / "a" / "b" / "results"
    results.mkdir(parents=True)
    (results / "history.csv").write_text("t,f\n0,0\n1,2\n")
    settings = {"analysis": {"type": "static"}, "mesh": {"geometry": "axisymmetric"},
                "plots": {"../../x": {"type": "history", "x": "t", "y": ["f"]}}}
    (results / "summary.json").write_text(json.dumps({"scene": "bar", "scene_settings": settings}))
    before = tree(tmp_path)
    rc, _, err = fp("plot", results)
    assert rc == 2 and "plots.'../../x': the plot's name must not contain /" in err, err
    assert tree(tmp_path) == before                         # the old code wrote a/x.png
    # a profile plot reads <output>.csv: an output name that leaves the folder is refused too
    settings["plots"] = {"p": {"type": "profile", "output": "../../../etc/passwd"}}
    (results / "summary.json").write_text(json.dumps({"scene": "bar", "scene_settings": settings}))
    rc, _, err = fp("plot", results)
    assert rc == 2 and "plots.p.output = '../../../etc/passwd'" in err, err


def test_300_character_scene_name(tmp_path):
    scene = bar_scene(tmp_path, f'# scene.name set below\n')
    rc, _, err = fp("run", scene, "--set", f'scene.name="{"n" * 300}"', cwd=tmp_path)
    assert rc == 2, err
    assert "scene.name = " in err and "300 characters long: at most 100" in err and "Traceback" not in err
    assert not (tmp_path / "results").exists()             # the old code left an empty results/ behind


# ----------------------------------------------------------------------------------------------
# the output folder


def test_out_names_a_file_or_a_path_that_cannot_be_made(tmp_path):
    f = tmp_path / "notes.txt"
    f.write_text("mine")
    rc, _, err = fp("run", BAR, "--out", f)
    assert rc == 2 and f"--out {f}: is a file, not a folder" in err and "Traceback" not in err, err
    assert f.read_text() == "mine"
    rc, _, err = fp("run", BAR, "--out", f / "sub")
    assert rc == 2 and f"{f} is a file, not a folder" in err and "Traceback" not in err, err
    # /proc refuses new folders even to root
    rc, _, err = fp("run", BAR, "--out", "/proc/fenics_plast_test/out")
    assert rc == 2 and "cannot create the folder" in err and "Traceback" not in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


@pytest.mark.skipif(hasattr(os, "geteuid") and os.geteuid() == 0, reason="root may write anywhere")
def test_out_in_a_read_only_folder(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        rc, _, err = fp("run", BAR, "--out", ro / "out")
        assert rc == 2 and "is not writable" in err and "Traceback" not in err, err
    finally:
        ro.chmod(0o755)


def test_a_folder_that_is_not_a_results_folder_is_refused(tmp_path):
    out = tmp_path / "mine"
    (out / "checkpoint").mkdir(parents=True)
    (out / "thesis.tex").write_text("chapter 1")
    (out / "checkpoint" / "notes.txt").write_text("keep me")
    before = tree(out)
    for extra in ([], ["--overwrite"]):
        rc, _, err = fp("run", BAR, "--out", out, *extra)
        assert rc == 2 and "is not empty and is not a fenics-plast results folder" in err, err
        assert tree(out) == before and sorted(p.name for p in out.iterdir()) == ["checkpoint", "thesis.tex"]
    # an empty folder is fine
    empty = tmp_path / "empty"
    empty.mkdir()
    rc, _, err = fp("run", BAR, "--out", empty)
    assert rc == 0, err
    assert json.loads((empty / MARKER).read_text())["scene"] == "bar" and not (empty / LOCK).exists()


def test_another_scenes_results_need_overwrite(tmp_path):
    out = tmp_path / "out"
    assert fp("run", BAR, "--out", out)[0] == 0
    assert fp("run", BAR, "--out", out)[0] == 0              # the same scene again (make demo twice)
    rc, _, err = fp("run", BAR, "--out", out, "--set", 'scene.name="other"')
    assert rc == 2 and "holds the results of scene 'bar', not 'other'" in err and "--overwrite" in err, err
    assert json.loads((out / "summary.json").read_text())["scene"] == "bar"
    rc, _, err = fp("run", BAR, "--out", out, "--set", 'scene.name="other"', "--overwrite")
    assert rc == 0, err
    assert json.loads((out / "summary.json").read_text())["scene"] == "other"
    assert json.loads((out / MARKER).read_text())["scene"] == "other"


def test_a_users_checkpoint_subfolder_is_kept(tmp_path):
    """A results folder of the scene whose checkpoint/ also holds a file of the user's: runs with and
    without checkpoints delete their own (and stale) checkpoint files only."""
    out = tmp_path / "out"
    assert fp("run", BAR, "--out", out)[0] == 0
    ck = out / "checkpoint"
    ck.mkdir()
    (ck / "notes.txt").write_text("keep me")
    (ck / "ckpt_000000007.json").write_text("{}")            # a stale checkpoint of an earlier run: goes
    for every in (0, 2):
        rc, _, err = fp("run", BAR, "--out", out, "--set", f"output.checkpoint_every={every}")
        assert rc == 0, err
        assert sorted(p.name for p in ck.iterdir()) == ["notes.txt"], every
        assert (ck / "notes.txt").read_text() == "keep me"


def test_checkpointer_deletes_its_own_files_only(tmp_path):
    settings = {"mesh": {"refine": 1}}
    ck = tmp_path / "checkpoint"
    ck.mkdir()
    (ck / "notes.txt").write_text("keep me")
    (ck / "sub").mkdir()
    (ck / "sub" / "ckpt_000000001.json").write_text("{}")     # not the checkpointer's (a subfolder)
    (ck / "ckpt_000000001.json").write_text("{}")
    (ck / "ckpt_000000001.rank0.npz").write_bytes(b"x")
    (ck / ".ckpt_000000002.rank0.npz.tmp123").write_bytes(b"x")
    Checkpointer(tmp_path, None, settings, "static", every=0)          # a fresh run without checkpoints
    assert sorted(p.name for p in ck.iterdir()) == ["notes.txt", "sub"]
    c = Checkpointer(tmp_path, None, settings, "static", every=1)
    c.save(1, solver={"t": 1.0})
    c.clear()
    assert sorted(p.name for p in ck.iterdir()) == ["notes.txt", "sub"]
    (ck / "notes.txt").unlink()
    (ck / "sub" / "ckpt_000000001.json").unlink()
    (ck / "sub").rmdir()
    c = Checkpointer(tmp_path, None, settings, "static", every=1)
    c.save(1, solver={"t": 1.0})
    c.clear()
    assert not ck.exists()                                   # nothing else in it: the folder goes too


# ----------------------------------------------------------------------------------------------
# the lock


def _dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def test_a_second_run_on_a_locked_folder_exits_2(tmp_path):
    out = tmp_path / "out"
    assert fp("run", BAR, "--out", out)[0] == 0
    assert not (out / LOCK).exists()                         # released at the end
    before = tree(out)
    holder = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        (out / LOCK).write_text(json.dumps({"pid": holder.pid, "host": socket.gethostname()}))
        rc, _, err = fp("run", BAR, "--out", out)
        assert rc == 2 and f"another run holds the folder: PID {holder.pid}" in err, err
        assert json.loads((out / LOCK).read_text())["pid"] == holder.pid
        (out / LOCK).unlink()
        assert tree(out) == before                           # the refused run touched nothing
    finally:
        holder.kill()
        holder.wait()


def test_a_stale_lock_is_taken_over(tmp_path):
    out = tmp_path / "out"
    assert fp("run", BAR, "--out", out)[0] == 0
    pid = _dead_pid()
    (out / LOCK).write_text(json.dumps({"pid": pid, "host": socket.gethostname()}))
    rc, _, err = fp("run", BAR, "--out", out)
    assert rc == 0, err
    assert (f"warning: {out / LOCK} was left by a run that has ended (PID {pid} on this host: no longer running): "
            f"taken over") in err
    assert not (out / LOCK).exists()


def test_lock_is_held_during_the_run_and_released_on_failure(tmp_path, monkeypatch):
    """In-process: the lock exists while the runner runs (with this process's PID), and is removed
    when the run fails (exit 1) or is interrupted (Ctrl-C)."""
    from fenics_plast import runner
    out = tmp_path / "out"
    seen = []

    def failing_run(problem, output, mesh_data=None):
        seen.append(json.loads((out / LOCK).read_text()))
        raise RuntimeError("boom")
    monkeypatch.setattr(runner, "run", failing_run)
    assert cli.main(["run", str(BAR), "--out", str(out)]) == 1
    held = seen[-1]
    assert (held["pid"], held["host"]) == (os.getpid(), socket.gethostname())
    assert held["processes"] == [list(this_process())]
    assert not (out / LOCK).exists() and (out / "summary.json").is_file()

    def interrupted(problem, output, mesh_data=None):
        assert (out / LOCK).exists()
        raise KeyboardInterrupt
    monkeypatch.setattr(runner, "run", interrupted)
    assert cli.main(["run", str(BAR), "--out", str(out)]) == 130
    assert not (out / LOCK).exists()


def test_runlock_unit(tmp_path):
    lock = RunLock.acquire(tmp_path)
    assert lock.warning is None
    with pytest.raises(OutputDirError, match=f"PID {os.getpid()} on this host"):
        RunLock.acquire(tmp_path)
    lock.release()
    assert not (tmp_path / LOCK).exists()
    (tmp_path / LOCK).write_text(json.dumps({"pid": 1, "host": "elsewhere.example"}))
    with pytest.raises(OutputDirError, match="PID 1 on host elsewhere.example"):
        RunLock.acquire(tmp_path)
    (tmp_path / LOCK).write_text("garbage")                  # not a lock of ours: stale
    lock = RunLock.acquire(tmp_path)
    assert lock.warning == f"warning: {tmp_path / LOCK} is not a lock written by fenics-plast: taken over"
    lock.release()
