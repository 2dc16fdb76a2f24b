"""Executing the runs of a study: one process per run, each a ``fenics-plast run``.

* :class:`Run`: one combination of ``--vary`` values and what became of it (status, reason,
  summary.json);
* :func:`run_command`: the command line of one run (under ``mpirun -n N`` with ``--np N``);
* :func:`execute`: run it as a subprocess in its own session (killed as a group at ``--timeout``
  or Ctrl-C), or reuse a finished run (``--reuse``), then read its summary.json;
* :func:`prevalidate`: the scene validator's message for an invalid combination (no process).

A run that fails (exit status 1: summary.json has ``error``; 2: invalid combination; a crash, a
signal or the timeout) is not an exception: its :class:`Run` gets status ``failed``, ``invalid``
or ``timeout`` and a one-line reason, and the study goes on.
"""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

from ..checkpoint import DIRNAME, remove_own
from ..out_files import LinkRefused, make_dir, open_write, remove_file, write_atomic
from ..output import OutputDirError, mark_results_folder, remove_listed, results_folder_scene


@dataclass
class Run:
    """One combination and what became of it."""
    name: str
    label: str
    settings: dict[str, str]
    status: str = "pending"              # ok | failed | invalid | timeout
    reason: str = ""
    summary: dict = field(default_factory=dict)
    process_time_s: float | None = None
    returncode: int | None = None
    reused: bool = False

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def value(self, key: str) -> Any:
        """A summary.json value of the run (``process_time_s``: measured by the study)."""
        if key == "process_time_s":
            return self.process_time_s
        return self.summary.get(key)


def _tail(text: str, n: int = 400) -> str:
    text = " ".join(text.strip().split())
    return text if len(text) <= n else "..." + text[-n:]


def _error_line(output: str) -> str | None:
    lines = [ln.strip() for ln in output.splitlines() if ln.strip().startswith("error: ")]
    return lines[-1][len("error: "):] if lines else None


def run_command(scene: Path, sets: Sequence[str], out_dir: Path, np_ranks: int = 1,
                python: str = sys.executable, trust_mesh_script: bool = False) -> list[str]:
    """The command line of one run (a list for subprocess)."""
    cmd = [python, "-m", "fenics_plast.cli", "run", str(scene), "--out", str(out_dir)]
    if trust_mesh_script:
        cmd.append("--trust-mesh-script")
    for s in sets:
        cmd += ["--set", s]
    if np_ranks > 1:
        mpirun = shutil.which("mpirun") or "/usr/bin/mpirun"
        pre = [mpirun, "--allow-run-as-root", "-n", str(np_ranks)]
        if np_ranks > (os.cpu_count() or 1):
            pre.append("--oversubscribe")
        cmd = pre + cmd
    return cmd


