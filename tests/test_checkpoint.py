"""Safe interruption: checkpoints and ``fenics-plast run ... --resume DIR``.

A run is killed for real (``os._exit(137)`` on every rank, through the test hook
``FENICS_PLAST_KILL_AFTER_CHECKPOINTS`` of fenics_plast/checkpoint.py) and resumed; the resumed run
must match an uninterrupted one to 1e-10: displacement field, the summary's results, history.csv
(rows the killed run wrote after its last checkpoint dropped, not duplicated). Serially and under
``mpirun -n 2`` (tests/checkpoint_driver.py keeps the final displacement of in-process CLI runs).
Plus the checkpoint files themselves: manifest written last, old ones pruned, a corrupt rank file
falls back to the previous checkpoint, and resume refuses another number of ranks, other scene
settings or another format, with a clear message and without touching the directory.
"""
from __future__ import annotations

import csv
import json
import os
import shutil
import socket
import subprocess
import sys
import threading
from pathlib import Path

from types import SimpleNamespace

import numpy as np
import pytest

from fenics_plast import checkpoint as ck
from fenics_plast.checkpoint import CheckpointError, Checkpointer, Keyed
from fenics_plast.output import LOCK

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))
import checkpoint_driver  # noqa: E402
from scene_runs import needs_mpirun, serial_and_two_ranks  # noqa: E402

COMMON = ["--set", "output.plots=false"]
# shortened scenes with frequent checkpoints; (scene file, overrides, kill point, material name)
SCENES = {
    # a checkpoint every 30 steps: killed while writing the 3rd (rank files, no manifest), after
    # rows past the 2nd: resumes from step 60
    "taylor": ("taylor_bar.toml", ["--set", "analysis.end_time=10", "--set", "output.history_points=21",
                                   "--set", "output.checkpoint_every=30"], "during", "copper"),
    # 3 mm of elongation in 10 increments (max_increment 0.1), a checkpoint every 2: killed right after
    # the 2nd (increment 4)
    "bar": ("bar_tension.toml", ["--set", 'boundary.grip.value="1.5 * t"', "--set", "analysis.increments=8",
                                 "--set", "output.checkpoint_every=2", "--set", "output.xdmf=false"], "after", "steel"),
    # 24 mm of travel in two steps (to 12 and 24 mm), frictional contact history: killed while writing
    # the 3rd checkpoint (increment 9)
    "punch": ("punch_stretching.toml", ["--set", "tools.punch.path.y=[0.0, 24.0]",
                                        "--set", "steps.to_20mm.increments=6", "--set", "steps.to_40mm.increments=6",
                                        "--set", "contact.punch.friction=0.15", "--set", "contact.die.friction=0.15",
                                        "--set", "output.checkpoint_every=3", "--set", "output.xdmf=false"],
              "during", "aluminium"),
}
TIMING_KEYS = {"wall_time_s", "step_loop_time_s", "time_per_step_s", "setup_time_s", "setup_and_solve_s",
               "solve_time_s", "solver_times_s", "peak_memory_mb"}     # measurements of the process
MPIRUN = ["/usr/bin/mpirun", "--allow-run-as-root", "-n", "2"]


def process_of(pid):
    """(PID, start time) of a running process, as a lock names it (fenics_plast/run_lock.py)."""
    with open(f"/proc/{pid}/stat") as f:
        text = f.read()
    return pid, text[text.rindex(")") + 2:].split()[19]


def scene_args(name):
    f, sets, _, _ = SCENES[name]
    return [str(REPO / "demos" / f), *sets, *COMMON]


