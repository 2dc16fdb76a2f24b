"""Running a scene file through the CLI in a test: one helper for every test that needs a whole run.

``run_scene(scene, out, *sets, np_ranks=1)`` runs ``fenics-plast run SCENE --out OUT --set ...`` (under
``mpirun -n np_ranks`` when > 1; progress off; allowed as root), asserts exit 0 with the output's tail
in the message, and returns summary.json as a dict; ``history(out)`` reads history.csv as a numpy
structured array (columns by name).
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

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
