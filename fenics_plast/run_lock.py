"""The lock of a results folder: one run (or study) writes into a folder at a time.

A run takes the lock :data:`fenics_plast.output.LOCK` (``DIR/.fenics-plast.lock``) before it writes
into its folder and removes it at the end. The lock is JSON: the host, the machine's boot id, and
every process of the run on that host (each MPI rank) as its PID and its start time
(``/proc/<pid>/stat`` field 22, clock ticks since boot), rank 0 first::

    {"pid": 4711, "host": "node1", "boot_id": "...", "processes": [[4711, "81234"], [4712, "81236"]]}

A lock is *held* while one of its processes still runs. A process is identified by its PID and its
start time, so a PID that the kernel has given to another process since (PIDs wrap at
``/proc/sys/kernel/pid_max``, 32768 on many machines, and threads use them too) does not hold the
lock, nor does a zombie (a killed rank that its parent has not reaped yet), nor anything after a
reboot (another boot id). A lock of another host cannot be checked and is held. A lock left by a
run that has ended is taken over with a warning.

A killed MPI run does not end at once: ``mpirun`` returns when one rank dies, while the others may
still be exiting. A resumed run therefore waits (``wait_s``, :data:`RESUME_WAIT_S`) for the ranks
of the run that holds the folder to end, saying so, before it refuses; a new run refuses at once.

Knows no physics; rank 0 takes and releases the lock (the CLI gathers every rank's process).
"""
from __future__ import annotations

import json
import os
import socket
import time
from pathlib import Path
from typing import Callable, Sequence

from .output import LOCK, OutputDirError, check_out_dir, make_out_dir, remove_created

__all__ = ["RunLock", "RESUME_WAIT_S", "this_process", "process_running", "take_results_folder"]

#: how long a resumed run waits for the processes of a killed run that still hold its folder [s]
RESUME_WAIT_S = 30.0
_POLL_S = 0.1


def _boot_id() -> str | None:
    try:
        return Path("/proc/sys/kernel/random/boot_id").read_text().strip() or None
    except OSError:
        return None


def _stat(pid: int) -> tuple[str, str] | None:
    """(state, start time) of process ``pid`` from /proc/<pid>/stat; None when it does not exist.
    Raises OSError where /proc cannot tell (not Linux)."""
    try:
        text = Path(f"/proc/{int(pid)}/stat").read_text()
    except (FileNotFoundError, ProcessLookupError):
        return None
    rest = text[text.rindex(")") + 2:].split()     # the command name, in (), may hold blanks
    return rest[0], rest[19]                        # fields 3 (state) and 22 (start time)


def this_process() -> tuple[int, str | None]:
    """(PID, start time) of the calling process."""
    try:
        st = _stat(os.getpid())
    except (OSError, ValueError, IndexError):
        st = None
    return os.getpid(), (st[1] if st else None)


def process_running(pid: int, started: str | None = None) -> bool:
    """Whether process ``pid`` runs (a zombie does not), and is the one that started at ``started``
    (/proc/<pid>/stat's start time; None: any process with that PID)."""
    try:
        st = _stat(pid)
    except (OSError, ValueError, IndexError):      # no /proc: the signal test only
        try:
            os.kill(int(pid), 0)
        except ProcessLookupError:
            return False
        except PermissionError:                    # another user's process
            return True
        except (OverflowError, ValueError):
            return False
        return True
    if st is None:
        return False
    state, start = st
    if state in ("Z", "X", "x"):                   # dead, waiting to be reaped
        return False
    return started is None or start == started


