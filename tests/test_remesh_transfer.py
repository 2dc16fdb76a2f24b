"""State transfer onto a new mesh (fenics_plast.remeshing.transfer, issue 35).

Old mesh: 2N x N distorted structured quadrilaterals of the 2 x 1 mm rectangle; new mesh: Gmsh's
unstructured quadrilaterals of the same rectangle (tests/mpi_remesh_transfer.py builds both). Shown:
second order in L2 for smooth fields (measured: about 2), linear fields and constants exact, b_e^-1
symmetric positive definite, no new extrema, the same mesh given back within the recovery error,
points outside the old body, P0 and CG1 fields, serial = two ranks.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from fenics_plast import dolfinx_compat as dc
from fenics_plast.remeshing import transfer as tr
from fenics_plast.state_variables import STATE, StateVariable

sys.path.insert(0, str(Path(__file__).resolve().parent))
import mpi_remesh_transfer as fx  # noqa: E402
from scene_runs import needs_mpirun, serial_and_two_ranks  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
COMM = MPI.COMM_WORLD
SIZES = (8, 16, 32)


def norms(mesh, error):
    """(L2 norm, max) over the owned quadrature points of ``mesh`` of error (n,) or (n, ...) (Frobenius)."""
    e2 = np.asarray(error).reshape(len(error), -1)
    e2 = (e2 * e2).sum(axis=1)
    vol = tr.quadrature_volumes(mesh, 2).reshape(-1)
    return (np.sqrt(COMM.allreduce(float(e2 @ vol))), np.sqrt(COMM.allreduce(float(e2.max(initial=0.0)), op=MPI.MAX)))


def order(errors):
    """Observed orders between successive halvings of h."""
    e = np.asarray(errors)
    return np.log2(e[:-1] / e[1:])


@pytest.fixture(scope="module")
def convergence():
    """Errors (L2, max) of eqps, log b_e^-1 and T transferred from structured(N) onto unstructured(H/N)."""
    rows = []
    for n in SIZES:
        old, new = fx.structured(COMM, n), fx.unstructured(COMM, fx.H / n)
        state, report = tr.StateTransfer(old).quadrature_state(fx.state_at(tr.quadrature_points(old, 2)), new)
        p = tr.quadrature_points(new, 2)
        exact = fx.state_at(p)
        rows.append({"eqps": norms(new, state["eqps"] - exact["eqps"]),
                     "log_binv": norms(new, tr.spd_log(state["binv"]) - fx.log_binv(p[:, 0], p[:, 1])),
                     "temperature": norms(new, state["temperature"] - exact["temperature"]),
                     "state": state, "report": report})
    return rows


@pytest.mark.parametrize("name", ["eqps", "log_binv", "temperature"])
def test_smooth_fields_converge_at_second_order_in_l2(convergence, name):
    l2 = [r[name][0] for r in convergence]
    mx = [r[name][1] for r in convergence]
    print(f"{name}: L2 {l2}, orders {order(l2)}; max {mx}, orders {order(mx)}")
    assert (order(l2) > 1.5).all(), (l2, order(l2))
    # max: second order where the extremum is inside; first order where it lies on the boundary (eqps
    # here, at y = 0), since the clip to the old points' range holds new points nearer the boundary
    assert order(mx[::2])[0] / 2 > 1.0, (mx, order(mx))


def test_binv_symmetric_positive_definite_and_no_new_extrema(convergence):
    for r in convergence:
        binv = r["state"]["binv"]
        assert np.array_equal(binv, np.swapaxes(binv, 1, 2))
        assert np.linalg.eigvalsh(binv).min() > 0
        for name in ("eqps", "temperature"):
            (old_lo, old_hi), (lo, hi) = r["report"].ranges[name]["old"], r["report"].ranges[name]["new"]
            assert old_lo <= lo and hi <= old_hi
        assert r["report"].outside == 0


def test_rough_binv_stays_positive_definite():
    """Random b_e^-1 from point to point, eigenvalues over several orders of magnitude (the
    extrapolation overshoots far): still symmetric positive definite; eqps with jumps stays in
    [0, old max]."""
    old, new = fx.structured(COMM, 6), fx.unstructured(COMM, fx.H / 9)
    n = len(tr.quadrature_points(old, 2))
    rng = np.random.default_rng(7 + COMM.rank)
    A = rng.normal(size=(n, 3, 3))
    eqps = np.where(rng.random(n) < 0.3, 0.0, rng.random(n))
    old_state = {"binv": tr.spd_exp(A + np.swapaxes(A, 1, 2)), "eqps": eqps}
    state, report = tr.StateTransfer(old).quadrature_state(old_state, new)
    assert np.linalg.eigvalsh(state["binv"]).min() > 0
    assert state["eqps"].min() >= 0.0
    assert COMM.allreduce(state["eqps"].max(), op=MPI.MAX) <= report.ranges["eqps"]["old"][1]
    assert report.clipped["eqps"] > 0


@pytest.mark.parametrize("axisymmetric", [False, True])
def test_constants_and_linear_fields_exact(axisymmetric):
    old, new = fx.structured(COMM, 5), fx.unstructured(COMM, fx.H / 7)
    p, q = tr.quadrature_points(old, 2), tr.quadrature_points(new, 2)

    def linear(x):
        L = np.zeros((len(x), 3, 3))
        L[:, 0, 0], L[:, 1, 1], L[:, 2, 2] = 0.01 * x[:, 0], -0.02 * x[:, 1], 0.003
        L[:, 0, 1] = L[:, 1, 0] = 0.01 + 0.004 * x[:, 0] - 0.007 * x[:, 1]
        return L
    old_state = {"binv": tr.spd_exp(linear(p)), "eqps": 0.1 + 0.2 * p[:, 0] - 0.1 * p[:, 1],
                 "temperature": np.full(len(p), 293.15)}
    transfer = tr.StateTransfer(old, axisymmetric=axisymmetric)
    state, report = transfer.quadrature_state(old_state, new, clip=False)
    assert np.abs(state["binv"] - tr.spd_exp(linear(q))).max() < 1e-12
    assert np.abs(state["eqps"] - (0.1 + 0.2 * q[:, 0] - 0.1 * q[:, 1])).max() < 1e-12
    assert np.abs(state["temperature"] - 293.15).max() < 1e-12
    # clipped (the default): exact where the linear value lies within the old points' range, the
    # bound elsewhere (new points nearer the boundary than the old ones)
    clipped, report = transfer.quadrature_state(old_state, new)
    lo, hi = report.ranges["eqps"]["old"]
    assert np.abs(clipped["eqps"] - np.clip(state["eqps"], lo, hi)).max() < 1e-12
    assert np.abs(clipped["temperature"] - 293.15).max() < 1e-12
    # a scalar per point on its own (the reference volume ratio): the scalars' rule, the same values
    ratio = 1.0 - 0.002 * p[:, 0] + 0.001 * p[:, 1]
    expected = np.clip(1.0 - 0.002 * q[:, 0] + 0.001 * q[:, 1], *transfer._range(ratio))
    assert np.abs(transfer.point_values(ratio, new) - expected).max() < 1e-12


def test_deformed_coordinates_given_as_x():
    """The old mesh left in its reference shape with the deformed node coordinates given as ``x``
    transfers as the mesh moved there."""
    flat, moved = fx.structured(COMM, 6, distortion=0.0), fx.structured(COMM, 6)
    new = fx.unstructured(COMM, fx.H / 5)
    old_state = fx.state_at(tr.quadrature_points(moved, 2))
    a, _ = tr.StateTransfer(moved).quadrature_state(old_state, new)
    b, _ = tr.StateTransfer(flat, x=moved.geometry.x.copy()).quadrature_state(old_state, new)
    assert np.abs(tr.quadrature_points(flat, 2, x=moved.geometry.x) - tr.quadrature_points(moved, 2)).max() == 0
    for name in a:
        assert np.abs(a[name] - b[name]).max() < 1e-14


@pytest.mark.parametrize("shift", [0.1, 0.2])
def test_nonconvex_old_cell(shift):
    """One old node moved towards the far corner of a cell, which becomes non-convex (shift 0.2: an
    arrowhead, as a cell folding around a tool edge): every new point of a linear field gets the exact
    value, or (not found in any cell) one within slope x distance of it."""
    old = fx.structured(COMM, 4, distortion=0.0)                       # cells of 0.25 mm
    x = old.geometry.x
    node = np.flatnonzero(np.isclose(x[:, 0], 1.0) & np.isclose(x[:, 1], 0.5))
    x[node, :2] += shift
    new = fx.unstructured(COMM, 0.05)
    p, q = tr.quadrature_points(old, 2), tr.quadrature_points(new, 2)
    state, report = tr.StateTransfer(old).quadrature_state({"eqps": 1.0 + 2.0 * p[:, 0] - 1.5 * p[:, 1]}, new,
                                                           clip=False)
    where = tr.locate(tr.OldBody(old), q)
    error = np.abs(state["eqps"] - (1.0 + 2.0 * q[:, 0] - 1.5 * q[:, 1]))
    assert error[~where.outside].max(initial=0.0) < 1e-12
    assert (error[where.outside] <= 2.5 * where.distance[where.outside] + 1e-12).all()
    print(f"shift {shift}: {report.outside} of {report.points} points in no cell, "
          f"max distance {report.max_distance:.2e}")


def test_same_mesh_gives_the_data_back_within_the_recovery_error():
    """Onto the same mesh: a continuous piecewise-Q1 field at the Gauss points comes back exactly;
    a smooth field within the extrapolation-averaging error, O(h^2)."""
    errors = []
    for n in (8, 16):
        mesh = fx.structured(COMM, n)
        transfer = tr.StateTransfer(mesh)
        corners = tr.cell_corners(mesh)
        nodal = fx.eqps(corners[..., 0], corners[..., 1])                      # continuous Q1 field
        X, _ = dc.quadrature_rule("quadrilateral", 2)
        q1 = np.einsum("qk,ck->cq", tr.shape_functions(X), nodal).reshape(-1)
        back, _ = transfer.quadrature_state({"eqps": q1}, mesh)
        assert np.abs(back["eqps"] - q1).max() < 1e-12
        p = tr.quadrature_points(mesh, 2)
        smooth = fx.state_at(p)
        back, _ = transfer.quadrature_state(smooth, mesh)
        errors.append(norms(mesh, back["eqps"] - smooth["eqps"])[0])
        assert np.abs(tr.spd_log(back["binv"]) - fx.log_binv(p[:, 0], p[:, 1])).max() < 1e-3
    assert errors[0] < 2e-3 and order(errors)[0] > 1.5, errors


def test_points_outside_the_old_body_take_the_nearest_boundary_value():
    """A new outline 1 % wider and taller than the old body: the points outside are found, at most
    about 1 % of the size away, and take values of the old boundary (within the old range)."""
    old, new = fx.structured(COMM, 8), fx.unstructured(COMM, fx.H / 8, width=1.01 * fx.W, height=1.01 * fx.H)
    old_state = fx.state_at(tr.quadrature_points(old, 2))
    state, report = tr.StateTransfer(old).quadrature_state(old_state, new)
    assert report.outside > 0 and 0 < report.max_distance < 0.011 * fx.W
    lo, hi = report.ranges["eqps"]["old"]
    assert lo <= state["eqps"].min() and state["eqps"].max() <= hi
    # a point outside a corner of the old body takes the corner's value
    body = tr.OldBody(old)
    where = tr.locate(body, np.array([[fx.W + 0.01, fx.H + 0.02], [fx.W / 2, -0.01], [0.3, 0.4]]))
    assert where.outside.tolist() == [True, True, False]
    x = tr.bilinear(body.corners, where.cells, where.xi)
    assert np.allclose(x[0], [fx.W, fx.H]) and np.allclose(x[1], [fx.W / 2, 0.0]) and np.allclose(x[2], [0.3, 0.4])


def test_cell_values():
    """P0: constants exact, a smooth field at first order at least, ``conserve`` keeps the integral."""
    errors = []
    for n in (8, 16, 32):
        old, new = fx.structured(COMM, n), fx.unstructured(COMM, fx.H / n)
        transfer = tr.StateTransfer(old)
        n_old = len(tr.cell_corners(old))
        assert np.abs(transfer.cell_values(np.full(n_old, 7.8e-9), new) - 7.8e-9).max() < 1e-20
        c_old, c_new = tr.cell_corners(old).mean(axis=1), tr.cell_corners(new).mean(axis=1)
        new_values = transfer.cell_values(fx.eqps(c_old[:, 0], c_old[:, 1]), new)
        vol = tr.quadrature_volumes(new, 2).sum(axis=1)
        errors.append(np.sqrt(COMM.allreduce(float(((new_values - fx.eqps(c_new[:, 0], c_new[:, 1])) ** 2) @ vol))))
        rho = 7.8e-9 * (1 + 0.1 * np.sin(3 * c_old[:, 0]))
        kept = transfer.cell_values(rho, new, conserve=True)
        old_vol = tr.quadrature_volumes(old, 2).sum(axis=1)
        assert abs(COMM.allreduce(float(kept @ vol)) / COMM.allreduce(float(rho @ old_vol)) - 1) < 1e-12
    print("P0 L2 errors", errors, "orders", order(errors))
    assert (order(errors) > 0.9).all(), errors


def test_nodal_function_linear_exact():
    import dolfinx.fem as fem
    old, new = fx.structured(COMM, 5), fx.unstructured(COMM, fx.H / 7)
    V_old, V_new = dc.vector_space(old), dc.vector_space(new)
    v_old, v_new = fem.Function(V_old), fem.Function(V_new)

    def field(x):
        return np.stack([1.0 + 2.0 * x[:, 0] - x[:, 1], -0.5 + 0.25 * x[:, 0] + 3.0 * x[:, 1]], axis=1)
    v_old.x.array[:] = field(V_old.tabulate_dof_coordinates()).reshape(-1)
    tr.StateTransfer(old).nodal_function(v_old, v_new)
    assert np.abs(v_new.x.array - field(V_new.tabulate_dof_coordinates()).reshape(-1)).max() < 1e-12


def test_rules_by_shape():
    old = fx.structured(COMM, 3)
    n = len(tr.quadrature_points(old, 2))
    transfer = tr.StateTransfer(old)
    with pytest.raises(NotImplementedError, match="backstress"):
        transfer.quadrature_state({"backstress": np.zeros((n, 6))}, old,
                                  variables=[StateVariable("backstress", (6,), "zero", "back stress")])
    bad = np.tile(np.diag([1.0, 1.0, -1.0]), (n, 1, 1))
    with pytest.raises(ValueError, match="positive definite"):
        transfer.quadrature_state({"binv": bad}, old)
    # every declared variable has a rule
    assert all(v.shape in tr.RULES for v in STATE)


@needs_mpirun
def test_serial_equals_two_ranks(tmp_path):
    a, b = serial_and_two_ranks(REPO / "tests" / "mpi_remesh_transfer.py", [8], tmp_path)
    assert int(a["ranks"]) == 1 and int(b["ranks"]) == 2
    for name in ("eqps", "binv", "temperature", "cells", "nodal"):
        assert a[name].shape == b[name].shape and len(a[name]) > 0
        assert np.abs(a[name] - b[name]).max() <= 1e-12, name
