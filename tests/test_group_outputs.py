"""Outputs that name a group (issue 36): ``group_mean`` (area-weighted mean of a group's displacement or
position component) and ``displacement`` / ``position`` with ``group`` (the node nearest ``point`` among the
group's), through the CLI.

* The homogeneous bar (tests/scenes/bar.toml, axisymmetric, every cell the same material point): its end
  face's mean axial displacement is the prescribed 1 mm and its mean radius 2/3 of the current radius (the
  weights 2 pi r dA integrate the linear field exactly), to 1e-12.
* The tutorial billet (docs/tutorial/billet.toml): the top face's mean axial displacement is the die's
  travel less the penalty penetration (within the largest penetration); the node nearest a point on the
  rim, taken among the outer side's nodes, is that group's (its radial displacement is the bulge's).
"""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from scene_runs import ROOT, needs_mpirun, run_scene  # noqa: E402

QUIET = ("output.xdmf=false", "output.plots=false")


def test_group_mean_of_a_homogeneous_bar(tmp_path):
    s = run_scene(ROOT / "tests" / "scenes" / "bar.toml", tmp_path / "bar", *QUIET,
                  "outputs.end_uz.quantity=group_mean", "outputs.end_uz.group=top", "outputs.end_uz.component=z",
                  "outputs.end_r.quantity=group_mean", "outputs.end_r.group=top", "outputs.end_r.component=r",
                  "outputs.end_r.of=position")
    print(f"\nbar: mean end displacement {s['end_uz_mm']!r} mm, mean end radius {s['end_r_mm']!r} mm, "
          f"radius {s['radius_mm']!r} mm")
    assert s["end_uz_mm"] == pytest.approx(1.0, abs=1e-12)
    assert s["end_r_mm"] == pytest.approx(2.0 / 3.0 * s["radius_mm"], rel=1e-12)


def test_group_mean_and_a_point_of_a_group_on_the_billet(tmp_path):
    s = run_scene(ROOT / "docs" / "tutorial" / "billet.toml", tmp_path / "billet", *QUIET,
                  "outputs.top_uz.quantity=group_mean", "outputs.top_uz.group=top", "outputs.top_uz.component=z",
                  "outputs.rim.quantity=position", "outputs.rim.point=[10.0, 10.0]", "outputs.rim.component=r",
                  "outputs.rim.group=outer")
    print(f"\nbillet: top mean uz {s['top_uz_mm']:.6f} mm, die travel {s['die_travel_mm']:.6f} mm, rim r "
          f"{s['rim_mm']:.6f} mm, bulge {s['bulge_radius_mm']:.6f} mm")
    assert -s["top_uz_mm"] < s["die_travel_mm"] and s["die_travel_mm"] + s["top_uz_mm"] < 0.03
    assert s["rim_mm"] <= s["bulge_radius_mm"] + 1e-12 and s["rim_mm"] > 10.0


@needs_mpirun
@pytest.mark.mpi
def test_group_outputs_two_ranks(tmp_path):
    """The billet's group mean and its point of a group on 2 ranks as serially (to 1e-9)."""
    sets = (*QUIET, "outputs.top_uz.quantity=group_mean", "outputs.top_uz.group=top", "outputs.top_uz.component=z",
            "outputs.rim.quantity=position", "outputs.rim.point=[10.0, 10.0]", "outputs.rim.component=r",
            "outputs.rim.group=outer")
    a = run_scene(ROOT / "docs" / "tutorial" / "billet.toml", tmp_path / "serial", *sets)
    b = run_scene(ROOT / "docs" / "tutorial" / "billet.toml", tmp_path / "mpi", *sets, np_ranks=2)
    for k in ("top_uz_mm", "rim_mm"):
        assert b[k] == pytest.approx(a[k], rel=1e-9, abs=1e-12), (k, a[k], b[k])
