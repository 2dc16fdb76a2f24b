"""3-D rigid analytic tools (fenics_plast.tools): Plane (3-vectors), Sphere, Cylinder, Torus and
RevolvedProfile.

Gaps and normals at hand-computed points; the UFL gap (a dolfinx Expression at points of a small,
displaced hexahedral mesh) against the numpy one; a RevolvedProfile of one line equal to a Plane
and to a Cylinder, of a full circle equal to a Torus; the guarded normals on the axis and at a
sphere's centre; translation along a 3-D path; bad input; the contact length scale of hexahedra.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx import mesh as dm
from mpi4py import MPI
from petsc4py import PETSc

from fenics_plast import dolfinx_compat as dc
from fenics_plast.tools import (Cylinder, Plane, RevolvedProfile, Sphere, Torus, contact_length_scale,
                                piecewise_path)

S2 = 1.0 / math.sqrt(2.0)
S3 = 1.0 / math.sqrt(3.0)


def check(tool, pts, g_ref, N_ref, t=0.0):
    g, N = tool.gap_np(np.array(pts, dtype=float), t)
    assert g == pytest.approx(np.array(g_ref, dtype=float), abs=1e-12)
    assert N == pytest.approx(np.array(N_ref, dtype=float), abs=1e-12)


# ----------------------------------------------------------------------------------------------
# closed forms


def test_plane_3d():
    wall = Plane((1.0, 2.0, 3.0), (0.0, 0.0, 2.0))                  # normalised
    assert wall.dim == 3
    check(wall, [[5.0, -1.0, 3.5], [0.0, 0.0, 1.0]], [0.5, -2.0], [[0, 0, 1], [0, 0, 1]])
    tilted = Plane((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    check(tilted, [[1.0, 1.0, 1.0], [1.0, -1.0, 0.0]], [math.sqrt(3.0), 0.0], [[S3, S3, S3]] * 2)
    assert Plane((0.0, 0.0), (0.0, 1.0)).dim == 2                   # 2-D unchanged


def test_sphere():
    b = Sphere((1.0, 0.0, -5.0), 5.0)
    check(b, [[1.0, 0.0, 1.0], [4.0, 4.0, -5.0], [1.0, 0.0, -9.0]], [1.0, 0.0, -1.0],
          [[0, 0, 1], [0.6, 0.8, 0], [0, 0, -1]])
    g, N = b.gap_np(np.array([[1.0, 0.0, -5.0]]), 0.0)              # the centre: guarded, not 0/0
    assert g[0] == pytest.approx(-5.0) and np.all(np.isfinite(N))


def test_cylinder():
    c = Cylinder((0.0, 0.0, 1.0), (0.0, 0.0, 7.0), 1.0)             # axis z, normalised
    check(c, [[3.0, 4.0, 7.0], [0.0, -0.5, -3.0]], [4.0, -0.5], [[0.6, 0.8, 0], [0, -1, 0]])
    tilted = Cylinder((0.0, 0.0, 0.0), (1.0, 1.0, 0.0), 2.0)        # axis along (1, 1, 0)
    check(tilted, [[5.0, 5.0, 3.0], [1.0, -1.0, 0.0]], [1.0, math.sqrt(2.0) - 2.0],
          [[0, 0, 1], [S2, -S2, 0]])
    g, N = c.gap_np(np.array([[0.0, 0.0, 4.0]]), 0.0)               # on the axis: guarded
    assert g[0] == pytest.approx(-1.0) and np.all(np.isfinite(N))


def test_torus_closed_form():
    """g = sqrt((rho - R)^2 + a^2) - r, N from the nearest point of the centre circle."""
    tor = Torus((1.0, 2.0, 3.0), (0.0, 0.0, 1.0), 5.0, 1.0)
    check(tor, [[8.0, 2.0, 3.0], [1.0, 7.0, 6.0], [1.0, 2.0 - 4.5, 3.0], [1.0, 2.0, 4.0], [4.0, 6.0, 4.0]],
          [1.0, 2.0, -0.5, math.sqrt(26.0) - 1.0, 0.0],           # (1, 2, 4): on the axis
          [[1, 0, 0], [0, 0, 1], [0, 1, 0], [0, 0, 1 / math.sqrt(26.0)], [0, 0, 1]])
    # random points against the closed form, a tilted axis
    axis = np.array([1.0, -2.0, 2.0]) / 3.0
    tor = Torus((0.5, 0.0, -1.0), (1.0, -2.0, 2.0), 4.0, 1.5)
    x = np.random.default_rng(0).uniform(-7.0, 7.0, (500, 3))
    y = x - np.array([0.5, 0.0, -1.0])
    a = y @ axis
    r = y - a[:, None] * axis
    rho = np.linalg.norm(r, axis=1)
    q = 4.0 * r / rho[:, None]                                       # nearest point of the centre circle
    dist = np.linalg.norm(y - q, axis=1)
    g, N = tor.gap_np(x, 0.0)
    assert np.abs(g - (dist - 1.5)).max() < 1e-12
    assert np.abs(N - (y - q) / dist[:, None]).max() < 1e-12


def test_revolved_profile_of_one_line_is_a_plane_and_a_cylinder():
    rng = np.random.default_rng(1)
    axis = np.array([0.0, 0.6, 0.8])
    center = np.array([0.3, -0.2, 0.5])
    x = center + rng.uniform(-3.0, 3.0, (400, 3))
    # a disc of radius 10 at a = 0, body on the +a side: the plane through center with normal axis
    disc = RevolvedProfile([("line", (0.0, 0.0), (10.0, 0.0))], center, axis)
    g, N = disc.gap_np(x, 0.0)
    gp, Np = Plane(center, axis).gap_np(x, 0.0)
    assert np.abs(g - gp).max() < 1e-12 and np.abs(N - Np).max() < 1e-12
    # a line at rho = 1.2 along the axis (|a| < 10), body outside: the cylinder
    tube = RevolvedProfile([("line", (1.2, 10.0), (1.2, -10.0))], center, axis)
    g, N = tube.gap_np(x, 0.0)
    gc, Nc = Cylinder(center, axis, 1.2).gap_np(x, 0.0)
    assert np.abs(g - gc).max() < 1e-12 and np.abs(N - Nc).max() < 1e-12
    assert (g < 0).any() and (g > 0).any()


def test_revolved_full_circle_is_the_torus():
    ring = [("arc", (5.0, 0.0), 1.0, 0.0, 180.0), ("arc", (5.0, 0.0), 1.0, 180.0, 360.0)]
    rev = RevolvedProfile(ring, (0.0, 1.0, 0.0), (1.0, 0.0, 1.0), body_side="right")
    tor = Torus((0.0, 1.0, 0.0), (1.0, 0.0, 1.0), 5.0, 1.0)
    x = np.random.default_rng(2).uniform(-8.0, 8.0, (1000, 3))
    g, N = rev.gap_np(x, 0.0)
    gt, Nt = tor.gap_np(x, 0.0)
    assert np.abs(g - gt).max() < 1e-12 and np.abs(N - Nt).max() < 1e-12


def test_revolved_profile_on_the_axis_and_a_flat_punch():
    """A flat-ended punch (face a = 0 out to rho 8, edge arc of radius 2, side rho = 10), the body
    below it: on the axis the normal is -axis (guarded e_rho), at the edge the arc's normal."""
    punch = RevolvedProfile([("line", (0.0, 0.0), (8.0, 0.0)), ("arc", (8.0, 2.0), 2.0, 270.0, 360.0),
                             ("line", (10.0, 2.0), (10.0, 30.0))], (0.0, 0.0, 0.0), (0.0, 0.0, 1.0),
                            body_side="right")
    c45 = math.cos(math.radians(45.0))
    edge = np.array([8.0 + 3.0 * c45, 0.0, 2.0 - 3.0 * c45])         # 3 mm from the arc's centre
    check(punch, [[0.0, 0.0, -1.5], [0.0, 3.0, 0.5], edge.tolist(), [-11.0, 0.0, 5.0]],
          [1.5, -0.5, 1.0, 1.0], [[0, 0, -1], [0, 0, -1], [c45, 0, -c45], [-1, 0, 0]])


