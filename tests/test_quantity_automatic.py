"""The automatic output quantities (fenics_plast/quantities/kinds/mass_scaling.py, wall_energy.py,
erosion.py): measured in every run whose body has them, never declared by a scene.

On a stand-in body (no solver): the columns follow the declared outputs' in the kinds' order, counts
stay integers (history.csv writes them so), the summary entries are measured at the end, a failed
run's are the finite ones, and ``info_results`` lists theirs in the order summary.json has always
had (mass scaling, erosion, walls). The runs' history.csv and summary.json are held to the runner's
by the scene tests (tests/test_walls_erosion.py, tests/test_explicit_stability.py).
"""
from __future__ import annotations

from types import SimpleNamespace

from fenics_plast.quantities import Quantities
from fenics_plast.quantities.registry import AUTOMATIC, KINDS
from fenics_plast.schema import choices

STATS = dict(added_mass=2e-3, fraction=0.25, cells=7, kinetic=3.0, energy=4.0, body_mass=8e-3, max_factor=9.5)
EROSION = dict(cells=3, volume_fraction=0.01, mass_fraction=0.02)


def body(scaling=True, walls=True, erosion=True):
    return SimpleNamespace(
        mass_scaling=SimpleNamespace(stats=lambda: STATS, target_us=0.02) if scaling else None,
        wall_energy=(lambda: 5.0) if walls else None,
        erosion=SimpleNamespace(stats=lambda: EROSION, ratio=0.1, cells=lambda: [(12, [0.5, 1.0])])
        if erosion else None)


def test_automatic_kinds_are_no_declared_quantity():
    assert list(AUTOMATIC) == ["mass_scaling", "wall_energy", "erosion"]
    assert not set(AUTOMATIC) & set(KINDS) and not set(AUTOMATIC) & set(choices("outputs.*.quantity"))


def test_columns_summary_and_info():
    q = Quantities({}, body(), None, {})
    row = q.row(1.5)
    assert list(row) == ["added_mass_kg", "added_mass_fraction", "mass_scaled_cells", "added_mass_kinetic_energy_J",
                         "mass_scaling_energy_J", "wall_energy_J", "eroded_cells", "eroded_volume_fraction"]
    assert row["added_mass_kg"] == 2.0 and row["wall_energy_J"] == 5e-3
    assert type(row["mass_scaled_cells"]) is int and type(row["eroded_cells"]) is int
    assert q.history == {} and q.times == [1.5]             # (not kept: the summary is measured at the end)
    s = q.automatic_summary()
    assert list(s) == ["mass_scaling_dt_us", "body_mass_kg", "added_mass_kg", "added_mass_fraction",
                       "mass_scaled_cells", "max_mass_scale_factor", "added_mass_kinetic_energy_J",
                       "mass_scaling_energy_J", "wall_energy_J", "eroded_cells", "eroded_volume_fraction",
                       "erosion_ratio", "eroded_mass_fraction", "eroded_cell_list"]
    assert s["eroded_cell_list"] == [dict(cell=12, reference_centre_mm=[0.5, 1.0])]
    assert list(q.automatic_summary(failed=True)) == [
        "added_mass_kg", "added_mass_fraction", "mass_scaled_cells", "max_mass_scale_factor", "wall_energy_J",
        "eroded_cells", "eroded_volume_fraction"]
    assert q.study_keys(automatic=True)["info_results"] == [
        "added_mass_fraction", "mass_scaled_cells", "eroded_cells", "eroded_volume_fraction", "wall_energy_J"]
    assert q.study_keys()["info_results"] == []


def test_only_what_the_body_has():
    q = Quantities({}, body(scaling=False, erosion=False), None, {})
    assert list(q.row(0.0)) == ["wall_energy_J"] and list(q.automatic_summary()) == ["wall_energy_J"]
    q = Quantities({}, body(False, False, False), None, {})
    assert q.row(0.0) == {} and q.automatic_summary() == {} and q.study_keys(automatic=True)["info_results"] == []
