"""The ``volume`` output quantity (fenics_plast/quantities/kinds/volume.py) against closed forms.

* the cell volumes of linear cells: a quadrilateral's area and 2 pi r dA (Pappus), a hexahedron's
  and a triangle's volume, exactly;
* the round bar of demos/bar_tension.toml without its imperfection, stretched elastically by a
  frictionless grip: the state is uniform, the bar stays a cylinder, so its volume is pi r^2 (L + d)
  (r: the measured outer radius) to the solver's tolerance, and starts at pi R^2 L; J = V / V0 is the
  uniaxial elastic 1 + (1 - 2 nu) eps to O(eps^2).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from fenics_plast.quantities import KINDS, column_names
from fenics_plast.quantities.kinds.volume import cell_volumes
from fenics_plast.schema import SCHEMA
from scene_runs import ROOT, history, run_scene


def test_cell_volumes_closed_form():
    quad = np.array([[[0, 0], [1, 0], [0, 1], [1, 1]]], float) * [2.0, 3.0] + [1.0, 0.0]
    assert cell_volumes(quad, False)[0] == pytest.approx(6.0, rel=1e-14)
    assert cell_volumes(quad, True)[0] == pytest.approx(2 * math.pi * 2.0 * 6.0, rel=1e-14)   # Pappus
    skew = np.array([[[0, 0], [2, 0], [0.5, 1], [3, 2]]], float)            # a general quadrilateral
    x, y = skew[0, [0, 1, 3, 2], 0], skew[0, [0, 1, 3, 2], 1]                # its outline, in turn
    area = 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    assert cell_volumes(skew, False)[0] == pytest.approx(area, rel=1e-14)
    corners = np.array(np.meshgrid([0, 1], [0, 1], [0, 1], indexing="ij")).reshape(3, -1).T[:, ::-1]  # x fastest
    hexa = corners[None] * [1.0, 2.0, 3.0]
    assert cell_volumes(hexa, False)[0] == pytest.approx(6.0, rel=1e-14)
    tri = np.array([[[1, 0], [3, 0], [1, 3]]], float)
    assert cell_volumes(tri, False)[0] == pytest.approx(3.0, rel=1e-14)
    assert cell_volumes(tri, True)[0] == pytest.approx(2 * math.pi * (5 / 3) * 3.0, rel=1e-14)


def test_volume_is_registered():
    assert "volume" in KINDS and "volume" in SCHEMA["outputs"].keys["quantity"].choices
    assert "volume" in SCHEMA["outputs"].keys["regions"].when["quantity"]
    assert column_names("v", type("O", (), dict(quantity="volume"))()) == ["v_mm3"]


R, L, NU, E = 6.413, 26.667, 0.29, 206.9e3       # demos/bar_tension.toml (the modelled half)


def stretched_bar(out, d, model="isochoric"):
    """demos/bar_tension.toml without its imperfection, coarse, the grip moved by ``d`` [mm]: its
    summary and history, with the volume and the outer radius recorded."""
    res = run_scene(ROOT / "demos" / "bar_tension.toml", out,
                    "mesh.parameters.imperfection=0", "mesh.parameters.cells_radial=4",
                    "mesh.parameters.cells_axial=8", "analysis.increments=4", f"boundary.grip.value={d}*t",
                    f"materials.steel.model={model}", "output.xdmf=false", "output.plots=false",
                    "outputs.v.quantity=volume", "outputs.r.quantity=extent", "outputs.r.group=outer",
                    "outputs.r.component=r", "outputs.r.which=max")
    return res, history(out)


def test_elastic_bar_volume(tmp_path):
    d = 0.05
    res, h = stretched_bar(tmp_path / "bar", d)
    V0 = math.pi * R ** 2 * L
    assert h["v_mm3"][0] == pytest.approx(V0, rel=1e-12)
    r = h["r_mm"][-1]
    assert res["v_mm3"] == pytest.approx(math.pi * r ** 2 * (L + d), rel=1e-9)     # still a cylinder
    assert res["v_mm3"] / V0 - 1.0 == pytest.approx((1 - 2 * NU) * d / L, rel=0.02)
    assert res["max_force_kN"] * 1e3 / (math.pi * R ** 2) < 450.0    # elastic throughout


def test_plastic_bar_volume(tmp_path):
    """Stretched 5.6 % (plastic flow): the isochoric model changes the volume by the elastic part only,
    ln J = tr(eps_e) = (1 - 2 nu) tau / E with tau = J F / (pi r^2) uniaxial (Hencky, uniform state);
    the seed model (be^-1 radial return) changes it by much more."""
    d = 1.5
    V0 = math.pi * R ** 2 * L
    for model, exact in (("isochoric", True), ("seed", False)):
        res, h = stretched_bar(tmp_path / model, d, model)
        r = h["r_mm"][-1]
        assert res["v_mm3"] == pytest.approx(math.pi * r ** 2 * (L + d), rel=1e-9)
        J = res["v_mm3"] / V0
        elastic = (1 - 2 * NU) * J * res["force_kN"] * 1e3 / (math.pi * r ** 2) / E
        if exact:
            assert math.log(J) == pytest.approx(elastic, rel=1e-6)
        else:
            assert math.log(J) > 1.3 * elastic
