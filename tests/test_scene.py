"""Scene files: defaults, --set overrides, error messages, SCENE_KEYS.md freshness. No dolfinx needed."""
import math
from pathlib import Path

import pytest

from fenics_plast.scene import (DOCS_PATH, README_PATH, SceneError, keys_markdown, load_scene, parse_scene,
                                readme_with_keys)

BAR = """
[scene]
name = "bar"
kind = "bar_tension"

[mesh]
radius = 6.413
length = 53.334
cells_radial = 5
cells_axial = 20

[material]
E = 206.9e3
nu = 0.29

[material.hardening]
law = "linear"
yield_stress = 450
modulus = 129.24

[loading]
displacement = 8
"""

PUNCH = """
[scene]
name = "punch"
kind = "punch_stretching"

[material]
E = 69000
nu = 0.3

[material.hardening]
law = "swift"
K = 589
eps0 = 0.0171
n = 0.216

[contact]
friction = 0.0
"""

TAYLOR = """
[scene]
name = "taylor"
kind = "taylor_bar"

[mesh]
radius = 3.2
length = 32.4
cells_radial = 5
cells_axial = 50

[material]
E = 117e3
nu = 0.35
density = 8930

[material.hardening]
law = "linear"
yield_stress = 400
modulus = 100

[loading]
velocity = 227
end_time_us = 80
"""


