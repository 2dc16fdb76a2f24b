"""Penalty contact that cannot be trusted is reported (issue 21, item 6).

A pair whose largest penetration exceeds 5 % of the depth of the cells along its group warns in the
log and in summary.json ("warnings", ``<pair>_penetration_per_cell_depth``), in static and explicit
runs; a static failure names a penalty far from its pair's default as the likely cause, and a failed
material update names the cell (input numbering) and where it is. The scenes are the shipped ones:
the punch (default penalty 4.14e4 N/mm^3: 0.3 E / h with h = 0.5 mm) and the Taylor bar against a
contact wall (20 µs of it).
"""
from __future__ import annotations

import json
import os
import subprocess

import pytest

from scene_runs import FP, ROOT, run_scene

PUNCH = ROOT / "demos" / "punch_stretching.toml"
WALL = ROOT / "demos" / "taylor_bar_wall.toml"
PUNCH_DEFAULT = 0.3 * 69e3 / 0.5          # the punch pairs' default penalty [N/mm^3]


def test_default_penalty_is_trusted(tmp_path):
    s = run_scene(PUNCH, tmp_path / "ok", "output.xdmf=false", "output.plots=false")
    assert "warnings" not in s
    assert 0.0 < s["punch_penetration_per_cell_depth"] < 0.05
    assert 0.0 < s["die_penetration_per_cell_depth"] < 0.05


@pytest.mark.parametrize("factor", [1e-3, 1e-9])
def test_soft_penalty_warns(tmp_path, factor):
    """1e-3 of the default: the punch sinks 1 mm (the whole sheet's thickness) into the sheet; 1e-9:
    40 mm at a force of ~1 N. Both converge, and both are reported."""
    s = run_scene(PUNCH, tmp_path / "soft", f"contact.*.penalty={factor * PUNCH_DEFAULT!r}",
                  "output.xdmf=false", "output.plots=false")
    assert s["converged"]
    assert s["punch_penetration_per_cell_depth"] > 1.0
    punch = [w for w in s["warnings"] if w.startswith("contact.punch:")]
    assert len(punch) == 1 and "too soft" in punch[0] and "default is 4.14e+04" in punch[0]


def test_soft_penalty_warns_in_explicit_runs(tmp_path):
    env = dict(os.environ, FENICS_PLAST_PROGRESS="off")
    p = subprocess.run([*FP, "run", str(WALL), "--out", str(tmp_path / "w"), "--set", "contact.*.penalty=100",
                        "--set", "analysis.end_time=20", "--set", "output.xdmf=false", "--set", "output.plots=false"],
                       cwd=ROOT, capture_output=True, text=True, env=env, timeout=600)
    assert p.returncode == 0, p.stderr[-2000:]
    assert "warning: contact.face: the largest penetration" in p.stderr
    s = json.loads((tmp_path / "w" / "summary.json").read_text())
    assert s["face_penetration_per_cell_depth"] > 0.05 and s["warnings"][0].startswith("contact.face:")


def test_stiff_penalty_failure_names_it(tmp_path):
    """1e11 x the default: the run fails and its message names the penalty as a possible cause, with how deep
    the nodes would be at the default. Where Newton
    ends on an inverted cell the message names the cell and its place (before: 'material update returned
    non-finite stress/tangent (min det Fu = nan)'); which of an inverted cell or a residual that no longer
    converges comes first at such a penalty depends on round-off (the development machine: the cell; fresh
    Debian 12 and 13 roots, since the compiled contact: no convergence)."""
    env = dict(os.environ, FENICS_PLAST_PROGRESS="off")
    p = subprocess.run([*FP, "run", str(PUNCH), "--out", str(tmp_path / "stiff"), "--set",
                        f"contact.*.penalty={1e11 * PUNCH_DEFAULT!r}", "--set", "output.xdmf=false",
                        "--set", "output.plots=false"], cwd=ROOT, capture_output=True, text=True, env=env,
                       timeout=600)
    assert p.returncode == 1
    s = json.loads((tmp_path / "stiff" / "summary.json").read_text())
    assert not s["converged"]
    assert "Possible cause: contact.punch.penalty = " in s["error"] and "times this pair's default" in s["error"]
    assert "% of a cell's depth" in s["error"], s["error"]
    if "in cell " in s["error"]:
        assert "reference centre at x = " in s["error"]
    else:
        assert "no convergence at load factor" in s["error"], s["error"]
