"""Initial velocities per region and as expressions of position (explicit analyses).

On the copper-steel bar of tests/scenes/two_region_impact.toml (region "lower" 0 <= z <= 4 mm,
"upper" 4 <= z <= 10 mm, axisymmetric): the lower region starts at -100 m/s, the upper one at a
velocity that grows with z, v_z = -(100 + 10 z) m/s. Nodes inside a region take its value; nodes on
the interface z = 4 take the last table's (the upper's). Serial and 2 ranks give the same run.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from fenics_plast.problem import load_problem
from fenics_plast.runner_explicit import build_explicit

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "tests" / "scenes" / "two_region_impact.toml"
SETS = ['initial_velocity.bar.value=[0.0, -100.0]', 'initial_velocity.bar.regions=["lower"]',
        'initial_velocity.top.value=[0.0, "-(100 + 10 * y)"]', 'initial_velocity.top.regions=["upper"]']


def test_region_and_expression_velocities_at_the_nodes():
    b = build_explicit(load_problem(SCENE, SETS), MPI.COMM_SELF)
    s = b.solver
    X = s.V.tabulate_dof_coordinates()
    v = s.v.x.array.reshape(-1, 2)
    # the wall holds v_z = 0 at z = 0
    lower, upper = (X[:, 1] > 1e-9) & (X[:, 1] < 4.0 - 1e-9), X[:, 1] > 4.0 - 1e-9
    assert lower.sum() > 10 and upper.sum() > 10
    free_r = X[:, 0] > 1e-9                                  # the axis holds v_r = 0 anyway
    assert np.all(v[free_r, 0] == 0.0)
    assert np.allclose(v[lower, 1], -100.0e3, rtol=1e-15)                        # m/s -> mm/s
    assert np.allclose(v[upper, 1], -(100.0 + 10.0 * X[upper, 1]) * 1e3, rtol=1e-14)


def test_serial_equals_two_ranks(tmp_path):
    env = dict(os.environ, FENICS_PLAST_PROGRESS="off", OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    out = {}
    for n in (1, 2):
        cmd = [sys.executable, "-m", "fenics_plast.cli", "run", str(SCENE), "--out", str(tmp_path / f"r{n}"),
               "--set", "analysis.end_time=1.0"]
        for s in SETS:
            cmd += ["--set", s]
        if n > 1:
            cmd = ["mpirun", "-n", "2", "--oversubscribe"] + cmd
        p = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, env=env, timeout=600)
        assert p.returncode == 0, p.stderr[-2000:]
        out[n] = json.loads((tmp_path / f"r{n}" / "summary.json").read_text())
    for k in out[1]["key_results"] + out[1]["info_results"]:
        if isinstance(out[1].get(k), float):
            assert out[2][k] == pytest.approx(out[1][k], rel=1e-9, abs=1e-12), k
