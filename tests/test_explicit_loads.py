"""Prescribed motion and external loads in explicit analyses (ExplicitDynamics drivers).

Small elastic bars (2 x 10 mm, nu = 0 so that the 1-D wave theory is exact), against closed forms:
a prescribed end velocity sends a wave whose reaction is rho c V A and whose work is what the bar
stores; a prescribed displacement is met exactly at the step ends and at the end time; a traction
on a free bar accelerates its centre of mass at F / m; the drivers' arguments are checked.
"""
import math

import numpy as np
import pytest
from mpi4py import MPI

from fenics_plast.kinematics import Kinematics
from fenics_plast.material import Material
from fenics_plast.meshing import bar_mesh
from fenics_plast.solvers.explicit import ExplicitDynamics

E, RHO, R, L = 200e3, 7.8e-9, 2.0, 10.0        # MPa, tonne/mm^3, mm, mm
C = math.sqrt(E / RHO)                          # bar wave speed (nu = 0) [mm/s]


def bar(geometry="axisymmetric", route="fused", fix_bottom=True, nz=20, comm=MPI.COMM_WORLD):
    mesh, _, ft, tags = bar_mesh(comm, R, L, 2, nz)
    kin = Kinematics(mesh, geometry)
    bcs = [(0, ft.find(tags["axis"]))] + ([(1, ft.find(tags["bottom"]))] if fix_bottom else [])
    s = ExplicitDynamics(mesh, kin, Material(E, 0.0, None), RHO, bcs, log=lambda m: None, internal_force=route)
    return s, ft, tags


def area(geometry):
    return math.pi * R ** 2 if geometry == "axisymmetric" else R


def top_values(s, nodes, arr):
    """(min, max) over all ranks of the y entries of ``arr`` at the owned nodes among ``nodes``."""
    own = 2 * nodes + 1
    own = own[own < s.n_own]
    loc = (arr[own].min(), arr[own].max()) if own.size else (np.inf, -np.inf)
    return s.comm.allreduce(loc[0], op=MPI.MIN), s.comm.allreduce(loc[1], op=MPI.MAX)


@pytest.mark.parametrize("geometry", ["axisymmetric", "plane_strain"])
def test_prescribed_velocity_reaction_and_work(geometry):
    """Top pulled at V(t) = V0 min(t / tr, 1), bottom fixed: before the wave comes back (t < 2 L / c)
    the reaction is rho c V A, its work rho c A V0^2 (t - 2 tr / 3), equal to KE + W_int; the top
    has moved by V0 (t - tr / 2)."""
    s, ft, tags = bar(geometry)
    V0, tr = 1e3, 0.2 * L / C
    top = s.boundary_dofs(ft.find(tags["top"]))
    k = s.add_prescribed_velocity(1, top, lambda t: V0 * min(t / tr, 1.0), name="top")
    T = 1.5 * L / C
    stats = s.run(T, rows=2, progress=0)
    A = area(geometry)
    Fx, Fy = s.reaction(k)
    assert Fx == 0.0
    assert Fy == pytest.approx(RHO * C * V0 * A, rel=0.01)          # pulls the bar up (tension)
    W = s.prescribed_work(k)
    assert W == pytest.approx(RHO * C * A * V0 ** 2 * (T - 2 * tr / 3), rel=0.01)
    e = s.energies()
    assert e["prescribed_work"] == pytest.approx(W) and e["external_work"] == pytest.approx(W)
    assert abs(e["kinetic"] + e["internal_work"] - W) < 0.01 * W
    assert e["balance_error"] < 0.01
    lo, hi = top_values(s, top, s.u.x.array)
    # the half-step velocities are V at the midpoints: exact but on the step that holds the ramp's
    # kink, where the midpoint rule errs by at most (V0 / tr) dt^2 / 8
    kink = V0 / tr * stats["dt_max"] ** 2 / 8
    assert abs(lo - V0 * (T - tr / 2)) <= kink and hi == pytest.approx(lo, rel=1e-12)
    lo, hi = top_values(s, top, s.v.x.array)
    assert lo == hi == V0