def write(tmp_path, text, name="scene.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_minimal_bar_defaults(tmp_path):
    s = load_scene(write(tmp_path, BAR))
    assert s.name == "bar" and s.kind == "bar_tension"
    assert s.path == tmp_path / "scene.toml"
    assert s.mesh.refine == 1 and s.mesh.geometry == "axisymmetric" and s.mesh.element == "q1p0"
    assert s.mesh.imperfection == 0.0
    assert s.material.model == "isochoric"
    assert s.material.E == 206.9e3 and isinstance(s.material.E, float)
    assert s.material.hardening.law == "linear" and s.material.hardening.modulus == 129.24
    assert s.material.density is None
    assert s.solver.increments == 20 and s.solver.linesearch == "bt"
    assert s.output.xdmf is True and s.output.every == 1
    assert s.active_physics == ["plasticity"]
    assert "contact" not in s.to_dict() or s.to_dict()["contact"] is None
    d = s.to_dict()
    assert d["material"]["hardening"]["yield_stress"] == 450.0
    # keys of other kinds are absent
    with pytest.raises(AttributeError):
        s.mesh.inner_radius
    with pytest.raises(AttributeError):
        s.solver.dt_safety


def test_punch_defaults_and_physics(tmp_path):
    s = load_scene(write(tmp_path, PUNCH))
    assert s.mesh.blank_radius == 65.53 and s.mesh.cells_radial == 60 and s.mesh.cells_thickness == 4
    assert s.tools.punch_radius == 50.8 and s.loading.travel == 40.0
    assert s.contact.law == "quasi-coulomb" and s.contact.penalty is None
    assert s.active_physics == ["contact", "plasticity"]
    s2 = load_scene(tmp_path / "scene.toml", ["contact.friction=0.3"])
    assert s2.contact.friction == 0.3
    assert s2.active_physics == ["contact", "friction", "plasticity"]


def test_taylor_unit_conversion(tmp_path):
    s = load_scene(write(tmp_path, TAYLOR))
    assert math.isclose(s.material.density, 8930e-12)
    assert s.material.density_kg_m3 == 8930
    assert math.isclose(s.loading.velocity, 227e3)
    assert s.loading.velocity_m_s == 227
    assert s.solver.dt_safety == 0.8 and s.solver.steps is None
    assert s.output.history_points == 200
    assert s.active_physics == ["inertia", "plasticity"]


def test_set_overrides(tmp_path):
    p = write(tmp_path, BAR)
    s = load_scene(p, ["material.nu=0.3", "mesh.refine=3", "scene.name=other",
                       "material.hardening.law=voce", "material.hardening.Q=100",
                       "material.hardening.b=10"])
    assert s.material.nu == 0.3 and s.mesh.refine == 3 and s.name == "other"
    assert s.material.hardening.law == "voce" and s.material.hardening.Q == 100.0
    assert s.overrides[0] == "material.nu=0.3"
    # a bare word falls back to a string
    s = load_scene(p, ["mesh.geometry=plane_strain"])
    assert s.mesh.geometry == "plane_strain"
    # removing plasticity is not possible by --set, but elastic scenes are fine
    s = parse_scene(BAR.split("[material.hardening]")[0] + "[loading]\ndisplacement = 1\n", "e.toml")
    assert s.material.hardening is None and s.active_physics == []


def test_table_law(tmp_path):
    text = BAR.replace('law = "linear"\nyield_stress = 450\nmodulus = 129.24',
                       'law = "table"\nstrain = [0, 0.1, 0.5]\nstress = [300, 400, 450]')
    s = load_scene(write(tmp_path, text))
    assert s.material.hardening.strain == (0.0, 0.1, 0.5)
    for bad, key in [("strain = [0, 0.5, 0.1]", "material.hardening.strain"),
                     ("strain = [0.1, 0.2, 0.5]", "material.hardening.strain"),
                     ("strain = [0]\nstress = [1]", "material.hardening.strain")]:
        t = text.replace("strain = [0, 0.1, 0.5]", bad)
        if "stress = [1]" in bad:
            t = t.replace("stress = [300, 400, 450]", "")
        with pytest.raises(SceneError, match=key.replace(".", r"\.")):
            load_scene(write(tmp_path, t, "t.toml"))
    with pytest.raises(SceneError, match=r"material\.hardening\.stress"):
        load_scene(write(tmp_path, text.replace("[300, 400, 450]", "[300, 400]"), "t.toml"))


@pytest.mark.parametrize("text, overrides, key, fragment", [
    ("[scene\nname = 'x'", [], "TOML", "syntax"),
    (BAR.replace("cells_axial = 20", "cells_axial = 20\ncells_hoop = 3"), [], "mesh.cells_hoop",
     "allowed keys"),
    (BAR, ["material.E=0"], "material.E", "E > 0"),
    (BAR, ["material.E=-5"], "material.E", "out of range"),
    (BAR, ["material.nu=0.5"], "material.nu", "-1 < nu < 0.5"),
    (BAR, ["material.hardening.yield_stress=-1"], "material.hardening.yield_stress", "yield_stress >= 0"),
    (PUNCH, ["contact.friction=-0.1"], "contact.friction", "friction >= 0"),
    (BAR.replace("[material]\nE = 206.9e3\nnu = 0.29\n", "").replace("[material.hardening]\nlaw = \"linear\"\n"
     "yield_stress = 450\nmodulus = 129.24\n", ""), [], "material", "missing required section"),
    (BAR, ["material.hardening.K=500"], "material.hardening.K", "not a parameter of law 'linear'"),
    (BAR, ["mesh.cells_radial=2.5"], "mesh.cells_radial", "must be an integer"),
    (BAR, ["material.E='stiff'"], "material.E", "must be a number"),
    (BAR, ["mesh.refine=0"], "mesh.refine", "refine >= 1"),
    (BAR, ["mesh.inner_radius=3"], "mesh.inner_radius", "not allowed for kind 'bar_tension'"),
    (BAR, ["contact.friction=0.1"], "contact", "not allowed for kind"),
    (BAR, ["scene.kind=taylor_bar"], "material.density", "required when inertia"),
    (BAR, ["scene.kind=rolling"], "scene.kind", "bar_tension, taylor_bar"),
    (BAR.replace("radius = 6.413\n", ""), [], "mesh.radius", "missing: required"),
    (BAR, ["mesh.imperfection=0.5"], "mesh.imperfection", "0 <= imperfection < 0.5"),
    (BAR, ["solver.linesearch=cp"], "solver.linesearch", "bt, basic, l2"),
    (BAR, ["solver.min_increment=0.5"], "solver.min_increment", "must not exceed"),
    (BAR, ["output.xdmf=1"], "output.xdmf", "true or false"),
    (BAR, ["bogus.key=1"], "bogus", "unknown section"),
    (BAR, ["material.nu"], "material.nu", "section.key=value"),
    (TAYLOR, ["solver.dt_safety=1.5"], "solver.dt_safety", "0 < dt_safety <= 1"),
    (TAYLOR, ["solver.increments=10"], "solver.increments", "only for bar_tension"),
])
def test_errors_name_file_and_key(tmp_path, text, overrides, key, fragment):
    p = write(tmp_path, text, "my_scene.toml")
    with pytest.raises(SceneError) as ei:
        load_scene(p, overrides)
    msg = str(ei.value)
    assert str(p) in msg, msg
    assert key in msg, msg
    assert fragment in msg, msg


def test_thick_cylinder_radii(tmp_path):
    text = """
[scene]
name = "cyl"
kind = "thick_cylinder"
[mesh]
inner_radius = 100
outer_radius = 200
cells_radial = 10
[material]
E = 210000
nu = 0.3
[loading]
pressure = 100
"""
    s = load_scene(write(tmp_path, text))
    assert s.mesh.cells_circumferential == 4 and s.loading.pressure == 100.0
    with pytest.raises(SceneError, match=r"mesh\.outer_radius = 50 is out of range"):
        load_scene(tmp_path / "scene.toml", ["mesh.outer_radius=50"])


def test_missing_file(tmp_path):
    with pytest.raises(SceneError, match="nope.toml"):
        load_scene(tmp_path / "nope.toml")


def test_scene_keys_doc_up_to_date():
    committed = Path(DOCS_PATH).read_text(encoding="utf-8")
    assert committed == keys_markdown(), (
        "docs/SCENE_KEYS.md is stale: regenerate with `python -m fenics_plast.scene`")
    readme = Path(README_PATH).read_text(encoding="utf-8")
    assert readme == readme_with_keys(readme), (
        "README.md's scene-file reference is stale: regenerate with `make keys`")
