"""The run's PNG plots drawn by a child process that imports matplotlib while the run computes.

matplotlib's import and first figure cost ~0.5 s, as much as a small 2-D scene's whole solve; a
:class:`PlotWorker` started with the run (rank 0) pays it on the other core, then waits on its standard
input. :meth:`PlotWorker.draw` sends it the folder and the scene's settings once the CSV files are
complete, and returns when the PNGs are written (the run ends after its plots, as before: nothing is
left running). The figures are :func:`fenics_plast.plots.draw_declared`'s, the same as in process and
as ``fenics-plast plot DIR``; the worker, which runs no MPI or PETSc, draws them in forked processes, one
per available core and one more (the run waits idle meanwhile; the default Taylor bar's three figures on
2 cores: 0.55 s in one process, 0.43 s in two, 0.35 s in three after a warm-up figure of each kind). If
the run stops early the worker sees its input close and exits without drawing.

Protocol: one JSON line on stdin, ``{"out_dir", "settings", "title", "references"}``; one JSON line
on stdout, ``{"paths": [...]}`` or ``{"error": "..."}``. Standard library, numpy and matplotlib only.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys


def _ignore_sigpipe() -> None:
    """Writing to a worker that has just died raises SIGPIPE, which PETSc's signal handler (installed when
    petsc4py starts) turns into an abort of the run. Ignore it, as Python itself does by default: the write
    then fails with EPIPE, which ``communicate`` absorbs, and :meth:`PlotWorker.draw` reports the worker lost."""
    import signal
    import threading
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGPIPE, signal.SIG_IGN)


class WorkerLost(RuntimeError):
    """The worker ended without answering (killed, or it could not start): draw in process instead."""


class PlotWorker:
    """A child Python process ready to draw one folder's plots."""

    def __init__(self):
        self.proc = subprocess.Popen([sys.executable, "-m", "fenics_plast.plot_worker"], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)

    def draw(self, out_dir, settings, title, references) -> list[str]:
        """Draw the declared figures of ``out_dir`` (the arguments of
        :func:`~fenics_plast.plots.draw_declared`); returns the PNG paths. Raises RuntimeError with the
        worker's message when a figure could not be drawn, :class:`WorkerLost` when the worker did not answer."""
        job = json.dumps(dict(out_dir=str(out_dir), settings=settings, title=title, references=references))
        if self.proc.poll() is not None:
            raise WorkerLost(f"the plot process ended early with status {self.proc.returncode}")
        _ignore_sigpipe()
        out, err = self.proc.communicate(job + "\n")
        lines = [line for line in out.splitlines() if line.startswith("{")]
        if not lines:
            raise WorkerLost(f"the plot process ended with status {self.proc.returncode}: {err.strip()[-500:]}")
        reply = json.loads(lines[-1])
        if "error" in reply:
            raise RuntimeError(reply["error"])
        return reply["paths"]

    def close(self) -> None:
        """Let the worker go without drawing (its input closes; it exits)."""
        if self.proc.poll() is None:
            try:
                self.proc.communicate("", timeout=10)
            except (subprocess.TimeoutExpired, OSError, ValueError):
                self.proc.kill()
                self.proc.wait()


def main() -> int:
    from fenics_plast import plots
    plots.preload()
    line = sys.stdin.readline()
    if not line.strip():
        return 0                # the run stopped before its plots
    job = json.loads(line)
    try:
        paths = plots.draw_declared(job["out_dir"], job["settings"], title=job["title"],
                                    references=job["references"], processes=len(os.sched_getaffinity(0)) + 1)
        reply = {"paths": [str(p) for p in paths]}
    except Exception as e:  # noqa: BLE001 - reported to the run, which logs it
        reply = {"error": f"{type(e).__name__}: {e}"}
    print(json.dumps(reply), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