def test_prescribed_displacement_reached_at_step_ends():
    """d(t) = D (1 - cos(pi t / T)) / 2 on the top: u = d(t) at every history row and at the end
    time (the run lands on the row times), energy balanced."""
    s, ft, tags = bar("axisymmetric")
    D, T = -0.01, 3 * L / C
    top = s.boundary_dofs(ft.find(tags["top"]))

    def d(t):
        return D * (1.0 - math.cos(math.pi * t / T)) / 2.0

    k = s.add_prescribed_displacement(1, top, d)
    seen = []

    def on_row(so, t):
        lo, hi = top_values(so, top, so.u.x.array)
        seen.append(t)
        assert lo == pytest.approx(d(t), rel=1e-12, abs=1e-18) and hi == pytest.approx(d(t), rel=1e-12, abs=1e-18)

    s.run(T, rows=7, progress=0, on_row=on_row)
    assert len(seen) == 7 and seen[-1] == pytest.approx(T)
    assert top_values(s, top, s.u.x.array)[0] == pytest.approx(D, rel=1e-12)
    # the final velocity is d'(T) = 0 (central difference of d)
    assert abs(top_values(s, top, s.v.x.array)[0]) < 1e-6 * abs(D) / T
    e = s.energies()
    assert e["prescribed_work"] > 0 and e["balance_error"] < 0.01
    assert s.reaction(k)[1] != 0.0


@pytest.mark.parametrize("geometry,route", [("axisymmetric", "fused"), ("plane_strain", "fused"),
                                            ("axisymmetric", "ufl")])
def test_traction_on_free_bar_gives_rigid_body_acceleration(geometry, route):
    """A free bar (no support) under a top traction p(t) = -p0 (1 + t / T): the centre of mass
    moves at v = F-impulse / m exactly (F = p A, m = rho A L), and KE + W_int = W_load."""
    s, ft, tags = bar(geometry, route=route, fix_bottom=False)
    p0, T = 5.0, 2 * L / C
    s.add_traction(ft, tags["top"], (0.0, lambda t: -p0 * (1.0 + t / T)))
    s.run(T, rows=3, progress=0)
    A = area(geometry)
    m = RHO * A * L
    v = s.v.x.array[: s.n_own].reshape(-1, 2)
    mv = s.comm.allreduce((s.mass.reshape(-1, 2) * v).sum(axis=0), op=MPI.SUM)
    M = s.comm.allreduce(float(s.mass[0::2].sum()), op=MPI.SUM)
    assert M == pytest.approx(m, rel=1e-12)
    impulse = -p0 * A * (T + T / 2)                                  # int_0^T p(t) A dt
    assert mv[1] / m == pytest.approx(impulse / m, rel=1e-10)
    assert abs(mv[0]) < 1e-9 * abs(mv[1])
    e = s.energies()
    assert e["load_work"] > 0
    assert abs(e["kinetic"] + e["internal_work"] - e["load_work"]) < 0.01 * e["load_work"]


def test_external_force_callable_equals_traction():
    """The same nodal load given as a callable of t: the same run to round-off."""
    out = []
    for how in ("traction", "callable"):
        s, ft, tags = bar("axisymmetric", fix_bottom=False, nz=10, comm=MPI.COMM_SELF)
        if how == "traction":
            s.add_traction(ft, tags["top"], (0.0, lambda t: -5.0 * t / 1e-6))
        else:
            s.add_traction(ft, tags["top"], (0.0, 1.0))
            base = s.drivers.load_vector(0.0).copy()               # the unit-traction load vector [N]
            s.drivers.loads.clear()
            s.add_external_force(lambda t: (-5.0 * t / 1e-6) * base)
        s.run(2e-6, rows=2, progress=0)
        out.append(s.u.x.array.copy())
    assert np.abs(out[0] - out[1]).max() <= 1e-12 * np.abs(out[0]).max()


def test_driver_arguments_are_validated():
    s, ft, tags = bar("axisymmetric", nz=4)
    bottom = s.boundary_dofs(ft.find(tags["bottom"]))
    top = s.boundary_dofs(ft.find(tags["top"]))
    with pytest.raises(ValueError, match="already constrained"):
        s.add_prescribed_velocity(1, bottom, 1.0)                   # held by velocity_bcs
    with pytest.raises(ValueError, match="component"):
        s.add_prescribed_velocity(2, top, 1.0)
    with pytest.raises(ValueError, match="block"):
        s.add_prescribed_velocity(1, top + s.u.x.array.size, 1.0)  # not node indices
    with pytest.raises(ValueError, match="already constrained"):
        s.add_prescribed_velocity(0, top, 0.5)                      # the axis node's u_r is held
    s.add_prescribed_displacement(1, top, 0.0)
    with pytest.raises(ValueError, match="already constrained"):
        s.add_prescribed_velocity(1, top, 1.0)
    s.add_external_force(lambda t: np.zeros(3))
    with pytest.raises(ValueError, match="owned dofs expected"):
        s.initialize()
