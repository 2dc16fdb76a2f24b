"""The shipped 3-D scenes against the axisymmetric answers (issue 14).

* demos/taylor_bar_3d.toml, a quarter of the Taylor bar: the first 10 µs in the default suite
  (energy balance, the quarter's energies scaled to the whole bar's initial kinetic energy);
  graded quarter meshes within 1 % of the axisymmetric Richardson limit of radius and length
  (slow; docs/STUDIES.md "taylor_3d" has refine 1 and 2).
* demos/punch_stretching_3d.toml, a quarter of the blank: punch force at 20, 30 and 40 mm within
  2 % of the axisymmetric scene's, frictionless and with mu = 0.15 (slow).
* demos/taylor_bar_oblique.toml, the half bar striking a wall at 10 degrees: it completes with the
  energy balance closed by the contact work, and the foot spreads away from the first contact (slow);
  its first 5 µs equal on 1 and 2 ranks (3-D explicit contact with friction under MPI).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from scene_runs import ROOT, history, run_scene

DEMOS = ROOT / "demos"
QUIET = ("output.xdmf=false", "output.plots=false")
#: Richardson limits of the axisymmetric uniform-mesh study (docs/STUDIES.md, taylor_mesh)
R_INF, L_INF = 7.22863, 21.4228
#: graded quarter: 18 layers, face layer 16 x thinner than the top one, ring cells 4 x narrower outside
GRADED = ("mesh.parameters.cells_axial=18", "mesh.parameters.axial_size_ratio=16",
          "mesh.parameters.radial_size_ratio=4")
RHO, V0, R0, L0 = 8930e-12, 227e3, 3.2, 32.4          # tonne/mm^3, mm/s, mm


def quarter_bar_volume():
    """Volume [mm^3] of the faceted quarter bar of demos/taylor_bar_3d.toml (its O-grid's straight
    edges cut 1.1 % of the circle's area)."""
    from dolfinx import fem
    from mpi4py import MPI
    import ufl
    from fenics_plast.meshing import mesh_from_file
    mesh = mesh_from_file(MPI.COMM_SELF, ROOT / "meshes" / "round_bar_quarter.geo",
                          dict(radius=R0, length=L0, cells_radial=6, cells_axial=36), gdim=3)[0]
    return fem.assemble_scalar(fem.form(1.0 * ufl.dx(domain=mesh)))


def test_taylor_quarter_first_microseconds(tmp_path):
    s = run_scene(DEMOS / "taylor_bar_3d.toml", tmp_path / "t", "analysis.end_time=10", *QUIET)
    assert s["cells"] == 972
    volume = quarter_bar_volume()
    assert volume == pytest.approx(math.pi * R0 ** 2 * L0 / 4, rel=0.015)
    ke0 = 4 * 0.5 * RHO * volume * V0 ** 2 * 1e-3                      # the whole bar [J]
    # scale = 4 on the quarter; the sliding support starts the face nodes at rest (their lumped
    # mass: half a layer of 36, 1.4 %)
    assert 0.98 * ke0 < s["max_kinetic_energy_J"] < 0.99 * ke0
    o = run_scene(DEMOS / "taylor_bar_oblique.toml", tmp_path / "o", "analysis.end_time=1", *QUIET)
    assert o["max_kinetic_energy_J"] == pytest.approx(ke0, rel=1e-10)  # scale = 2 on the half, all nodes moving
    assert s["max_energy_balance_error"] < 1e-3
    assert s["radius_mm"] > R0 * 1.3 and s["length_mm"] < L0
    total = s["kinetic_energy_J"] + s["plastic_dissipation_J"] + s["elastic_energy_J"]
    assert total == pytest.approx(s["max_kinetic_energy_J"], rel=1e-3)


@pytest.mark.slow
def test_taylor_quarter_graded_within_one_percent_of_the_axisymmetric_limit(tmp_path):
    s = run_scene(DEMOS / "taylor_bar_3d.toml", tmp_path / "t", *GRADED, *QUIET)
    assert abs(s["radius_mm"] / R_INF - 1) < 0.01          # measured +0.80 % (refine 2: +0.42 %)
    assert abs(s["length_mm"] / L_INF - 1) < 0.01          # measured +0.28 % (refine 2: +0.09 %)
    assert s["max_energy_balance_error"] < 0.01


def punch_force_at(out, travel_mm):
    h = history(out)
    return np.interp(travel_mm, h["punch_displacement_mm"], h["punch_force_kN"])


@pytest.mark.slow
@pytest.mark.parametrize("mu", [0.0, 0.15])
def test_punch_quarter_matches_the_axisymmetric_force(tmp_path, mu):
    sets = (f"contact.*.friction={mu}", *QUIET)
    run_scene(DEMOS / "punch_stretching.toml", tmp_path / "axi", *sets)
    run_scene(DEMOS / "punch_stretching_3d.toml", tmp_path / "3d", *sets)
    for travel in (20.0, 30.0, 40.0):
        axi, quarter = punch_force_at(tmp_path / "axi", travel), punch_force_at(tmp_path / "3d", travel)
        assert quarter == pytest.approx(axi, rel=0.02), travel


@pytest.mark.slow
def test_oblique_impact_completes_with_the_contact_work_in_the_balance(tmp_path):
    s = run_scene(DEMOS / "taylor_bar_oblique.toml", tmp_path / "o", *QUIET)
    assert s["converged"] and s["max_energy_balance_error"] < 0.01
    assert s["contact_work_J"] > 0.0
    # the foot spreads away from the edge that touched first (x = -R): asymmetric about the axis
    assert s["foot_max_x_mm"] > 2.0 * abs(s["foot_min_x_mm"])
    assert s["max_wall_force_x_kN"] > 0.05 * s["max_wall_force_z_kN"]


@pytest.mark.mpi
def test_oblique_impact_serial_equals_two_ranks(tmp_path):
    """3-D explicit penalty contact with friction (plane tool, two pairs) under MPI: the first 5 µs of
    the oblique impact give the same wall force, foot, energies and contact work on 1 and 2 ranks."""
    sets = ("analysis.end_time=5", *QUIET)
    one = run_scene(DEMOS / "taylor_bar_oblique.toml", tmp_path / "one", *sets)
    two = run_scene(DEMOS / "taylor_bar_oblique.toml", tmp_path / "two", *sets, np_ranks=2)
    assert two["mpi_ranks"] == 2 and two["steps"] == one["steps"]
    assert one["contact_work_J"] > 0.1 and one["max_wall_force_z_kN"] > 10.0
    for k in ("wall_force_z_kN", "wall_force_x_kN", "foot_min_x_mm", "foot_max_x_mm", "length_mm", "max_eqps",
              "kinetic_energy_J", "plastic_dissipation_J", "contact_work_J"):
        assert two[k] == pytest.approx(one[k], rel=1e-9, abs=1e-12), k
