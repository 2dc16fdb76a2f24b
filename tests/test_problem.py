"""The general scene format: validation of scene files (fenics_plast.problem) and the mesh's groups;
defaults, --set overrides, error messages that name the file and the key, and the freshness of the
key reference docs/SCENE_KEYS.md."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from fenics_plast.problem import SceneError, load_problem, parse_problem

ROOT = Path(__file__).resolve().parent.parent
GENERAL = ROOT / "demos"
PUNCH = GENERAL / "punch_stretching.toml"
TAYLOR = GENERAL / "taylor_bar.toml"
BAR = GENERAL / "bar_tension.toml"

# the least a static scene needs (every other key at its default); the mesh by absolute path
MINIMAL = f"""
[scene]
name = "bar"

[analysis]
type = "static"

[mesh]
file = "{ROOT / 'meshes' / 'round_bar.geo'}"

[materials.steel]
E = 206900
nu = 0.29

[materials.steel.hardening]
law = "linear"
yield_stress = 450

[boundary.grip]
group = "top"
type = "displacement"
components = ["z"]
value = "8.0 * t"
"""


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
    assert p.active_physics == ["inertia", "plasticity", "walls"]
    assert load_problem(TAYLOR, ["analysis.erosion_ratio=0.1"]).active_physics == ["erosion", "inertia", "plasticity",
                                                                             "walls"]
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


def test_minimal_scene_defaults(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(MINIMAL)
    p = load_problem(path)
    assert p.name == "bar" and p.path == path and not p.explicit
    assert p.mesh.refine == 1 and p.mesh.geometry == "axisymmetric" and p.mesh.element == "q1p0"
    assert p.mesh.parameters == {} and p.mesh_file == ROOT / "meshes" / "round_bar.geo"
    m = p.materials["steel"]
    assert m.model == "isochoric" and m.E == 206900.0 and isinstance(m.E, float) and m.density is None
    assert m.regions is None
    assert m.hardening.law == "linear" and m.hardening.modulus == 0.0 and m.hardening.yield_stress == 450.0
    a = p.analysis
    assert (a.increments, a.min_increment, a.max_increment, a.max_iterations, a.linesearch) == (20, 1e-4, 0.1, 25, "bt")
    assert (a.rtol, a.atol) == (1e-9, 1e-8)
    assert p.output.xdmf is True and p.output.every == 1 and p.output.plots is True
    assert p.output.checkpoint_every == 10
    assert p.steps == {} and p.tools == {} and p.contact == {} and p.outputs == {} and p.plots == {}
    assert p.active_physics == ["plasticity"]
    assert p.to_dict()["materials"]["steel"]["hardening"]["yield_stress"] == 450.0
    # keys of the other analysis are absent
    with pytest.raises(AttributeError):
        p.analysis.dt_safety
    t = load_problem(TAYLOR)
    assert t.analysis.dt_safety == 0.8 and t.analysis.time_steps is None and t.analysis.internal_force == "fused"
    assert t.output.history_points == 161 and t.materials["copper"].density_as_written == 8930.0
    with pytest.raises(AttributeError):
        t.analysis.increments
    c = load_problem(PUNCH).contact["punch"]
    assert c.law == "quasi-coulomb" and c.tangential_penalty is None


def test_set_overrides(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(MINIMAL)
    p = load_problem(path, ["materials.steel.nu=0.3", "mesh.refine=3", "scene.name=other",
                            "materials.steel.hardening.law=voce", "materials.steel.hardening.Q=100",
                            "materials.steel.hardening.b=10", "mesh.parameters.cells_axial=7"])
    assert p.materials["steel"].nu == 0.3 and p.mesh.refine == 3 and p.name == "other"
    h = p.materials["steel"].hardening
    assert h.law == "voce" and h.Q == 100.0 and h.b == 10.0 and h.yield_stress == 450.0
    assert p.mesh.parameters == {"cells_axial": 7}
    assert p.overrides[0] == "materials.steel.nu=0.3"
    # a bare word falls back to a string
    assert load_problem(path, ["mesh.geometry=plane_strain"]).mesh.geometry == "plane_strain"
    # an elastic scene: no hardening table, no plasticity; --set adds a table
    elastic = MINIMAL.replace('[materials.steel.hardening]\nlaw = "linear"\nyield_stress = 450\n', "")
    e = parse_problem(elastic, tmp_path / "e.toml")
    assert e.materials["steel"].hardening is None and e.active_physics == []
    e = parse_problem(elastic, tmp_path / "e.toml", ["materials.steel.hardening.law=linear",
                                                     "materials.steel.hardening.yield_stress=300"])
    assert e.materials["steel"].hardening.yield_stress == 300.0 and e.active_physics == ["plasticity"]


def test_table_law(tmp_path):
    text = MINIMAL.replace('law = "linear"\nyield_stress = 450',
                           'law = "table"\nstrain = [0, 0.1, 0.5]\nstress = [300, 400, 450]')
    path = tmp_path / "t.toml"
    path.write_text(text)
    assert load_problem(path).materials["steel"].hardening.strain == (0.0, 0.1, 0.5)
    key = "materials.steel.hardening"
    for bad, words in [("strain = [0, 0.5, 0.1]", [f"{key}.strain", "strictly increasing"]),
                       ("strain = [0.1, 0.2, 0.5]", [f"{key}.strain", "first entry must be 0"]),
                       ("strain = [0, 0.1]", [f"{key}.stress has 3 entries", "as many as"])]:
        path.write_text(text.replace("strain = [0, 0.1, 0.5]", bad))
        msg = refused(path)
        for w in words:
            assert w in msg, msg
    path.write_text(text.replace("[300, 400, 450]", "[300, -1, 450]"))
    assert f"{key}.stress" in refused(path)


@pytest.mark.parametrize("path, sets, words", [
    (BAR, ["materials.steel.E=0"], ["materials.steel.E = 0", "E > 0"]),
    (BAR, ["materials.steel.nu=0.5"], ["materials.steel.nu", "-1 < nu < 0.5"]),
    (BAR, ["materials.steel.hardening.yield_stress=-1"], ["materials.steel.hardening.yield_stress",
                                                          "yield_stress >= 0"]),
    (BAR, ["materials.steel.density=-1"], ["materials.steel.density", "density > 0"]),
    (PUNCH, ["contact.punch.friction=-0.1"], ["contact.punch.friction", "friction >= 0"]),
    (BAR, ["materials.steel.hardening.K=500"], ["materials.steel.hardening.K", "not a key of law 'voce'"]),
    (BAR, ["materials.steel.E='stiff'"], ["materials.steel.E", "must be a number"]),
    (BAR, ["mesh.refine=0"], ["mesh.refine", "refine > 0"]),
    (BAR, ["mesh.refine=-2.5"], ["mesh.refine", "refine > 0"]),
    (BAR, ["mesh.cells_radial=3"], ["mesh.cells_radial", "unknown key", "parameters"]),
    (BAR, ["analysis.linesearch=cp"], ["analysis.linesearch", "bt, basic, l2"]),
    (BAR, ["analysis.min_increment=0.5"], ["analysis.min_increment", "must not exceed"]),
    (BAR, ["output.xdmf=1"], ["output.xdmf", "true or false"]),
    (BAR, ["boundary.grip.components=['q']"], ["boundary.grip.components", "'q' is not a component"]),
    (BAR, ["materials.steel.nu"], ["materials.steel.nu", "section.key=value"]),
    (TAYLOR, ["analysis.dt_safety=1.5"], ["analysis.dt_safety", "0 < dt_safety <= 1"]),
    (TAYLOR, ["analysis.increments=10"], ["analysis.increments", "not a key of type 'explicit'"]),
    (TAYLOR, ["steps.a.end=1"], ["steps", "only for static analyses"]),
])
def test_errors_name_file_and_key(path, sets, words):
    msg = refused(path, *sets)
    for w in words:
        assert w in msg, msg


def test_missing_sections_and_file(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(MINIMAL.split("[materials.steel]")[0] + MINIMAL.split('yield_stress = 450\n')[1])
    assert "missing required section [materials]" in refused(path)
    assert "cannot read scene file" in refused(tmp_path / "nope.toml")


def test_scene_keys_doc_up_to_date():
    from fenics_plast.keys_doc import DOCS_PATH, keys_markdown
    assert Path(DOCS_PATH).read_text(encoding="utf-8") == keys_markdown(), (
        "docs/SCENE_KEYS.md is stale: regenerate with `make keys` (python -m fenics_plast.keys_doc)")
