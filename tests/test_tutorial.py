"""The user guide's tutorial scene (docs/guide/tutorial.md: docs/tutorial/billet.toml + billet.geo) runs as
written, and its frictionless variant equals the closed form of homogeneous upsetting.

Without friction the billet stays a cylinder: with the plastic strain incompressible and the elastic
strain ~1e-3, the radius is R sqrt(h0/h) and the press force is sigma_y(eps) pi R^2 h0/h with the
log strain eps = ln(h0/h) (Swift: sigma_y = K (eps0 + eps)^n; the elastic part of eps shifts the
force by about n sigma / (E (eps0 + eps)) ~ 0.2 %).
"""
from __future__ import annotations

import math
from pathlib import Path

import pytest

from scene_runs import run_scene

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "docs" / "tutorial" / "billet.toml"


def run(out, *sets):
    return run_scene(SCENE, out, *sets)


def test_frictionless_upsetting_equals_the_homogeneous_closed_form(tmp_path):
    s = run(tmp_path / "b", "contact.die.friction=0.0", "mesh.parameters.cells_radial=4",
            "mesh.parameters.cells_axial=4")
    ratio = 10.0 / 7.0                                       # h0 / h at 3 mm of travel on the half height
    eps = math.log(ratio)
    force_kN = 800.0 * (0.01 + eps) ** 0.2 * math.pi * 10.0 ** 2 * ratio / 1e3
    assert s["die_travel_mm"] == pytest.approx(3.0, rel=1e-12)
    assert s["max_die_force_kN"] == pytest.approx(force_kN, rel=0.01)
    assert s["bulge_radius_mm"] == pytest.approx(10.0 * math.sqrt(ratio), rel=0.005)


def test_the_tutorial_scene_runs_as_written(tmp_path):
    """Friction barrels the billet: the bulge exceeds the frictionless cylinder's radius and the force
    exceeds the frictionless force (slab method: x (1 + 2 mu R / (3 h)) ~ 1.06)."""
    s = run(tmp_path / "b")
    ratio = 10.0 / 7.0
    frictionless = 800.0 * (0.01 + math.log(ratio)) ** 0.2 * math.pi * 100.0 * ratio / 1e3
    assert s["converged"] and s["active_physics"] == ["contact", "friction", "plasticity"]
    assert 1.0 < s["max_die_force_kN"] / frictionless < 1.1
    assert s["bulge_radius_mm"] > 10.0 * math.sqrt(ratio)
    for png in ("force.png", "shape.png"):
        assert (tmp_path / "b" / png).exists()
