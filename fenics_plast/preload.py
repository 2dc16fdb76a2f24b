"""Start-up work of ``fenics-plast run`` out of the way: Gmsh's library loads in a background thread while
the run imports the dolfinx stack, and a run without mpirun starts MPI without probing for networks.

``import gmsh`` costs ~0.5 s, nearly all of it the dynamic loading of libgmsh and the libraries it needs
(OpenCASCADE among them). The dynamic loader runs with Python's GIL released (ctypes), so a thread that
loads the library as ``fenics-plast run`` starts overlaps it with the imports of numpy, numba, UFL,
petsc4py and dolfinx, which hold the GIL. When :mod:`fenics_plast.meshing` then imports ``gmsh``, its own
``CDLL`` finds the library loaded (the loader returns the same handle, or waits for the thread if it is
still loading). Measured (2-core machine, medians of 5 interleaved runs): the 2-D punch's process 4.56 ->
4.18 s, the default Taylor bar's 5.42 -> 4.86 s.

Nothing here changes what is loaded: the library is the one ``gmsh.py`` itself loads (``libgmsh.so``
beside ``gmsh.py``, else the one ``ctypes.util.find_library`` finds), and a failure here is silent
(``import gmsh`` reports it as before).

MPI: a run started without a launcher is a single MPI process (a singleton). OpenMPI's default
point-to-point layer probes for network transports (UCX) to reach peers a singleton does not have:
``from mpi4py import MPI`` takes 0.40 s, 0.19 s with OpenMPI's own layer (ob1, shared memory and self),
measured here. :func:`single_process_mpi` chooses ob1 for such a run, unless the user chose a layer.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import importlib.util
import os
import threading

#: environment variables that a launcher (mpirun, mpiexec, srun) sets in the processes it starts
LAUNCHED = ("OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE", "SLURM_PROCID")


def _gmsh_library() -> str | None:
    """The path gmsh.py loads, or None without Gmsh."""
    spec = importlib.util.find_spec("gmsh")
    if spec is None or not spec.origin:
        return None
    beside = os.path.join(os.path.dirname(os.path.realpath(spec.origin)), "libgmsh.so")
    return beside if os.path.exists(beside) else ctypes.util.find_library("gmsh")


def _load() -> None:
    try:
        path = _gmsh_library()
        if path:
            ctypes.CDLL(path)
    except (OSError, ImportError, ValueError):
        pass        # import gmsh will say what is wrong


def start_gmsh() -> threading.Thread:
    """Start loading libgmsh in a daemon thread; returns it (nobody needs to join it)."""
    thread = threading.Thread(target=_load, name="preload-gmsh", daemon=True)
    thread.start()
    return thread


def single_process_mpi() -> None:
    """Before MPI starts: in a process no launcher started, OpenMPI's point-to-point layer ob1
    (``OMPI_MCA_pml``, unless already set; MPICH ignores it). Under mpirun nothing changes."""
    if not any(v in os.environ for v in LAUNCHED):
        os.environ.setdefault("OMPI_MCA_pml", "ob1")