def execute(run: Run, scene: Path, sets: list[str], run_dir: Path, np_ranks: int = 1,
            timeout: float | None = None, reuse: bool = False, trust_mesh_script: bool = False,
            root: Path | None = None) -> Run:
    """Run one combination as a subprocess (or reuse a finished one) and fill ``run``.

    ``run_dir`` gets run.log (the process's output), summary.json (written by the run) and
    study_run.json (the command, exit status and times: what ``reuse`` reads back). An earlier run's
    folder is emptied of what the study and the run wrote there (nothing else, nothing through a link:
    a link at ``run_dir`` or in it is refused, :class:`~fenics_plast.out_files.LinkRefused`); ``root``:
    the study's folder (the folders below it are not followed through links)."""
    root = Path(root) if root is not None else run_dir.parent
    record_path = run_dir / "study_run.json"
    cmd = run_command(scene, sets, run_dir, np_ranks, trust_mesh_script=trust_mesh_script)
    if reuse and record_path.is_file():
        try:
            rec = json.loads(record_path.read_text())
        except (OSError, json.JSONDecodeError):
            rec = None
        if rec and rec.get("sets") == sets and rec.get("np") == np_ranks and rec.get("status") in (
                "ok", "failed", "invalid"):         # invalid: refused by the run itself (exit 2, e.g. its time step)
            _fill(run, rec["returncode"], rec.get("output_tail", ""), rec.get("process_time_s"), run_dir)
            run.reused = True
            return run
    if os.path.lexists(run_dir):
        if run_dir.is_symlink() or not run_dir.is_dir():
            raise LinkRefused(f"{run_dir}: is a symbolic link or not a folder: the study does not write or delete "
                              f"through it; remove it, or choose another --out")
        if any(run_dir.iterdir()) and not results_folder_scene(run_dir)[0]:
            raise OutputDirError(f"{run_dir}: is not a results folder of a study run (no marker): the study does "
                                 f"not delete it; remove it, or choose another --out")
        remove_listed(run_dir)              # the earlier run's files (the marker's list), nothing else
        for name in ("run.log", "study_run.json", "summary.json"):
            remove_file(run_dir / name, root=root)
        remove_own(run_dir / DIRNAME)
    else:
        make_dir(run_dir, root=root)
    mark_results_folder(run_dir, None)      # the run's folder (run.log goes in first): a results folder
    env = _run_environment(np_ranks)
    t0 = time.perf_counter()
    with open_write(run_dir / "run.log", root=root, encoding="utf-8") as log:
        proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=env, start_new_session=True)
        try:
            rc = proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            _kill(proc)
            rc = None
        except BaseException:            # Ctrl-C: do not leave the run behind
            _kill(proc)
            raise
    elapsed = time.perf_counter() - t0
    output = (run_dir / "run.log").read_text(encoding="utf-8", errors="replace")
    if rc is None:
        run.status, run.reason = "timeout", f"timed out after {timeout:g} s (--timeout)"
        run.process_time_s = elapsed
        remove_file(run_dir / "summary.json", root=root)     # not expected: the run was killed
    else:
        _fill(run, rc, output, elapsed, run_dir)
    record = dict(sets=sets, np=np_ranks, command=cmd, returncode=rc, status=run.status, reason=run.reason,
                  process_time_s=elapsed, output_tail=output[-4000:])
    write_atomic(record_path, json.dumps(record, indent=1), root=root, fsync=False)
    return run


def _run_environment(np_ranks: int) -> dict[str, str]:
    """The environment of a run: this process's, root allowed to run mpirun; under mpirun without the
    MPI variables of this process (``OMPI_*``, ``PMIX_*``, ``OPAL_*``: a process that initialised MPI as a
    singleton, ``run --accuracy`` or a test, has them, and mpirun started under them fails at once)."""
    env = dict(os.environ)
    if np_ranks > 1:
        env = {k: v for k, v in env.items() if not k.startswith(("OMPI_", "PMIX_", "OPAL_"))}
    return dict(env, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")


def _kill(proc: subprocess.Popen) -> None:
    """Stop the run's process group (its own session: only what this study started)."""
    for sig in (signal.SIGTERM, signal.SIGKILL):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            return
        try:
            proc.wait(timeout=10)
            return
        except subprocess.TimeoutExpired:
            continue


def _fill(run: Run, rc: int, output: str, elapsed: float | None, run_dir: Path) -> None:
    """Status, reason and summary of a finished process (exit status ``rc``, its ``output``)."""
    run.returncode, run.process_time_s = rc, elapsed
    summary_path = run_dir / "summary.json"
    if summary_path.is_file():
        try:
            run.summary = json.loads(summary_path.read_text())
        except (OSError, json.JSONDecodeError) as e:
            run.summary = {}
            run.status, run.reason = "failed", f"unreadable summary.json: {e}"
            return
    if rc == 0 and run.summary:
        run.status, run.reason = "ok", ""
        if not run.summary.get("converged", True):
            run.status, run.reason = "failed", "summary.json says converged: false"
    elif rc == 2:
        run.status = "invalid"
        run.reason = _error_line(output) or f"exit status 2: {_tail(output)}"
    else:
        run.status = "failed"
        if run.summary.get("error"):
            run.reason = str(run.summary["error"])
        elif rc is not None and rc < 0:
            run.reason = f"killed by signal {signal.Signals(-rc).name}: {_tail(output, 200)}"
        else:
            run.reason = _error_line(output) or f"exit status {rc}: {_tail(output)}"
            if rc == 0:
                run.reason = "exit status 0 but no summary.json"


def prevalidate(scene: Path, sets: list[str]) -> str | None:
    """The SceneError message of a combination, or None when it is a valid scene (no MPI, fast)."""
    from ..problem import SceneError, load_problem
    try:
        load_problem(scene, sets)
    except SceneError as e:
        return str(e)
    return None
