"""Running a scene file through the CLI in a test: one helper for every test that needs a whole run.

``run_scene(scene, out, *sets, np_ranks=1)`` runs ``fenics-plast run SCENE --out OUT --set ...`` (under
``mpirun -n np_ranks`` when > 1; progress off; allowed as root), asserts exit 0 with the output's tail
in the message, and returns summary.json as a dict; ``history(out)`` reads history.csv as a numpy
structured array (columns by name). ``serial_and_two_ranks(script, args, tmp_path)`` runs a helper
script ``script OUT.npz ARGS...`` serially and under ``mpirun -n 2`` and returns both .npz files
(``needs_mpirun``: the skip marker of such tests).
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

ROOT = Path(__file__).resolve().parent.parent
FP = [sys.executable, "-m", "fenics_plast.cli"]


def run_scene(scene, out, *sets, np_ranks=1, timeout=900) -> dict:
    cmd = FP + ["run", str(scene), "--out", str(out)]
    for s in sets:
        cmd += ["--set", s]
    if np_ranks > 1:
        cmd = ["mpirun", "-n", str(np_ranks), "--oversubscribe"] + cmd
    env = dict(os.environ, FENICS_PLAST_PROGRESS="off", OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    p = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=ROOT, timeout=timeout)
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-2000:]
    return json.loads((Path(out) / "summary.json").read_text())


def history(out) -> np.ndarray:
    return np.genfromtxt(Path(out) / "history.csv", delimiter=",", names=True)


MPIRUN = "/usr/bin/mpirun" if Path("/usr/bin/mpirun").exists() else shutil.which("mpirun")
#: a test that starts its own mpirun: serial pytest only, and mpirun installed
needs_mpirun = pytest.mark.skipif(MPI.COMM_WORLD.size > 1 or MPIRUN is None,
                                  reason="starts its own mpirun (serial pytest, mpirun installed)")


def serial_and_two_ranks(script, args, tmp_path, timeout=300):
    """``python SCRIPT OUT.npz ARGS...`` serially and under ``mpirun -n 2`` (in a clean environment:
    this process is an MPI singleton whose OMPI_/PMIX_ variables confuse mpirun); asserts exit 0 for
    both and returns their .npz files (serial, two ranks)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_", "OPAL_"))}
    out = []
    for name, launch in (("serial", [sys.executable]),
                         ("mpi", [MPIRUN, "--allow-run-as-root", "--oversubscribe", "-n", "2", sys.executable])):
        npz = Path(tmp_path) / f"{name}.npz"
        p = subprocess.run([*launch, str(script), str(npz), *map(str, args)], cwd=ROOT, timeout=timeout, env=env,
                           capture_output=True, text=True)
        assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
        out.append(np.load(npz))
    return tuple(out)
