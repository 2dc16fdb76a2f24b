"""The Hockett-Sherby law, sigma_y = sigma_sat - (sigma_sat - sigma_0) exp(-b eps_p^n): flow stress and slope
against the closed form (and the safeguarded slope at eps_p = 0), a uniaxial material point on the curve for
both models, its scene rule, and a scene that selects it with ``--set``."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from fenics_plast.errors import SceneError
from fenics_plast.material import Hardening, Material
from fenics_plast.material.point import uniaxial_stress
from fenics_plast.problem import parse_problem

REPO = Path(__file__).resolve().parent.parent
S0, SSAT, B, N = 150.0, 400.0, 6.0, 0.7      # MPa, MPa, -, -


def curve(eps):
    return SSAT - (SSAT - S0) * np.exp(-B * eps ** N)


def test_flow_stress_and_slope_are_the_closed_form():
    h = Hardening("hockett_sherby", yield_stress=S0, saturation_stress=SSAT, b=B, n=N)
    eps = np.array([1e-6, 1e-3, 0.05, 0.2, 1.0, 3.0])
    s, ds = h(eps)
    np.testing.assert_allclose(s, curve(eps), rtol=1e-14)
    np.testing.assert_allclose(ds, (SSAT - S0) * B * N * eps ** (N - 1.0) * np.exp(-B * eps ** N), rtol=1e-13)
    assert h(0.0) == (S0, 0.0)                                      # the safeguard: slope 0, not inf
    voce = Hardening("voce", yield_stress=S0, Q=SSAT - S0, b=B)      # n = 1 is Voce without the linear term
    one = Hardening("hockett_sherby", yield_stress=S0, saturation_stress=SSAT, b=B, n=1.0)
    np.testing.assert_allclose(one(eps)[0], voce(eps)[0], rtol=1e-14)
    assert one(0.0) == pytest.approx(voce(0.0), rel=1e-14)


@pytest.mark.parametrize("model", ["isochoric", "seed"])
def test_uniaxial_point_follows_the_curve(model):
    E = 70e3
    mat = Material(E, 0.3, Hardening("hockett_sherby", yield_stress=S0, saturation_stress=SSAT, b=B, n=N), model)
    out = uniaxial_stress(mat, 0.6, 80)
    plastic = out["eqps"] > 0.0
    assert plastic.sum() >= 75
    np.testing.assert_allclose(out["kirchhoff_axial_MPa"][plastic], curve(out["eqps"][plastic]), rtol=1e-9)


def test_saturation_below_yield_is_refused():
    scene = REPO / "demos" / "taylor_bar.toml"
    h = "materials.copper.hardening."
    sets = [h + "law=hockett_sherby", h + "yield_stress=200", h + "saturation_stress=150", h + "b=5", h + "n=0.5"]
    with pytest.raises(SceneError) as e:
        parse_problem(scene.read_text().replace("modulus", "# modulus"), scene, sets)
    assert "hardening.saturation_stress = 150 is out of range: must be at least" in str(e.value)


def test_a_scene_selects_it_from_the_command_line(tmp_path):
    from fenics_plast import cli
    text = (REPO / "demos" / "taylor_bar.toml").read_text()
    text = text.replace('file = "../meshes/round_bar.geo"', f'file = "{REPO / "meshes" / "round_bar.geo"}"')
    scene = tmp_path / "taylor_hs.toml"
    scene.write_text("\n".join(ln for ln in text.splitlines() if not ln.startswith("modulus")) + "\n")
    h = "materials.copper.hardening."
    out = tmp_path / "res"
    assert cli.main(["run", str(scene), "--out", str(out), "--set", h + "law=hockett_sherby", "--set",
                     h + "saturation_stress=450", "--set", h + "b=3", "--set", h + "n=0.6",
                     "--set", "analysis.end_time=4", "--set", "output.plots=false"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["max_eqps"] > 0.0
