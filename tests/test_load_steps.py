"""Static load steps and ramps as users of Abaqus and CalculiX expect (issue 21, item 7).

* The first increment of a [steps] table after the first starts from the converged state with the
  Newton correction carrying the boundary values' increment (StaticSolver's tangent predictor): a
  plane-strain cylinder expanded from a = 10 to 85 mm in four steps runs as in one step. Before, each
  step's first increment put the whole increment on the inner nodes alone, inverted the thin inner
  cells and cut back (18 cut-backs against the one-step run's 5, and a failure with coarser steps).
* A value that does not depend on t is ramped over the first step (amplitude "ramp", the default):
  the same numbers as writing the ramp as an expression of t; amplitude "step" applies it in full
  from the first increment.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from scene_runs import ROOT, history, run_scene

RING = ROOT / "tests" / "scenes" / "ring.toml"
FINE = ("mesh.parameters.cells_radial=16", "mesh.parameters.cells_circumferential=16")


def _ring_copy(tmp_path: Path, name: str, value: list[str], steps=(), extra: str = "") -> Path:
    """tests/scenes/ring.toml with the inner boundary's value replaced, the mesh path made absolute and
    [steps] tables ending at ``steps`` appended (written into tmp_path)."""
    text = RING.read_text().replace('"../../meshes/ring.geo"', f'"{ROOT / "meshes" / "ring.geo"}"')
    text = re.sub(r'(?m)^value = \[.*\]$', "value = [" + ", ".join(f'"{v}"' for v in value) + "]", text, count=1)
    text = text.replace('type = "displacement"\ncomponents = ["x", "y"]',
                        'type = "displacement"\ncomponents = ["x", "y"]' + extra)
    text += "".join(f"\n[steps.s{i}]\nend = {end!r}\n" for i, end in enumerate(steps))
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


def test_cylinder_expansion_in_steps_runs_as_in_one_step(tmp_path):
    """Inner radius 10 -> 85 mm (the ring 10/20 mm, 16 x 16 cells, perfectly plastic): four steps give
    the one-step pressure to 1e-4 with no more cut-backs than the one-step run."""
    value = ["75.0 * t * x / 10", "75.0 * t * y / 10"]
    one = run_scene(_ring_copy(tmp_path, "one", value), tmp_path / "one", *FINE, "analysis.increments=40")
    four = run_scene(_ring_copy(tmp_path, "four", value, steps=(0.25, 0.5, 0.75, 1.0)), tmp_path / "four",
                     *FINE, "analysis.increments=10")
    assert one["converged"] and four["converged"]
    assert four["cutbacks"] <= one["cutbacks"], (four["cutbacks"], one["cutbacks"])
    assert four["pressure_MPa"] == pytest.approx(one["pressure_MPa"], rel=1e-4)


def test_constant_value_is_ramped_like_its_expression(tmp_path):
    """A displacement that does not depend on t (amplitude "ramp", the default) equals the same value
    written as "... * t" to round-off at every increment (no [steps]: the ramp ends at t = 1); with
    [steps] it ends at the first step's end and is held after it."""
    d = 0.16887495373796554
    ramp = run_scene(_ring_copy(tmp_path, "ramp", [f"{d} * x / 10", f"{d} * y / 10"]), tmp_path / "ramp")
    expr = run_scene(_ring_copy(tmp_path, "expr", [f"{d} * t * x / 10", f"{d} * t * y / 10"]), tmp_path / "expr")
    hr, he = history(tmp_path / "ramp"), history(tmp_path / "expr")
    np.testing.assert_allclose(hr["time"], he["time"], rtol=0, atol=0)
    np.testing.assert_allclose(hr["inner_displacement_mm"], he["inner_displacement_mm"], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(hr["pressure_MPa"], he["pressure_MPa"], rtol=1e-9)
    assert ramp["pressure_MPa"] == pytest.approx(expr["pressure_MPa"], rel=1e-9)
    # with steps ending at 0.5 and 1: full value from t = 0.5 on
    run_scene(_ring_copy(tmp_path, "steps", [f"{d} * x / 10", f"{d} * y / 10"], steps=(0.5, 1.0)), tmp_path / "steps")
    hs = history(tmp_path / "steps")
    expected = d * np.minimum(hs["time"] / 0.5, 1.0)
    np.testing.assert_allclose(hs["inner_displacement_mm"], expected, rtol=1e-12, atol=1e-15)


def test_amplitude_step_applies_the_value_in_full(tmp_path):
    """amplitude = "step": the full displacement from the first increment (the old behaviour, now asked
    for); the converged end state is the one-step elastic-plastic answer of the same displacement."""
    d = 0.05
    scene = _ring_copy(tmp_path, "step", [f"{d} * x / 10", f"{d} * y / 10"], extra='\namplitude = "step"')
    run_scene(scene, tmp_path / "step")
    h = history(tmp_path / "step")
    assert h["time"][1] > 0.0
    np.testing.assert_allclose(h["inner_displacement_mm"][1:], d, rtol=1e-12)
    assert h["inner_displacement_mm"][0] == 0.0


def test_amplitude_step_of_a_constant(tmp_path):
    """A constant displacement with amplitude "step" (tests/scenes/bar.toml's grip, 0.05 mm, elastic): in full
    from the first increment, as the same value written as an expression that does not ramp (before, a
    constant's "step" was measured from its own value at t = 0 and never applied)."""
    step = run_scene(ROOT / "tests" / "scenes" / "bar.toml", tmp_path / "step", "boundary.grip.value=0.05",
                     "boundary.grip.amplitude=step", "analysis.increments=4", "output.xdmf=false")
    expr = run_scene(ROOT / "tests" / "scenes" / "bar.toml", tmp_path / "expr", "boundary.grip.value=0.05 + 0 * t",
                     "analysis.increments=4", "output.xdmf=false")
    h_step, h_expr = history(tmp_path / "step"), history(tmp_path / "expr")
    assert h_step["force_N"][1] > 0.0
    assert np.allclose(h_step["force_N"], h_expr["force_N"], rtol=1e-12, atol=1e-9)
    assert step["force_N"] == pytest.approx(expr["force_N"], rel=1e-12)