def kill_env(point):
    env = dict(os.environ, FENICS_PLAST_KILL_AFTER_CHECKPOINTS="2", FENICS_PLAST_KILL_POINT=point,
               OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    return env


def run_killed(name, out, mpi=False):
    """The scene through the CLI in a subprocess that kills itself at its 2nd/3rd checkpoint."""
    cmd = ([*MPIRUN] if mpi else []) + [sys.executable, "-m", "fenics_plast.cli", "run", *scene_args(name),
                                        "--out", str(out)]
    r = subprocess.run(cmd, capture_output=True, text=True, cwd=REPO, timeout=300, env=kill_env(SCENES[name][2]))
    assert r.returncode == 137, r.stdout[-2000:] + r.stderr[-2000:]
    return r


def history(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], np.array([[float(x) if x else np.nan for x in r] for r in rows[1:]])


def check_killed_dir(out, point):
    """What a killed run leaves: no summary.json; two complete checkpoints (manifests); with the kill
    during the 3rd, its rank files but no manifest, and history rows beyond the 2nd checkpoint."""
    assert not (out / "summary.json").exists()
    manifests = sorted((out / "checkpoint").glob("ckpt_*.json"))
    assert len(manifests) == 2
    last = json.loads(manifests[-1].read_text())
    rank_files = sorted((out / "checkpoint").glob("ckpt_*.rank*.npz"))
    extra = len(rank_files) - 2 * last["ranks"]
    assert extra == (last["ranks"] if point == "during" else 0)
    assert not list((out / "checkpoint").glob(".*tmp*"))
    _, rows = history(out / "history.csv")
    saved = len(last["history_rows"])
    assert (len(rows) > saved) if point == "during" else (len(rows) == saved)
    return last


def compare(ref_dir, res_dir, ref_npz, res_npz, exact_history):
    """Max differences resumed vs uninterrupted; asserts 1e-10 (and equal history.csv text serially)."""
    a, b = np.load(ref_npz), np.load(res_npz)
    assert int(a["rc"]) == 0 and int(b["rc"]) == 0
    assert np.array_equal(a["X"], b["X"])
    du = float(np.abs(a["u"] - b["u"]).max())
    assert du <= 1e-10, du
    sa = json.loads((ref_dir / "summary.json").read_text())
    sb = json.loads((res_dir / "summary.json").read_text())
    assert sb["resumed_from_checkpoint"] > 0 and sb["converged"] is True
    worst = 0.0
    for k, v in sa.items():
        if k in TIMING_KEYS or k.startswith("checkpoint"):
            continue
        if isinstance(v, float):
            rel = abs(v - sb[k]) / max(abs(v), 1e-300) if v != sb[k] else 0.0
            worst = max(worst, rel)
            assert rel <= 1e-10, (k, v, sb[k])
        else:
            assert sb[k] == v, (k, v, sb[k])
    ha, hb = history(ref_dir / "history.csv"), history(res_dir / "history.csv")
    assert ha[0] == hb[0] and ha[1].shape == hb[1].shape
    np.testing.assert_allclose(hb[1], ha[1], rtol=1e-10, atol=1e-12)
    if exact_history:
        assert (ref_dir / "history.csv").read_bytes() == (res_dir / "history.csv").read_bytes()
    assert not (res_dir / "checkpoint").exists()          # removed after success
    return du, worst


# ----------------------------------------------------------------------------------------------
# end to end


@pytest.mark.parametrize("name", ["taylor", "bar", "punch"])
def test_kill_and_resume_serial(tmp_path, name, capsys):
    ref, res = tmp_path / "ref", tmp_path / "res"
    assert checkpoint_driver.run_job(["run", *scene_args(name), "--out", ref], tmp_path / "ref.npz") == 0
    run_killed(name, res)
    last = check_killed_dir(res, SCENES[name][2])
    hist_before = (res / "history.csv").read_bytes()
    # refused: other scene settings (nothing touched)
    capsys.readouterr()
    material = SCENES[name][3]
    assert checkpoint_driver.run_job(["run", *scene_args(name), "--set", f"materials.{material}.nu=0.31",
                                      "--resume", res], tmp_path / "bad.npz") == 2
    err = capsys.readouterr().err
    assert f"materials.{material}.nu = 0.31 (checkpoint: " in err and "scene settings differ" in err
    assert (res / "history.csv").read_bytes() == hist_before and not (res / "summary.json").exists()
    # resumed (the bar: while a rank of the killed run is still exiting, here a process that ends after
    # 1.5 s holding the lock: the resume waits for it, says so, and goes on)
    exiting = None
    if name == "bar":
        exiting = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(1.5)"])
        (res / LOCK).write_text(json.dumps({"pid": 1, "host": socket.gethostname(),
                                            "processes": [[1, "0"], list(process_of(exiting.pid))]}))
        threading.Thread(target=exiting.wait).start()
    assert checkpoint_driver.run_job(["run", *scene_args(name), "--resume", res], tmp_path / "res.npz") == 0
    if exiting is not None:
        out = capsys.readouterr()
        assert f"waiting up to 30 s for the run that holds the folder (PIDs 1, {exiting.pid} on this host)" in out.out
        assert (f"{res / LOCK} was left by a run that has ended (PIDs 1, {exiting.pid} on this host: no longer "
                f"running): taken over") in out.err and not (res / LOCK).exists()
    summary = json.loads((res / "summary.json").read_text())
    assert summary["resumed_from_checkpoint"] == last["counter"]
    # the explicit kernels are numba code compiled with FMA contraction: a process that compiles them and
    # one that loads them from the cache may round differently (1e-15), so the Taylor history is compared
    # to 1e-10 like the MPI runs; the static scenes must give the same text
    du, rel = compare(ref, res, tmp_path / "ref.npz", tmp_path / "res.npz", exact_history=name != "taylor")
    print(f"{name} serial: resumed from {last['counter']}, max |du| = {du:.3g} mm, max rel. summary diff {rel:.3g}")
    if name == "taylor":     # the killed run's fields are kept apart, the resumed run's go on in fields.xdmf
        part = (res / "fields_part1.xdmf").read_text()
        assert "fields_part1.h5:" in part and "fields.h5:" not in part and (res / "fields.xdmf").is_file()


@pytest.mark.mpi
def test_kill_and_resume_mpi(tmp_path, capsys):
    """Under mpirun -n 2: Taylor bar (killed during its 3rd checkpoint) and necking bar (killed after
    its 2nd); the serial resume of a 2-rank checkpoint is refused; the 2-rank resumes match 2-rank
    uninterrupted runs to 1e-10 (history.csv numerically: MPI sums are not bitwise reproducible)."""
    names = ["taylor", "bar"]
    for name in names:
        run_killed(name, tmp_path / f"{name}_res", mpi=True)
        check_killed_dir(tmp_path / f"{name}_res", SCENES[name][2])
    capsys.readouterr()
    assert checkpoint_driver.run_job(["run", *scene_args("taylor"), "--resume", tmp_path / "taylor_res"],
                                     tmp_path / "x.npz") == 2
    assert "written by 2 MPI rank(s), this run has 1" in capsys.readouterr().err
    jobs = [dict(argv=["run", *scene_args(n), "--out", str(tmp_path / f"{n}_ref")], npz=str(tmp_path / f"{n}_ref.npz"))
            for n in names]
    jobs += [dict(argv=["run", *scene_args(n), "--resume", str(tmp_path / f"{n}_res")],
                  npz=str(tmp_path / f"{n}_res.npz")) for n in names]
    jobs += [dict(keys=n, npz=str(tmp_path / f"{n}_keys2.npz")) for n in names]
    (tmp_path / "jobs.json").write_text(json.dumps(jobs))
    r = subprocess.run([*MPIRUN, sys.executable, str(REPO / "tests" / "checkpoint_driver.py"),
                        str(tmp_path / "jobs.json")], capture_output=True, text=True, cwd=REPO, timeout=300,
                       env=dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1"))
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    for n in names:
        assert int(np.load(tmp_path / f"{n}_ref.npz")["ranks"]) == 2
        rcs = [int(np.load(tmp_path / f"{n}_{kind}.npz")["rc"]) for kind in ("ref", "res")]
        assert rcs == [0, 0], f"{n}: exit statuses {rcs} (uninterrupted, resumed)\n{r.stderr[-3000:]}"
        du, rel = compare(tmp_path / f"{n}_ref", tmp_path / f"{n}_res", tmp_path / f"{n}_ref.npz",
                          tmp_path / f"{n}_res.npz", exact_history=False)
        print(f"{n} mpi: max |du| = {du:.3g} mm, max rel. summary diff {rel:.3g}")
    # rows are matched by key on resume: the keys name the same nodes, cells and points on 1 and 2 ranks
    for n in names:
        checkpoint_driver.key_coordinates(n, tmp_path / f"{n}_keys1.npz")
        k1, k2 = np.load(tmp_path / f"{n}_keys1.npz"), np.load(tmp_path / f"{n}_keys2.npz")
        for what in ("dof", "qp"):
            assert np.array_equal(k1[f"{what}_keys"], k2[f"{what}_keys"])
            assert np.unique(k1[f"{what}_keys"]).size == k1[f"{what}_keys"].size
            np.testing.assert_allclose(k2[f"{what}_x"], k1[f"{what}_x"], rtol=0, atol=1e-12)


# ----------------------------------------------------------------------------------------------
# the checkpoint files (no dolfinx)


class _Out:
    """Stand-in for RunOutput: history rows and where they are restored."""

    def __init__(self, out_dir):
        self.out_dir = Path(out_dir)
        self.comm = None
        self.history_rows = []
        self.restored = None

    def restore_history(self, rows):
        self.restored = rows


SETTINGS = {"mesh": {"refine": 1}, "materials": {"steel": {"E": 1.0, "nu": 0.3}}}


def fake_scene(settings, analysis="static"):
    """Stand-in for a Problem: what check_resume reads (its settings and analysis type)."""
    return SimpleNamespace(analysis=SimpleNamespace(type=analysis), to_dict=lambda: settings)


def _state(i):
    keys = np.array([7, 3, 11], dtype=np.int64)
    return dict(u=Keyed(np.arange(6.0).reshape(3, 2) + i, keys), t=0.5 * i, rows=[1, 2.5, "x"])


def test_save_prune_and_load(tmp_path):
    out = _Out(tmp_path)
    c = Checkpointer(tmp_path, None, SETTINGS, "static", every=1, output=out)
    for i in (1, 2, 3):
        out.history_rows.append(dict(step=i, f=0.1 * i))
        c.save(i, solver=_state(i), loop=dict(dl=0.25))
    names = sorted(p.name for p in (tmp_path / "checkpoint").iterdir())
    assert names == ["ckpt_000000002.json", "ckpt_000000002.rank0.npz", "ckpt_000000003.json",
                     "ckpt_000000003.rank0.npz"]
    r = Checkpointer(tmp_path, None, SETTINGS, "static", resume=True, output=out)
    st = r.load()
    assert st["counter"] == 3 and st["solver"]["t"] == 1.5
    assert st["solver"]["rows"] == [1, 2.5, "x"] and st["loop"] == {"dl": 0.25}
    # rows come back by key, in the order asked for
    np.testing.assert_array_equal(st["solver"]["u"].take([11, 7]), [[7.0, 8.0], [3.0, 4.0]])
    with pytest.raises(CheckpointError, match="no values for 1 of"):
        st["solver"]["u"].take([7, 5])
    assert out.restored == [dict(step=i, f=0.1 * i) for i in (1, 2, 3)]
    assert r.summary()["resumed_from_checkpoint"] == 3
    # a corrupt rank file: the older complete checkpoint is used
    p = tmp_path / "checkpoint" / "ckpt_000000003.rank0.npz"
    p.write_bytes(p.read_bytes()[:-10])
    assert r.load()["counter"] == 2
    # a plain array is refused: it would be tied to this rank's partition
    with pytest.raises(TypeError, match="Keyed"):
        c.save(4, solver=dict(u=np.zeros(3)))


def test_fresh_run_clears_and_finished_run_not_resumable(tmp_path, monkeypatch):
    Checkpointer(tmp_path, None, SETTINGS, "static", every=1).save(1, solver=_state(1))
    Checkpointer(tmp_path, None, SETTINGS, "static", every=1)      # a new run in the same place
    assert list((tmp_path / "checkpoint").iterdir()) == []
    scene = fake_scene(SETTINGS)
    with pytest.raises(CheckpointError, match="no complete checkpoint"):
        ck.check_resume(tmp_path, scene, 1)
    (tmp_path / "summary.json").write_text("{}")
    shutil.rmtree(tmp_path / "checkpoint")
    with pytest.raises(CheckpointError, match="has finished"):
        ck.check_resume(tmp_path, scene, 1)


def test_refusals(tmp_path):
    c = Checkpointer(tmp_path, None, SETTINGS, "static", every=1)
    c.save(5, solver=_state(5))
    scene = fake_scene(SETTINGS)
    assert ck.check_resume(tmp_path, scene, 1)["counter"] == 5
    with pytest.raises(CheckpointError, match=r"written by 1 MPI rank\(s\), this run has 2"):
        ck.check_resume(tmp_path, scene, 2)
    other = fake_scene({"mesh": {"refine": 2}, "materials": {"steel": {"E": 1.0, "nu": 0.3}}})
    with pytest.raises(CheckpointError, match=r"mesh.refine = 2 \(checkpoint: 1\)"):
        ck.check_resume(tmp_path, other, 1)
    # output keys that do not change the numbers may differ
    free = fake_scene(dict(SETTINGS, output={"xdmf": False, "checkpoint_every": 7}, scene={"description": "other"}))
    assert ck.check_resume(tmp_path, free, 1)["counter"] == 5
    # a checkpoint of another analysis type
    with pytest.raises(CheckpointError, match="of a 'static' analysis, the scene's is 'explicit'"):
        ck.check_resume(tmp_path, fake_scene(SETTINGS, "explicit"), 1)
    m = tmp_path / "checkpoint" / "ckpt_000000005.json"
    d = json.loads(m.read_text())
    d["format"] = ck.FORMAT + 1
    m.write_text(json.dumps(d))
    with pytest.raises(CheckpointError, match="another version of fenics-plast"):
        ck.check_resume(tmp_path, scene, 1)
    r = Checkpointer(tmp_path, None, SETTINGS, "static", resume=True)
    with pytest.raises(CheckpointError, match="format"):
        r.load()


def test_restore_history_drops_later_rows(tmp_path):
    from fenics_plast.output import RunOutput
    o = RunOutput(tmp_path)
    for i in range(4):
        o.history(step=i, x=np.float64(i / 3))
    saved = o.history_rows[:2]
    o.close_history()
    (tmp_path / "summary.json").write_text("{}")
    o2 = RunOutput(tmp_path, resume=True)          # an earlier summary.json goes at once
    assert not (tmp_path / "summary.json").exists()
    o2.restore_history(json.loads(json.dumps(saved)))
    o2.history(step=2, x=np.float64(2 / 3))
    o2.close_history()
    assert (tmp_path / "history.csv").read_text().splitlines() == [
        "step,x", "0,0.0", f"1,{1 / 3!r}", f"2,{2 / 3!r}"]


# ----------------------------------------------------------------------------------------------
# a changed problem (issue 21): the fingerprint of the mesh and of the files it is read from


def test_resume_refuses_an_edited_mesh_file_and_reports_a_corrupt_checkpoint(tmp_path):
    """The bar (tests/scenes/bar.toml) with its .geo copied beside it, killed after its 2nd checkpoint.
    The .geo edited (another radius), then edited in a comment only: each resume is refused (exit 2)
    saying what changed, and touches nothing. The .geo restored and the newest checkpoint's rank file
    corrupted: the run resumes from the older checkpoint, with a warning in the log and summary.json."""
    scene_dir = tmp_path / "scene"
    scene_dir.mkdir()
    geo = scene_dir / "round_bar.geo"
    shutil.copy(REPO / "meshes" / "round_bar.geo", geo)
    scene = scene_dir / "bar.toml"
    scene.write_text((REPO / "tests" / "scenes" / "bar.toml").read_text()
                     .replace('"../../meshes/round_bar.geo"', '"round_bar.geo"'))
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "fenics_plast.cli", "run", str(scene), "--set", "output.checkpoint_every=2"]
    env = dict(os.environ, FENICS_PLAST_PROGRESS="off")
    r = subprocess.run(cmd + ["--out", str(out)], capture_output=True, text=True, cwd=REPO, timeout=300,
                       env=dict(kill_env("after"), FENICS_PLAST_PROGRESS="off"))
    assert r.returncode == 137, r.stdout[-2000:] + r.stderr[-2000:]
    last = check_killed_dir(out, "after")
    assert set(last["fingerprint"]["files"]) == {"round_bar.geo"} and len(last["fingerprint"]["mesh"]) == 64
    original = geo.read_text()
    before = {p.name: p.read_bytes() for p in list(out.iterdir()) + list((out / "checkpoint").iterdir()) if p.is_file()}

    def resume():
        return subprocess.run(cmd + ["--resume", str(out)], capture_output=True, text=True, cwd=REPO, timeout=300,
                              env=env)
    geo.write_text(original.replace("R0 = R * (1 - imperfection);", "R0 = 0.9 * R * (1 - imperfection);"))
    r = resume()
    assert r.returncode == 2, r.stdout[-2000:] + r.stderr[-2000:]
    assert "the problem changed since the checkpoint was written" in r.stderr
    assert "the mesh file round_bar.geo was edited" in r.stderr and "the mesh differs" in r.stderr
    geo.write_text(original + "// a comment\n")        # the same mesh, another file: refused all the same
    r = resume()
    assert r.returncode == 2 and "was edited" in r.stderr and "the mesh differs" not in r.stderr, r.stderr
    after = {p.name: p.read_bytes() for p in list(out.iterdir()) + list((out / "checkpoint").iterdir()) if p.is_file()}
    assert after == before                              # refused resumes touch nothing
    geo.write_text(original)
    newest = sorted((out / "checkpoint").glob("ckpt_*.rank0.npz"))[-1]
    newest.write_bytes(newest.read_bytes()[:-10])
    r = resume()
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    assert (f"warning: {out / 'checkpoint'}: the newest checkpoint could not be used (checkpoint {last['counter']}"
            in r.stderr)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["resumed_from_checkpoint"] < last["counter"]
    assert any(f"checkpoint {last['counter']}: {newest.name} does not match its manifest" in w
               for w in summary["warnings"])


def test_corrupt_newest_manifest_is_reported(tmp_path):
    out = _Out(tmp_path)
    c = Checkpointer(tmp_path, None, SETTINGS, "static", every=1, output=out)
    for i in (1, 2):
        c.save(i, solver=_state(i))
    (tmp_path / "checkpoint" / "ckpt_000000002.json").write_text("{not json")
    r = Checkpointer(tmp_path, None, SETTINGS, "static", resume=True, output=out)
    assert r.load()["counter"] == 1
    assert r.warnings == [f"{tmp_path / 'checkpoint'}: the newest checkpoint could not be used (checkpoint 2: its "
                          f"manifest ckpt_000000002.json cannot be read): resumed from the older checkpoint 1"]
    r2 = Checkpointer(tmp_path, None, SETTINGS, "static", resume=True, output=out)
    (tmp_path / "checkpoint" / "ckpt_000000002.json").unlink()
    r2.load()
    assert r2.warnings == []                            # no warning when the newest one is fine


def test_check_fingerprint_messages():
    then = {"mesh": "a" * 64, "files": {"/s/m.geo": "1" * 64, "/s/part.geo": "2" * 64}}
    ck.check_fingerprint("out", {"fingerprint": then}, dict(then))
    ck.check_fingerprint("out", {}, then)                # a manifest without one: nothing to compare
    now = {"mesh": "b" * 64, "files": {"/s/m.geo": "3" * 64, "/s/new.geo": "4" * 64}}
    with pytest.raises(CheckpointError) as e:
        ck.check_fingerprint("out", {"fingerprint": then}, now)
    msg = str(e.value)
    assert msg.startswith("out: the problem changed since the checkpoint was written: ")
    for part in ("the mesh file /s/m.geo was edited", "the mesh is read from /s/new.geo now, not then",
                 "the mesh was read from /s/part.geo then, not now", "the mesh differs (node coordinates or cells)"):
        assert part in msg


@needs_mpirun
def test_mesh_fingerprint_does_not_depend_on_the_partition(tmp_path):
    a, b = serial_and_two_ranks(REPO / "tests" / "mpi_mesh_fingerprint.py", [], tmp_path)
    assert int(a["ranks"]) == 1 and int(b["ranks"]) == 2 and int(b["same_on_all_ranks"]) == 1
    assert list(a["digests"]) == list(b["digests"]) and len(set(a["digests"])) == 3


def test_a_moved_project_folder_resumes(tmp_path):
    """A project folder (scene, its own .geo, the killed run's results) moved elsewhere resumes: the
    fingerprint names the mesh files relative to the scene's folder (it held absolute paths, and the
    resume was refused as "the mesh was read from ... then, not now")."""
    first = tmp_path / "project"
    first.mkdir()
    shutil.copy(REPO / "meshes" / "round_bar.geo", first / "round_bar.geo")
    text = (REPO / "demos" / "bar_tension.toml").read_text().replace('"../meshes/round_bar.geo"', '"round_bar.geo"')
    (first / "bar.toml").write_text(text)
    _, sets, point, _ = SCENES["bar"]
    cmd = [sys.executable, "-m", "fenics_plast.cli", "run", str(first / "bar.toml"), *sets, *COMMON,
           "--out", str(first / "out")]
    r = subprocess.run(cmd, capture_output=True, text=True, cwd=REPO, timeout=300, env=kill_env(point))
    assert r.returncode == 137, r.stderr[-2000:]
    manifest = json.loads(sorted((first / "out" / "checkpoint").glob("ckpt_*.json"))[-1].read_text())
    assert list(manifest["fingerprint"]["files"]) == ["round_bar.geo"]
    moved = tmp_path / "elsewhere" / "project"
    moved.parent.mkdir()
    first.rename(moved)
    r = subprocess.run([sys.executable, "-m", "fenics_plast.cli", "run", str(moved / "bar.toml"), *sets, *COMMON,
                        "--resume", str(moved / "out")], capture_output=True, text=True, cwd=REPO, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    assert json.loads((moved / "out" / "summary.json").read_text())["resumed_from_checkpoint"] == manifest["counter"]
