"""The lock of a results folder (fenics_plast/run_lock.py, issue 40): a process is the PID *and* its
start time, so a reused PID, a zombie or a lock of an earlier boot does not hold a folder; a lock
names every rank of an MPI run; a resumed run waits for the ranks of a killed run that are still
exiting, and says so, instead of refusing at once."""
from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import threading
import time

import pytest

from fenics_plast.output import LOCK, OutputDirError
from fenics_plast.run_lock import RunLock, process_running, this_process


def _sleeper(seconds=60):
    return subprocess.Popen([sys.executable, "-c", f"import time; time.sleep({seconds})"])


def _start(pid):
    with open(f"/proc/{pid}/stat") as f:
        text = f.read()
    return text[text.rindex(")") + 2:].split()[19]


def _write_lock(folder, processes, **extra):
    lock = {"pid": processes[0][0], "host": socket.gethostname(), "processes": [list(p) for p in processes]}
    lock.update(extra)
    (folder / LOCK).write_text(json.dumps(lock))


def test_a_process_is_its_pid_and_start_time():
    pid, start = this_process()
    assert pid == os.getpid() and start == _start(pid)
    assert process_running(pid, start) and process_running(pid)
    assert not process_running(pid, str(int(start) + 1))        # the same PID, another process


def test_a_zombie_does_not_run():
    child = subprocess.Popen(["true"])
    for _ in range(200):                                       # ended, not reaped: a zombie
        with open(f"/proc/{child.pid}/stat") as f:
            if f.read().rsplit(")", 1)[1].split()[0] == "Z":
                break
        time.sleep(0.01)
    else:
        pytest.fail("the child did not become a zombie")
    try:
        assert not process_running(child.pid)
        os.kill(child.pid, 0)                                  # what the old check asked: it still "exists"
    finally:
        child.wait()


def test_a_reused_pid_does_not_hold_the_folder(tmp_path):
    """A lock whose PID now belongs to another running process (PIDs wrap at pid_max) is stale: the old
    lock (PID and host only) took that process for the holder and refused the run."""
    other = _sleeper()
    try:
        _write_lock(tmp_path, [(other.pid, str(int(_start(other.pid)) - 1))])
        lock = RunLock.acquire(tmp_path)
        assert "was left by a run that has ended" in lock.warning and f"PID {other.pid}" in lock.warning
        lock.release()
    finally:
        other.kill()
        other.wait()


def test_a_lock_of_an_earlier_boot_is_stale(tmp_path):
    _write_lock(tmp_path, [this_process()], boot_id="not-this-boot")
    lock = RunLock.acquire(tmp_path)
    assert "before a reboot" in lock.warning
    lock.release()


def test_every_rank_of_the_holder_counts(tmp_path):
    """Rank 0 of the killed run has ended, rank 1 still runs: the folder is held."""
    rank1 = _sleeper()
    try:
        dead = subprocess.Popen(["true"])
        dead.wait()
        _write_lock(tmp_path, [(dead.pid, None), (rank1.pid, _start(rank1.pid))])
        with pytest.raises(OutputDirError, match=f"PIDs {dead.pid}, {rank1.pid} on this host"):
            RunLock.acquire(tmp_path)
    finally:
        rank1.kill()
        rank1.wait()
    lock = RunLock.acquire(tmp_path)
    assert "has ended" in lock.warning
    lock.release()


def test_waiting_for_the_holder_to_end(tmp_path):
    """With wait_s (a resumed run), the lock is taken once the holder's processes end, after one line
    saying what it waits for; without, it is refused at once."""
    holder = _sleeper(1.5)
    _write_lock(tmp_path, [(holder.pid, _start(holder.pid))])
    reaper = threading.Thread(target=holder.wait)
    reaper.start()
    t0 = time.monotonic()
    with pytest.raises(OutputDirError, match="another run holds the folder"):
        RunLock.acquire(tmp_path)
    assert time.monotonic() - t0 < 1.0
    said = []
    lock = RunLock.acquire(tmp_path, wait_s=20, say=said.append)
    waited = time.monotonic() - t0
    reaper.join()
    assert 0.5 < waited < 15, waited
    assert len(said) == 1 and f"waiting up to 20 s for the run that holds the folder (PID {holder.pid}" in said[0]
    assert json.loads((tmp_path / LOCK).read_text())["processes"] == [list(this_process())]
    lock.release()


def test_waiting_ends_in_a_refusal(tmp_path):
    holder = _sleeper()
    try:
        _write_lock(tmp_path, [(holder.pid, _start(holder.pid))])
        t0 = time.monotonic()
        with pytest.raises(OutputDirError, match=f"PID {holder.pid} on this host"):
            RunLock.acquire(tmp_path, wait_s=0.5)
        assert 0.4 < time.monotonic() - t0 < 5
        assert json.loads((tmp_path / LOCK).read_text())["pid"] == holder.pid      # left as it was
    finally:
        holder.kill()
        holder.wait()


def test_a_link_at_the_locks_temporary_name_is_not_written_through(tmp_path):
    outside = tmp_path / "outside.txt"
    outside.write_text("the user's")
    folder = tmp_path / "out"
    folder.mkdir()
    (folder / f"{LOCK}.tmp{os.getpid()}").symlink_to(outside)
    lock = RunLock.acquire(folder)
    assert outside.read_text() == "the user's" and json.loads((folder / LOCK).read_text())["pid"] == os.getpid()
    assert not (folder / f"{LOCK}.tmp{os.getpid()}").exists()
    lock.release()