def test_translation_along_a_path():
    path = piecewise_path([0.0, 0.5, 1.0], dx=[0.0, 0.0, 2.0], dy=[0.0, 1.0, 1.0], dz=[0.0, -1.0, -3.0])
    assert len(path(0.3, False)) == 3
    ball = Sphere((0.0, 0.0, 0.0), 1.0, path=path)
    assert ball.translation(0.75, use_ufl=False) == pytest.approx([1.0, 1.0, -2.0])
    check(ball, [[1.0, 1.0, 0.0]], [1.0], [[0, 0, 1]], t=0.75)        # centre at (1, 1, -2)
    # a 2-component path moves a 3-D tool in x and y only; 2-D paths keep 2 components
    flat = Plane((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), path=piecewise_path([0.0, 1.0], dx=[0.0, 1.0]))
    assert flat.translation(0.5, use_ufl=False) == pytest.approx([0.5, 0.0, 0.0])
    assert len(piecewise_path([0.0, 1.0], dx=[0.0, 1.0])(0.5, False)) == 2
    check(flat, [[2.0, 5.0, 5.0]], [1.5], [[1, 0, 0]], t=0.5)


def test_bad_input():
    with pytest.raises(ValueError, match="same dimension"):
        Plane((0.0, 0.0), (0.0, 0.0, 1.0))
    with pytest.raises(ValueError, match="non-zero"):
        Plane((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="3-vector"):
        Sphere((0.0, 0.0), 1.0)
    with pytest.raises(ValueError, match="radius"):
        Sphere((0.0, 0.0, 0.0), 0.0)
    with pytest.raises(ValueError, match="axis must be non-zero"):
        Cylinder((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 1.0)
    with pytest.raises(ValueError, match="ring_radius"):
        Torus((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), -1.0, 1.0)
    with pytest.raises(ValueError, match="rho"):
        RevolvedProfile([("line", (-1.0, 0.0), (5.0, 0.0))], (0.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    with pytest.raises(ValueError, match="rho"):
        RevolvedProfile([("arc", (0.5, 0.0), 1.0, 90.0, 270.0)], (0.0, 0.0, 0.0), (0.0, 0.0, 1.0))


# ----------------------------------------------------------------------------------------------
# UFL against numpy


def _tools_for_ufl():
    path = piecewise_path([0.0, 1.0], dx=[0.0, 0.3], dy=[0.0, -0.2], dz=[0.0, 0.1])
    die = [("line", (0.5, -1.5), (0.5, -0.4)), ("arc", (0.9, -0.4), 0.4, 180, 90), ("line", (0.9, 0.0), (2.5, 0.0))]
    return {
        "plane": Plane((0.1, 0.2, 0.3), (0.3, 1.0, -0.4), path=path),
        "sphere": Sphere((1.1, 0.4, 0.2), 0.7, path=path),
        "cylinder": Cylinder((0.9, 0.5, 0.0), (0.2, 1.0, 0.3), 0.6, path=path),
        "torus": Torus((0.8, 0.4, 0.1), (0.0, 0.3, 1.0), 0.9, 0.35, path=path),
        "revolved_die": RevolvedProfile(die, (0.9, 0.5, 0.3), (0.1, 0.2, 1.0), path=path),
    }


@pytest.mark.parametrize("name", list(_tools_for_ufl()))
def test_ufl_equals_numpy(name):
    tool = _tools_for_ufl()[name]
    msh = dm.create_box(MPI.COMM_WORLD, [np.array([-1.0, -1.0, -1.0]), np.array([3.0, 2.0, 1.5])], [4, 3, 3],
                        dm.CellType.hexahedron)
    V = dc.vector_space(msh)
    u = fem.Function(V)
    u.interpolate(lambda x: np.vstack([0.03 * np.sin(3 * x[1] + 1), 0.02 * np.cos(2 * x[0]), 0.02 * x[2] * x[0]]))
    x = ufl.SpatialCoordinate(msh) + u
    t = fem.Constant(msh, PETSc.ScalarType(0.7))
    g, N = tool.gap(x, t)
    q = np.array([[a, b, c] for a in (0.0, 0.37, 1.0) for b in (0.0, 0.61, 1.0) for c in (0.0, 0.29, 1.0)])
    cells = np.arange(msh.topology.index_map(3).size_local, dtype=np.int32)
    vals = dc.eval_expression(fem.Expression(ufl.as_vector([g, N[0], N[1], N[2]]), q), msh, cells).reshape(-1, 4)
    xs = dc.eval_expression(fem.Expression(x, q), msh, cells).reshape(-1, 3)
    g_np, N_np = tool.gap_np(xs, 0.7)
    assert np.max(np.abs(vals[:, 0] - g_np)) <= 1e-12
    assert np.max(np.abs(vals[:, 1:] - N_np)) <= 1e-12
    assert np.allclose(np.linalg.norm(N_np, axis=1), 1.0)
    assert (g_np < 0).any() and (g_np > 0).any()


def test_contact_length_scale_of_hexahedra():
    """Mean depth of the cells along a face = the cell size normal to it (also for a sheared box)."""
    msh = dm.create_box(MPI.COMM_WORLD, [np.zeros(3), np.array([2.0, 1.0, 1.5])], [4, 5, 3], dm.CellType.hexahedron)
    bot = dm.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.0))
    side = dm.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[0], 2.0))
    idx = np.concatenate([bot, side]).astype(np.int32)
    val = np.concatenate([np.full(len(bot), 1, np.int32), np.full(len(side), 2, np.int32)])
    o = np.argsort(idx)
    ft = dm.meshtags(msh, 2, idx[o], val[o])
    assert contact_length_scale(msh, ft, 1) == pytest.approx(0.5, rel=1e-12)
    assert contact_length_scale(msh, ft, 2) == pytest.approx(0.5, rel=1e-12)
    # shear x += 0.3 z: volumes and the bottom faces keep their size
    msh.geometry.x[:, 0] += 0.3 * msh.geometry.x[:, 2]
    assert contact_length_scale(msh, ft, 1) == pytest.approx(0.5, rel=1e-12)
    with pytest.raises(ValueError, match="no facet"):
        contact_length_scale(msh, ft, 7)