class RunLock:
    """The lock of a results folder, held by one run (rank 0) from start to end.

    :meth:`acquire` creates the lock atomically (written under a temporary name, then hard-linked to
    its name, which fails if it exists). A lock held by a running process of this host, or of
    another host (where that cannot be checked), is an :class:`~fenics_plast.output.OutputDirError`
    naming it, after waiting up to ``wait_s`` for the processes to end; a stale one (its processes
    have ended, or it is not a lock file at all) is taken over, with :attr:`warning` saying so.
    :meth:`release` removes it (only if it is still this run's)."""

    def __init__(self, path: Path, warning: str | None = None):
        self.path = path
        self.warning = warning
        self.released = False

    @classmethod
    def acquire(cls, out_dir, processes: Sequence[tuple[int, str | None]] | None = None, wait_s: float = 0.0,
                say: Callable[[str], None] | None = None) -> "RunLock":
        """Take the lock of ``out_dir`` for ``processes`` (this host's (PID, start time) of every rank of
        the run, rank 0 first; default: this process). ``wait_s``: how long to wait for a holder's
        processes to end; ``say`` gets one line when waiting starts."""
        path = Path(out_dir) / LOCK
        host = socket.gethostname()
        processes = [list(p) for p in (processes or [this_process()])]
        me = {"pid": processes[0][0], "host": host, "boot_id": _boot_id(), "processes": processes}
        tmp = path.with_name(f"{path.name}.tmp{os.getpid()}")
        deadline = time.monotonic() + max(float(wait_s), 0.0)
        warning, waited = None, False
        try:
            tmp.unlink(missing_ok=True)             # (a crashed run's, or a link: never written through)
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644)
            with os.fdopen(fd, "w", encoding="utf-8") as f:
                f.write(json.dumps(me) + "\n")
            takeovers = 0
            while True:
                try:
                    os.link(tmp, path)
                    return cls(path, warning)
                except FileExistsError:
                    pass
                try:
                    held = json.loads(path.read_text(encoding="utf-8"))
                except FileNotFoundError:
                    continue                        # released meanwhile: try again
                except (OSError, ValueError):
                    held = None
                holder = _holder(held, host)
                if holder is None:
                    stale = f"{path} is not a lock written by fenics-plast"
                elif holder["running"]:
                    if time.monotonic() < deadline:
                        if not waited and say is not None:
                            say(f"fenics-plast: {path.parent}: waiting up to {wait_s:g} s for the run that holds "
                                f"the folder ({holder['who']}) to end")
                        waited = True
                        time.sleep(_POLL_S)
                        continue
                    raise OutputDirError(f"{path.parent}: another run holds the folder: {holder['who']} ({path}); "
                                         + (f"if that run has ended, delete {path}" if holder["elsewhere"] else
                                            "wait for it to end, or choose another folder"))
                else:
                    stale = f"{path} was left by a run that has ended ({holder['who']}: no longer running)"
                takeovers += 1
                if takeovers > 3:
                    raise OutputDirError(f"{path.parent}: cannot take the lock {path}: other runs keep taking it")
                warning = f"warning: {stale}: taken over"
                path.unlink(missing_ok=True)
        except OSError as e:
            raise OutputDirError(f"{path.parent}: cannot create the lock {path}: {e.strerror or e}") from None
        finally:
            tmp.unlink(missing_ok=True)

    def release(self) -> None:
        if self.released:
            return
        self.released = True
        try:
            held = json.loads(self.path.read_text(encoding="utf-8"))
            if int(held.get("pid", -1)) == os.getpid():
                self.path.unlink()
        except (OSError, ValueError, TypeError, AttributeError):
            pass


def _holder(held, host: str) -> dict | None:
    """What a lock's JSON says of its holder: {"who": words, "running": bool, "elsewhere": bool}; None
    for a file that is not a lock (unreadable, not JSON, no PID)."""
    try:
        pid, where = int(held["pid"]), str(held["host"])
        processes = [(int(p), None if s is None else str(s)) for p, s in held.get("processes") or [(pid, None)]]
    except (KeyError, TypeError, ValueError):
        return None
    pids = ", ".join(str(p) for p, _ in processes)
    who = f"PID{'s' if len(processes) > 1 else ''} {pids} on " + ("this host" if where == host else f"host {where}")
    if where != host:
        return {"who": who, "running": True, "elsewhere": True}
    boot = held.get("boot_id")
    if boot is not None and _boot_id() is not None and boot != _boot_id():
        return {"who": who + " before a reboot", "running": False, "elsewhere": False}
    return {"who": who, "running": any(process_running(p, s) for p, s in processes), "elsewhere": False}


def take_results_folder(out: Path, scene: str, kind: str, names: Sequence[str], overwrite: bool = False,
                        log: Callable[[str], None] = print) -> RunLock:
    """The results folder ``out`` of a study or an accuracy request (``kind``) checked
    (:func:`fenics_plast.output.check_out_dir`, ``names``: the files it writes), created, and locked (one
    writer per folder; a lock left by a killed process is taken over, ``log``-ged). OutputDirError,
    with nothing left behind, when any of that is refused."""
    check_out_dir(out, scene, overwrite=overwrite, kind=kind, names=names)
    created = make_out_dir(out)
    try:
        lock = RunLock.acquire(out)
    except OutputDirError:
        remove_created(created)
        raise
    if lock.warning:
        log(lock.warning)
    return lock
