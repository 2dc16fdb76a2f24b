"""Gmsh in a child process: Gmsh dying (a signal, an abort, running out of memory) ends the child, not
the run, and becomes a :class:`MeshError` naming the file.

:func:`in_child` forks the calling process (rank 0 only; the child uses no MPI and leaves with
``os._exit``), caps the child's address space (what the run already maps plus
:data:`CHILD_MEMORY_SHARE` of the machine's memory, :func:`machine_memory`) and returns what the
function it runs there returns (pickled through a pipe). The body mesh (:mod:`fenics_plast.meshing`)
and the size estimates (:mod:`fenics_plast.mesh_size`) run Gmsh this way. Measured: +25 ms for a
small scene's meshing (9 -> 23 ms in-process, the estimate 10 ms).
"""
from __future__ import annotations

import os
import tempfile

__all__ = ["MeshError", "in_child", "machine_memory", "CHILD_MEMORY_SHARE"]


class MeshError(ValueError):
    """A mesh file cannot be read or meshed, or names a parameter it does not define."""


def machine_memory() -> int | None:
    """The machine's physical memory [bytes] (os.sysconf), or None where it cannot be read."""
    try:
        return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


#: the memory Gmsh may take in its child process, beyond what the run's process already maps: this share
#: of the machine's memory (:func:`in_child`)
CHILD_MEMORY_SHARE = 0.75


def _mapped_bytes() -> int:
    """The address space this process maps now [bytes] (/proc/self/statm; 0 where it cannot be read)."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


def _memory_cap() -> int | None:
    """The address-space limit of the Gmsh child [bytes]: what is mapped now plus
    :data:`CHILD_MEMORY_SHARE` of the machine's memory (None: no limit)."""
    memory = machine_memory()
    if not memory:
        return None
    return _mapped_bytes() + int(CHILD_MEMORY_SHARE * memory)


def _reached(cap: int | None) -> bool:
    """Whether this process's peak address space (/proc/self/status VmPeak) came within half of ``cap``
    [bytes]: an allocation that failed then failed for the cap (the allocations that fail grow by
    doubling, so none asks for more than what is mapped)."""
    if cap is None:
        return False
    try:
        with open("/proc/self/status") as f:
            peak = next(int(line.split()[1]) * 1024 for line in f if line.startswith("VmPeak:"))
    except (OSError, ValueError, IndexError, StopIteration):
        return False
    return peak > 0.5 * cap


def in_child(what: str, fn, *args):
    """``fn(*args)`` run in a forked child process whose address space is capped (:func:`_memory_cap`), so
    that Gmsh dying (a signal, an abort, running out of memory) ends the child, not the run; returns
    ``fn``'s (picklable) result. A :class:`MeshError` in the child is raised again here; any other
    exception, and the child dying, raise MeshError naming ``what`` (the file being meshed):
    "Gmsh died (signal 11, SIGSEGV) while meshing <what>", "Gmsh ran out of memory (...) while meshing
    <what>" (a signal with the memory near the cap, a MemoryError, or an error once the child's peak address
    space came within half of the cap: :func:`_reached`). Call it on one
    rank only (it uses no MPI); the child leaves with ``os._exit`` (no MPI, no atexit, no flush)."""
    import pickle
    import resource
    import signal
    import warnings
    cap = _memory_cap()
    err = tempfile.TemporaryFile()      # the child's stderr (what a dying Gmsh or C++ runtime says)
    r, w = os.pipe()
    with warnings.catch_warnings():     # (Python >= 3.12 warns of fork in a process with threads)
        warnings.simplefilter("ignore", DeprecationWarning)
        pid = os.fork()
    if pid == 0:                        # the child
        status = 0
        try:
            os.close(r)
            os.dup2(err.fileno(), 2)
            import faulthandler
            faulthandler.disable()      # (pytest's) and MPI's crash handlers: the parent reports the signal
            for sig in (signal.SIGSEGV, signal.SIGABRT, signal.SIGBUS, signal.SIGFPE, signal.SIGILL):
                signal.signal(sig, signal.SIG_DFL)
            if cap is not None:
                hard = resource.getrlimit(resource.RLIMIT_AS)[1]
                resource.setrlimit(resource.RLIMIT_AS, (cap if hard == resource.RLIM_INFINITY else
                                                        min(cap, hard), hard))
            try:
                out = ("ok", fn(*args))
            except MemoryError:
                out = ("memory", None)
            except BaseException as e:  # noqa: BLE001 - reported by the parent
                if _reached(cap):       # (Gmsh 4.13 turns a failed allocation into an empty error)
                    out = ("memory", None)
                elif isinstance(e, MeshError):
                    out = ("error", str(e))
                else:
                    out = ("error", f"Gmsh cannot mesh {what}: {type(e).__name__}: {e}")
            data = pickle.dumps(out)
            with os.fdopen(w, "wb") as f:
                f.write(data)
        except BaseException:           # noqa: BLE001 - the parent reports the child's status
            status = 70
        finally:
            os._exit(status)
    os.close(w)
    with os.fdopen(r, "rb") as f:
        data = f.read()
    while True:
        try:
            _, status, usage = os.wait4(pid, 0)
            break
        except InterruptedError:
            continue
    with err:
        err.seek(0)
        said = [line.strip() for line in err.read()[-4000:].decode("utf-8", "replace").splitlines() if line.strip()]
    limit = f"its limit {cap / 2**30:.3g} GiB of address space" if cap else "no limit set"
    peak = usage.ru_maxrss * 1024
    if data:
        kind, value = pickle.loads(data)
        if kind == "ok":
            return value
        if kind == "memory":
            raise MeshError(f"Gmsh ran out of memory ({limit}, it had taken {peak / 2**30:.3g} GiB) while "
                            f"meshing {what}: the mesh is too fine for this machine")
        raise MeshError(value)
    memory = machine_memory() or 0
    oom = (any("bad_alloc" in line or "emory" in line for line in said)
           or memory and peak > 0.5 * CHILD_MEMORY_SHARE * memory)
    last = f": {said[-1][:300]}" if said else ""
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        try:
            name = signal.Signals(sig).name
        except ValueError:
            name = "unknown signal"
        if oom:
            raise MeshError(f"Gmsh ran out of memory ({limit}, it had taken {peak / 2**30:.3g} GiB; it died of "
                            f"signal {sig}, {name}) while meshing {what}: the mesh is too fine for this machine")
        raise MeshError(f"Gmsh died (signal {sig}, {name}) while meshing {what}{last}")
    code = os.WEXITSTATUS(status) if os.WIFEXITED(status) else status
    raise MeshError(f"Gmsh ended (exit status {code}{', out of memory' if oom else ''}) while meshing {what} "
                    f"without a mesh (an Exit command in the file ends the process that reads it)")
