"""The general scene format: validation of scene files (fenics_plast.problem) and the mesh's groups."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from fenics_plast.problem import SceneError, load_problem

ROOT = Path(__file__).resolve().parent.parent
GENERAL = ROOT / "demos"
PUNCH = GENERAL / "punch_stretching.toml"
TAYLOR = GENERAL / "taylor_bar.toml"


def refused(path, *sets):
    with pytest.raises(SceneError) as e:
        load_problem(path, sets)
    msg = str(e.value)
    assert msg.startswith(str(path)), msg
    return msg


def test_shipped_scenes_load_with_units_converted():
    p = load_problem(TAYLOR)
    assert p.explicit and p.analysis.end_time == pytest.approx(80e-6)
    assert p.materials["copper"].density == pytest.approx(8930.0e-12)
    assert p.initial_velocity["bar"].value[1].evaluate() == -227.0      # m/s as written (scaled by the runner)
    assert p.active_physics == ["inertia", "plasticity"]
    q = load_problem(PUNCH, ["contact.punch.friction=0.15"])
    assert q.active_physics == ["contact", "friction", "plasticity"]
    assert list(q.steps) == ["to_20mm", "to_40mm"]
    assert q.tools["punch"].path["y"].evaluate(t=0.25) == pytest.approx(10.0)
    assert q.output.checkpoint_every == 10 and p.output.checkpoint_every == 2000


@pytest.mark.parametrize("sets, words", [
    (["analysis.type=quasi"], ["analysis.type = 'quasi'", "static, explicit"]),
    (["analysis.dt_safety=0.5"], ["analysis.dt_safety", "not a key of type 'static'"]),
    (["materials.aluminium.nu=0.5"], ["materials.aluminium.nu = 0.5", "out of range"]),
    (["materials.aluminium.E=nan"], ["materials.aluminium.E", "not a finite number"]),
    (["tools.punch.path={t=[0, 0], y=[0, 40]}"], ["tools.punch.path", "increase strictly"]),
    (["boundary.clamp.value=1"], ["boundary.clamp.value", "not a key of type 'fixed'"]),
    (["contact.punch.tool=anvil"], ["contact.punch.tool = 'anvil'", "punch, die"]),
    (["outputs.punch_force.quantity=energy"], ["outputs.punch_force"]),
    (["mesh.element=q2"], ["mesh.element = 'q2'", "q1p0, q1"]),
    (["steps.to_40mm.end=0.5"], ["steps", "same end"]),
    (["bogus.key=1"], ["unknown section [bogus]"]),
])
def test_bad_keys_name_the_key(sets, words):
    msg = refused(PUNCH, *sets)
    for w in words:
        assert w in msg, msg


@pytest.mark.parametrize("value, words", [
    ('"__import__(\'os\')"', ["__import__"]),
    ('"3*q"', ["unknown symbol 'q'"]),
    ('"open(1)"', ["unknown function 'open'"]),
    ('"2 +"', ["does not parse"]),
])
def test_expressions_are_data(tmp_path, value, words):
    text = PUNCH.read_text().replace('[boundary.clamp]\ngroup = "rim"\ntype = "fixed"\ncomponents = ["r", "z"]',
                                     f'[boundary.clamp]\ngroup = "rim"\ntype = "displacement"\n'
                                     f'components = ["r"]\nvalue = {value}')
    path = tmp_path / "s.toml"
    path.write_text(text.replace("../meshes", str(ROOT / "meshes")))
    msg = refused(path)
    assert "boundary.clamp.value" in msg
    for w in words:
        assert w in msg, msg


def test_overlapping_materials_are_refused(tmp_path):
    text = TAYLOR.read_text() + """
[materials.steel]
regions = ["bar"]
E = 210e3
nu = 0.3
density = 7800.0
"""
    text = text.replace("[materials.copper]\n", '[materials.copper]\nregions = ["bar"]\n')
    path = tmp_path / "s.toml"
    path.write_text(text)
    msg = refused(path)
    assert "region 'bar' is also in materials.copper.regions" in msg


def test_geo_that_gmsh_cannot_mesh_gives_gmsh_message(tmp_path):
    (tmp_path / "bad.geo").write_text("Point(1) = {0, 0, 0};\nLine(1) = {1, 2};\n")
    path = tmp_path / "s.toml"
    path.write_text(TAYLOR.read_text().replace('file = "../meshes/round_bar.geo"', 'file = "bad.geo"')
                    .split("[mesh.parameters]")[0] + "\n" + TAYLOR.read_text().split("cells_axial = 36")[1])
    out = tmp_path / "out"
    p = subprocess.run([sys.executable, "-m", "fenics_plast.cli", "run", str(path), "--out", str(out)],
                       capture_output=True, text=True, cwd=ROOT, env=dict(os.environ, FENICS_PLAST_PROGRESS="off"))
    assert p.returncode == 2, p.stderr
    assert "mesh.file" in p.stderr and "Unknown control point 2" in p.stderr
    assert not out.exists()
