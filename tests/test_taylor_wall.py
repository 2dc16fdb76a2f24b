"""The Taylor bar against a rigid contact wall (demos/taylor_bar_wall.toml) and the sliding support.

The scene replaces the sliding support of demos/taylor_bar.toml (u_z = 0 on the impact face) by a
rigid plane and explicit penalty contact on the face. The two problems differ in ways the tests
measure (the scene file's header explains them):

* the support holds the face nodes at rest from t = 0, so the wall run starts with the kinetic
  energy of one more row of nodes: a share 1 / (2 cells_axial) of the mass, exactly;
* the wall only pushes: the face's outer edge lifts off where the support pulls it down, and the
  radius (the corner node's r) comes out larger, by 4.4 % at the 3 x 18 cells used here, 3.4 % at
  the scene's 6 x 36, 2.6 % at 12 x 72; the length agrees to 0.19 %, 0.06 %, 0.10 %;
* plastic dissipation over the initial kinetic energy agrees to 0.1 % (3 x 18) and 0.24 % (6 x 36).

Fast tests run 3 x 18 cells (1-2 s a run); the scene's own mesh is @slow.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import scene_runs

ROOT = Path(__file__).resolve().parent.parent
WALL = ROOT / "demos" / "taylor_bar_wall.toml"
SLIDING = ROOT / "demos" / "taylor_bar.toml"
NZ = 18
COARSE = ("mesh.parameters.cells_radial=3", f"mesh.parameters.cells_axial={NZ}")
#: the physics of a run (serial against 2 ranks); steps, times and checkpoints are not physics
PHYSICS = ("radius_mm", "length_mm", "max_eqps", "face_lift_mm", "max_face_lift_mm", "max_wall_force_kN",
           "kinetic_energy_J", "elastic_energy_J", "plastic_dissipation_J", "contact_work_J", "contact_stored_J",
           "face_max_penetration_mm")


def run_scene(scene, out, *sets, np_ranks=1):
    """summary.json and history.csv of one run (no fields, no figures)."""
    summary = scene_runs.run_scene(scene, out, "output.xdmf=false", "output.plots=false", *sets, np_ranks=np_ranks)
    summary["history"] = scene_runs.history(out)
    return summary


def ke0(s):
    return float(s["history"]["kinetic_energy_J"][0])


@pytest.fixture(scope="module")
def coarse(tmp_path_factory):
    """Sliding support, wall mu = 0 and wall mu = 0.1 at 3 x 18 cells, 80 us."""
    base = tmp_path_factory.mktemp("taylor_wall")
    return {"sliding": run_scene(SLIDING, base / "sliding", *COARSE),
            0.0: run_scene(WALL, base / "wall_mu0", *COARSE),
            0.1: run_scene(WALL, base / "wall_mu0.1", *COARSE, "contact.face.friction=0.1")}


def compare_with_sliding(wall, sliding, nz, radius_max, length_tol, dissipation_tol):
    # the support starts the face nodes at rest: one row of nodes, 1 / (2 nz) of the mass, less KE0
    assert ke0(sliding) == pytest.approx(ke0(wall) * (1.0 - 1.0 / (2 * nz)), rel=1e-12)
    # the wall lets the outer edge lift off (the support holds it): larger radius, same length
    assert 0.0 < wall["radius_mm"] / sliding["radius_mm"] - 1.0 < radius_max
    assert wall["max_face_lift_mm"] > 0.1
    assert wall["length_mm"] == pytest.approx(sliding["length_mm"], rel=length_tol)
    # what each run dissipates of the energy it starts with
    assert wall["plastic_dissipation_J"] / ke0(wall) == pytest.approx(
        sliding["plastic_dissipation_J"] / ke0(sliding), rel=dissipation_tol)


def test_frictionless_wall_against_the_sliding_support(coarse):
    """Measured at 3 x 18: radius +4.43 %, length -0.19 %, dissipation / KE0 +0.10 %."""
    compare_with_sliding(coarse[0.0], coarse["sliding"], NZ, radius_max=0.06, length_tol=5e-3, dissipation_tol=5e-3)


@pytest.mark.parametrize("mu", [0.0, 0.1])
def test_energy_balance_includes_the_contact_work(coarse, mu):
    """KE + W_int + E_c = KE0 within 1 % over the whole run (measured, mu = 0 / 0.1: 0.06 % / 0.10 % at the
    end, 0.50 % / 0.50 % at worst, at the first history row, 0.5 us into the impact); friction dissipates."""
    s = coarse[mu]
    assert s["energy_balance_error"] < 0.01
    assert s["max_energy_balance_error"] < 0.01
    assert np.all(s["history"]["energy_balance_error"] < 0.01)
    # the balance from the summary's own entries (plastic = W_int - elastic)
    w_int = s["elastic_energy_J"] + s["plastic_dissipation_J"]
    assert abs(s["kinetic_energy_J"] + w_int + s["contact_work_J"] - ke0(s)) < 0.01 * ke0(s)
    if mu == 0.0:
        # a fixed frictionless wall only stores energy in its springs: the rest is the penalty's
        # in-and-out error, measured 0.59 J = 0.25 % of KE0 (0.07 % at the scene's 6 x 36 cells)
        assert abs(s["contact_work_J"] - s["contact_stored_J"]) < 5e-3 * ke0(s)
    else:
        assert s["contact_work_J"] > 0.02 * ke0(s)          # friction work, measured 6.29 J = 2.6 %
    # penetration small against the cell (1.8 mm axially here; measured 0.078 and 0.068 mm)
    assert s["face_max_penetration_mm"] < 0.1 * 32.4 / NZ


def test_friction_gives_a_smaller_radius(coarse):
    """mu = 0.1 holds the face back: radius 6.844 against 7.244 mm (-5.5 %), the bar ends longer."""
    r0, r1 = coarse[0.0]["radius_mm"], coarse[0.1]["radius_mm"]
    assert r1 < 0.97 * r0
    assert coarse[0.1]["length_mm"] > coarse[0.0]["length_mm"]
    assert coarse[0.1]["face_lift_mm"] < 0.5 * coarse[0.0]["face_lift_mm"]      # friction keeps the edge down


@pytest.mark.mpi
@pytest.mark.parametrize("mu", [0.0, 0.1])
def test_serial_equals_two_ranks(coarse, tmp_path, mu):
    """Same steps; results to 1e-8 (measured: 5e-11 at worst, history and summary)."""
    s2 = run_scene(WALL, tmp_path / "mpi", *COARSE, f"contact.face.friction={mu}", np_ranks=2)
    s1 = coarse[mu]
    assert s2["mpi_ranks"] == 2 and s2["steps"] == s1["steps"]
    for k in PHYSICS:
        assert s2[k] == pytest.approx(s1[k], rel=1e-8, abs=1e-12), k
    for col in s1["history"].dtype.names:
        np.testing.assert_allclose(s2["history"][col], s1["history"][col], rtol=1e-8, atol=1e-10, err_msg=col)


def test_a_node_in_two_pairs_has_both_springs_in_the_stable_step():
    """The corner of face and side, in a pair of each: 2 sqrt(m / (eps (A_face + A_side)))."""
    from mpi4py import MPI

    from fenics_plast.kinematics import Kinematics
    from fenics_plast.material import Material
    from fenics_plast.meshing import bar_mesh
    from fenics_plast.solvers.explicit import ExplicitDynamics
    from fenics_plast.tools import Plane

    mesh, _, ft, tags = bar_mesh(MPI.COMM_SELF, 3.2, 10.0, 3, 6)
    s = ExplicitDynamics(mesh, Kinematics(mesh, "axisymmetric"), Material(117e3, 0.35), 8.93e-9,
                         [(0, ft.find(tags["axis"]))], log=lambda m: None)
    eps = 1e6
    face = s.add_contact(Plane(), ft, tags["bottom"], penalty=eps)
    side = s.add_contact(Plane(), ft, tags["outer"], penalty=eps)
    corner = lambda p: int(np.flatnonzero(np.isclose(p.X[:, 0], 3.2) & np.isclose(p.X[:, 1], 0.0))[0])
    i, j = corner(face), corner(side)
    assert face.dofs[i, 0] == side.dofs[j, 0]
    m = s.mass[face.dofs[i, 0]]
    expected = 2.0 * math.sqrt(m / (eps * (face.area[i] + side.area[j])))
    assert s.contact.dt_stable == pytest.approx(expected, rel=1e-12)
    assert s.contact.dt_stable < min(face.dt_stable, side.dt_stable)


# ----------------------------------------------------------------------------------------------
# the scene's own mesh (6 x 36 cells): 2-3 s a run

#: measured (serial): demos/taylor_bar.toml and demos/taylor_bar_wall.toml with mu = 0, 0.1 (again
#: after the solver began to cut each history-row interval into equal steps: radius and length moved
#: by < 1e-3, the corner's max eqps by 3 %)
FULL = {"sliding": {"radius_mm": 7.083917111942336, "length_mm": 21.454488965782005, "max_eqps": 3.1166009922516458},
        0.0: {"radius_mm": 7.321328053387344, "length_mm": 21.447537998424465, "max_eqps": 4.212759554550654},
        0.1: {"radius_mm": 6.869701661183889, "length_mm": 21.581164102835338, "max_eqps": 3.158370755309511}}


@pytest.fixture(scope="module")
def full(tmp_path_factory):
    base = tmp_path_factory.mktemp("taylor_wall_full")
    return {"sliding": run_scene(SLIDING, base / "sliding"), 0.0: run_scene(WALL, base / "wall_mu0"),
            0.1: run_scene(WALL, base / "wall_mu0.1", "contact.face.friction=0.1")}


@pytest.mark.slow
def test_full_resolution_wall_against_the_sliding_support(full):
    """Radius +3.35 %, length -0.03 %, dissipation / KE0 +0.1 %; mu = 0.1: radius -6.2 % from mu = 0;
    energy balance within 0.05 % throughout; penetration 0.066 mm (7 % of the 0.9 mm cell)."""
    for run, ref in FULL.items():
        for k, v in ref.items():
            assert full[run][k] == pytest.approx(v, rel=1e-6), (run, k)
    compare_with_sliding(full[0.0], full["sliding"], 36, radius_max=0.045, length_tol=2e-3, dissipation_tol=4e-3)
    assert full[0.1]["radius_mm"] < 0.95 * full[0.0]["radius_mm"]
    for mu in (0.0, 0.1):
        assert full[mu]["max_energy_balance_error"] < 0.005
        assert full[mu]["face_max_penetration_mm"] < 0.1 * 0.9
    assert abs(full[0.0]["contact_work_J"] - full[0.0]["contact_stored_J"]) < 1e-3 * ke0(full[0.0])


@pytest.mark.slow
@pytest.mark.mpi
def test_full_resolution_serial_equals_two_ranks(full, tmp_path):
    """Measured: 1e-11 in the physics, the same 10542 steps."""
    s2 = run_scene(WALL, tmp_path / "mpi", np_ranks=2)
    assert s2["steps"] == full[0.0]["steps"]
    for k in PHYSICS:
        assert s2[k] == pytest.approx(full[0.0][k], rel=1e-8, abs=1e-12), k
