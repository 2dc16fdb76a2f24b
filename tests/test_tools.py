"""Rigid analytic tools (fenics_plast.tools) and per-pair contact parameters (fenics_plast.contact).

Fast: gaps and normals of Plane, Circle and Profile at hand-computed points (corners, a smooth
line-arc joint, beyond an open end, both body sides, closed profiles, translation), the UFL gap
against the numpy one at mesh points, bad input, the contact length scale; Newton on an elastic
block pressed by a Profile die (same forces as a Plane on the flat part, quadratic convergence on
the shoulder) and two pairs with different penalty/friction/law on one mesh.
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
from fenics_plast import contact as contact_mod
from fenics_plast.contact import PenaltyContact
from fenics_plast.kinematics import Kinematics
from fenics_plast.material import Material
from fenics_plast.solvers.static import StaticSolver
from fenics_plast.tools import (Circle, Plane, Profile, contact_length_scale, default_penalty,
                                piecewise_path)

S2 = 1.0 / math.sqrt(2.0)
#: axisymmetric die: wall r = 20 going up, shoulder R 5 (clockwise), flat top z = 0 out to r = 60
DIE = [("line", (20, -30), (20, -5)), ("arc", (25, -5), 5, 180, 90), ("line", (25, 0), (60, 0))]


def check(tool, pts, g_ref, N_ref, t=0.0):
    g, N = tool.gap_np(np.array(pts, dtype=float), t)
    assert g == pytest.approx(np.array(g_ref, dtype=float), abs=1e-12)
    assert N == pytest.approx(np.array(N_ref, dtype=float), abs=1e-12)


# ----------------------------------------------------------------------------------------------
# closed forms


def test_plane():
    wall = Plane(point=(1.0, 2.0), normal=(0.0, 3.0))          # normalised
    check(wall, [[5.0, 2.5], [0.0, 1.0]], [0.5, -1.0], [[0, 1], [0, 1]])
    tilted = Plane(point=(0.0, 0.0), normal=(1.0, 1.0))
    check(tilted, [[1.0, 1.0, 0.0]], [math.sqrt(2)], [[S2, S2]])     # (n, 3) input too


def test_circle():
    c = Circle((0.0, -5.0), 5.0)
    check(c, [[0.0, 1.0], [3.0, -1.0], [0.0, -9.0]], [1.0, 0.0, -1.0], [[0, 1], [0.6, 0.8], [0, -1]])


def test_translated_tools():
    path = piecewise_path([0.0, 0.5, 1.0], dx=[0.0, 0.0, 2.0], dy=[0.0, 1.0, 1.0])
    wall = Plane((0.0, 0.0), (0.0, 1.0), path=path)
    assert wall.translation(0.75, use_ufl=False) == pytest.approx([1.0, 1.0])
    check(wall, [[7.0, 3.0]], [2.5], [[0, 1]], t=0.25)               # wall at y = 0.5
    c = Circle((0.0, 0.0), 1.0, path=path)
    check(c, [[1.0, 3.0]], [1.0], [[0, 1]], t=0.75)                  # centre (1, 1)
    die = Profile(DIE, path=path)
    ref = Profile(DIE)
    x = np.array([[40.0, 2.0], [19.0, -10.0], [23.0, -2.0]])
    g, N = die.gap_np(x, 0.75)
    g0, N0 = ref.gap_np(x - [1.0, 1.0], 0.0)
    assert np.array_equal(g, g0) and np.array_equal(N, N0)
    assert g[0] == pytest.approx(1.0)


def test_profile_die():
    die = Profile(DIE)
    a = [25 - 6 * S2, -5 + 6 * S2]                                    # 1 outside the shoulder
    b = [25 - 4 * S2, -5 + 4 * S2]                                    # 1 inside it
    check(die, [[40, 1], [40, -0.5], a, b, [19, -10], [21, -10]],
          [1, -0.5, 1, -1, 1, -1], [[0, 1], [0, 1], [-S2, S2], [-S2, S2], [-1, 0], [-1, 0]])
    # smooth line-arc joints: on the common normal, and just either side of it
    check(die, [[25, 2], [18, -5], [25.001, 2]], [2, 2, 2], [[0, 1], [-1, 0], [0, 1]])
    g, N = die.gap_np(np.array([[24.999, 2.0]]), 0.0)                 # on the shoulder: ~ continuous
    assert g[0] == pytest.approx(2.0, abs=1e-6) and N[0] == pytest.approx([0, 1], abs=1e-3)
    # beyond the open end (60, 0): distance to the end, sign of the tangent line's side
    check(die, [[61, 1], [61, -1]], [math.sqrt(2), -math.sqrt(2)], [[S2, S2], [-S2, S2]])
    # the other body side flips g and N; walking the other way on the other side changes nothing
    x = np.array([[40, 1], a, b, [19, -10], [61, -1], [22, -3]], dtype=float)
    g, N = die.gap_np(x, 0.0)
    g2, N2 = Profile(DIE, body_side="right").gap_np(x, 0.0)
    assert np.array_equal(g2, -g) and np.array_equal(N2, -N)
    back = [("line", (60, 0), (25, 0)), ("arc", (25, -5), 5, 90, 180), ("line", (20, -5), (20, -30))]
    g3, N3 = Profile(back, body_side="right").gap_np(x, 0.0)
    assert g3 == pytest.approx(g, abs=1e-12) and N3 == pytest.approx(N, abs=1e-12)


def test_profile_corners():
    # convex tool corner (flat top, vertical wall down): the nearest point is the corner
    convex = Profile([("line", (0, 0), (10, 0)), ("line", (10, 0), (10, -5))])
    r = math.hypot(0.5, 0.2)
    check(convex, [[11, 1], [10.5, 0.2], [9.9, -0.05], [9.95, -0.5]],
          [math.sqrt(2), r, -0.05, -0.05], [[S2, S2], [0.5 / r, 0.2 / r], [0, 1], [1, 0]])
    # concave tool corner (the body in a 45-degree wedge): behind the corner is inside the tool
    wedge = Profile([("line", (-10, 0), (0, 0)), ("line", (0, 0), (-5, 5))])
    r = math.hypot(1.0, 0.5)
    check(wedge, [[1, 0.5], [-3, 1]], [-r, 1], [[-1 / r, -0.5 / r], [0, 1]])


def test_closed_profiles():
    square = Profile([("line", (0, 0), (1, 0)), ("line", (1, 0), (1, 1)), ("line", (1, 1), (0, 1)),
                      ("line", (0, 1), (0, 0))], body_side="right")     # counter-clockwise, body outside
    # (-1, -1) faces the corner that closes the chain (last piece to first): convex, g > 0
    check(square, [[0.5, 0.4], [2, 2], [-1, -1], [0.5, -1]],
          [-0.4, math.sqrt(2), math.sqrt(2), 1], [[0, -1], [S2, S2], [-S2, -S2], [0, -1]])
    # a full counter-clockwise circle with the body outside is the Circle; inside: a ring die
    rng = np.random.default_rng(1)
    x = rng.uniform(-3, 3, (50, 2)) + [1.0, 2.0]
    ring = Profile([("arc", (1.0, 2.0), 1.5, 30, 390)], body_side="right")
    g, N = ring.gap_np(x, 0.0)
    gc, Nc = Circle((1.0, 2.0), 1.5).gap_np(x, 0.0)
    assert g == pytest.approx(gc, abs=1e-12) and N == pytest.approx(Nc, abs=1e-12)
    g, N = Profile([("arc", (1.0, 2.0), 1.5, 30, 390)]).gap_np(x, 0.0)
    assert g == pytest.approx(-gc, abs=1e-12) and N == pytest.approx(-Nc, abs=1e-12)


def test_bad_input():
    with pytest.raises(ValueError, match="do not join"):
        Profile([("line", (0, 0), (1, 0)), ("line", (1.001, 0), (2, 0))])
    Profile([("line", (0, 0), (1, 0)), ("line", (1 + 1e-12, 0), (2, 0))])       # within 1e-9
    with pytest.raises(ValueError, match="do not join"):
        Profile([("line", (0, 0), (1, 0)), ("arc", (1, 1), 1, 0, 90)])
    with pytest.raises(ValueError, match="radius > 0"):
        Profile([("arc", (0, 0), 0.0, 0, 90)])
    with pytest.raises(ValueError, match="radius must be > 0"):
        Circle((0, 0), 0.0)
    with pytest.raises(ValueError, match="non-zero"):
        Plane((0, 0), (0.0, 0.0))
    with pytest.raises(ValueError, match="two distinct"):
        Profile([("line", (1, 1), (1, 1))])
    with pytest.raises(ValueError, match="sweep"):
        Profile([("arc", (0, 0), 1.0, 10, 10)])
    with pytest.raises(ValueError, match="expected"):
        Profile([("spline", (0, 0), (1, 1))])
    with pytest.raises(ValueError, match="cusp"):
        Profile([("line", (0, 0), (1, 0)), ("line", (1, 0), (0, 0))])
    with pytest.raises(ValueError, match="body_side"):
        Profile(DIE, body_side="up")


# ----------------------------------------------------------------------------------------------
# UFL == numpy at mesh points


def _tools_for_ufl():
    path = piecewise_path([0.0, 1.0], dx=[0.0, 0.3], dy=[0.0, -0.2])
    die = [("line", (0.5, -1.5), (0.5, -0.4)), ("arc", (0.9, -0.4), 0.4, 180, 90),
           ("line", (0.9, 0.0), (2.5, 0.0))]
    return {
        "plane": Plane((0.1, 0.2), (0.3, 1.0), path=path),
        "circle": Circle((1.1, 0.4), 0.7, path=path),
        "die": Profile(die, path=path),
        "die_right": Profile(die, body_side="right"),
        "corners": Profile([("line", (-0.7, 0.9), (0.4, 0.1)), ("line", (0.4, 0.1), (1.6, 0.6)),
                            ("arc", (1.3, 1.0), 0.5, -53.13010235415598, 40.0)], path=path),
        "ring": Profile([("arc", (1.2, 0.3), 0.6, 0, 180), ("arc", (1.2, 0.3), 0.6, 180, 360)],
                        body_side="right"),
    }


@pytest.mark.parametrize("name", list(_tools_for_ufl()))
def test_ufl_equals_numpy(name):
    tool = _tools_for_ufl()[name]
    msh = dm.create_rectangle(MPI.COMM_WORLD, [np.array([-1.0, -1.5]), np.array([3.0, 2.0])], [8, 7],
                              dm.CellType.quadrilateral)
    V = dc.vector_space(msh)
    u = fem.Function(V)
    u.interpolate(lambda x: np.vstack([0.03 * np.sin(3 * x[1] + 1), 0.02 * np.cos(2 * x[0])]))
    x = ufl.SpatialCoordinate(msh) + u
    t = fem.Constant(msh, PETSc.ScalarType(0.7))
    g, N = tool.gap(x, t)
    q = np.array([[a, b] for a in (0.0, 0.13, 0.41, 0.77, 1.0) for b in (0.0, 0.29, 0.62, 1.0)])
    cells = np.arange(msh.topology.index_map(2).size_local, dtype=np.int32)
    vals = dc.eval_expression(fem.Expression(ufl.as_vector([g, N[0], N[1]]), q), msh, cells).reshape(-1, 3)
    xs = dc.eval_expression(fem.Expression(x, q), msh, cells).reshape(-1, 2)
    g_np, N_np = tool.gap_np(xs, 0.7)
    assert np.max(np.abs(vals[:, 0] - g_np)) <= 1e-12
    assert np.max(np.abs(vals[:, 1:] - N_np)) <= 1e-12
    assert np.allclose(np.linalg.norm(N_np, axis=1), 1.0)
    assert (g_np < 0).any() and (g_np > 0).any()


def test_contact_length_scale_and_default_penalty():
    msh = dm.create_rectangle(MPI.COMM_WORLD, [np.array([0.0, 0.0]), np.array([2.0, 1.0])], [4, 5],
                              dm.CellType.quadrilateral)
    ft = _tags(msh, {1: lambda x: np.isclose(x[1], 0.0), 2: lambda x: np.isclose(x[0], 2.0)})
    assert contact_length_scale(msh, ft, 1) == pytest.approx(0.2)      # 0.5 x 0.2 cells, 0.5 facets
    assert contact_length_scale(msh, ft, 2) == pytest.approx(0.5)      # 0.2 facets
    with pytest.raises(ValueError, match="no facet"):
        contact_length_scale(msh, ft, 7)
    assert default_penalty(1000.0, 0.2) == pytest.approx(0.3 * 1000.0 / 0.2)
    assert contact_mod.default_penalty is default_penalty and contact_mod.PENALTY_FACTOR == 0.3


# ----------------------------------------------------------------------------------------------
# Newton on an elastic block


def _tags(msh, where):
    msh.topology.create_connectivity(1, 2)
    idx, val = [], []
    for tag, f in where.items():
        e = dm.locate_entities_boundary(msh, 1, f)
        idx.append(e)
        val.append(np.full(len(e), tag, np.int32))
    idx, val = np.concatenate(idx).astype(np.int32), np.concatenate(val)
    o = np.argsort(idx)
    return dm.meshtags(msh, 1, idx[o], val[o])


def _solver(msh, ft):
    s = StaticSolver(Kinematics(msh, "plane_strain"), Material(1000.0, 0.3, None), element="q1p0",
                     rtol=1e-13, atol=1e-11, verbose=False)
    s.add_dirichlet(0, ft, 2, 0.0)
    s.add_dirichlet(1, ft, 2, 0.0)
    return s


def _block(nx=4):
    msh = dm.create_rectangle(MPI.COMM_WORLD, [np.array([0.0, 0.0]), np.array([2.0, 1.0])], [nx, 2],
                              dm.CellType.quadrilateral)
    return msh, _tags(msh, {1: lambda x: np.isclose(x[1], 0.0), 2: lambda x: np.isclose(x[1], 1.0)})


def _run(s, c, pairs, increments=10):
    """Forces (per pair, per increment: Fx, Fy), contact/slip node counts and Newton norms."""
    c.attach()
    s.setup()
    rec = []

    def cb(sol):
        rec.append(dict(F=[p.force() for p in pairs], status=[p.status() for p in pairs],
                        norms=list(sol.increments[-1]["norms"])))
        c.commit()
        return False

    s.run(increments=increments, max_increment=1.0 / increments, callback=cb)
    s.close()       # collective SNES destroy now, on every rank (not whenever the GC frees it)
    assert abs(s.lam_converged - 1.0) < 1e-12
    return rec


def _order(norms, floor=1e-10):
    r = np.asarray(norms)
    return [np.log(r[k + 1] / r[0]) / np.log(r[k] / r[0]) for k in range(1, len(r) - 1)
            if r[k + 1] > floor and r[k] < 0.5 * r[0]]


def _path(d, sx):
    return piecewise_path([0.0, 0.5, 1.0], dx=[0.0, 0.0, sx], dy=[0.0, d, d])


def test_profile_die_flat_part_equals_plane():
    """Pressed up by 0.01 and pushed sideways (Coulomb, mu 0.3, full slip) on the flat part only."""
    out = {}
    for kind in ("plane", "profile"):
        msh, ft = _block()
        s = _solver(msh, ft)
        path = _path(0.01, 0.05)
        tool = Plane((0.0, 0.0), (0.0, 1.0), path=path) if kind == "plane" else \
            Profile([("line", (-1.0, 0.0), (2.5, 0.0)), ("arc", (2.5, -1.0), 1.0, 90, 0)], path=path)
        c = PenaltyContact(s)
        pair = c.add_pair(tool, ft, 1, penalty=1e4, friction=0.3, law="coulomb")
        out[kind] = _run(s, c, [pair])
    Fp = np.array([r["F"][0] for r in out["plane"]])
    Fq = np.array([r["F"][0] for r in out["profile"]])
    assert np.max(np.abs(Fp - Fq)) <= 1e-10 * np.max(np.abs(Fp))
    assert Fp[-1, 1] > 10.0 and Fp[-1, 0] == pytest.approx(0.3 * Fp[-1, 1], rel=1e-9)
    assert [len(r["norms"]) for r in out["plane"]] == [len(r["norms"]) for r in out["profile"]]


def test_profile_die_shoulder_newton_quadratic():
    """The block slides (Coulomb, mu 0.3) over the flat top onto a shoulder of radius 4."""
    msh, ft = _block(nx=8)
    s = _solver(msh, ft)
    die = Profile([("line", (-1.0, 0.0), (1.0, 0.0)), ("arc", (1.0, -4.0), 4.0, 90, 45)],
                  path=_path(0.04, -0.1))
    c = PenaltyContact(s)
    pair = c.add_pair(die, ft, 1, penalty=1e4, friction=0.3, law="coulomb")
    rec = _run(s, c, [pair])
    assert max(r["status"][0][0] for r in rec) >= 6          # 5 nodes on the flat part (x <= 1)
    assert any(0 < r["status"][0][1] for r in rec)
    for r in rec:
        ords = _order(r["norms"])
        if len(r["norms"]) >= 3 and ords:
            assert max(ords) >= 1.8, r["norms"]
    assert c.max_penetration() == pytest.approx(pair.max_penetration())
    assert 0 < pair.max_penetration() < 0.01


def _two_blocks():
    """Two unconnected 2 x 1 blocks (x in [0, 2] and [3, 5]) in one mesh; bottoms tagged 1 and 3,
    tops 2."""
    comm = MPI.COMM_WORLD
    nx, ny = 4, 2
    if comm.rank == 0:
        pts, cells = [], []
        for x0 in (0.0, 3.0):
            base = len(pts)
            pts += [[x0 + 2.0 * i / nx, j / ny] for j in range(ny + 1) for i in range(nx + 1)]
            cells += [[base + j * (nx + 1) + i, base + j * (nx + 1) + i + 1,
                       base + (j + 1) * (nx + 1) + i, base + (j + 1) * (nx + 1) + i + 1]
                      for j in range(ny) for i in range(nx)]
        pts, cells = np.array(pts), np.array(cells, dtype=np.int64)
    else:
        pts, cells = np.zeros((0, 2)), np.zeros((0, 4), dtype=np.int64)
    domain = ufl.Mesh(dc.coordinate_element("quadrilateral", 2))
    msh = dm.create_mesh(comm, cells, pts, domain)
    ft = _tags(msh, {1: lambda x: np.isclose(x[1], 0.0) & (x[0] < 2.5),
                     3: lambda x: np.isclose(x[1], 0.0) & (x[0] > 2.5),
                     2: lambda x: np.isclose(x[1], 1.0)})
    return msh, ft


A = dict(penalty=1e4, friction=0.3, law="coulomb", tangential_penalty=None)
B = dict(penalty=3e3, friction=0.1, law="quasi-coulomb", tangential_penalty=5e3)


def test_pairs_keep_their_own_parameters():
    """Two pairs (different penalty, friction, law, tangential penalty) on two unconnected blocks
    of one mesh give what each gives alone (contact-wide parameters, add_tool)."""
    def wall():
        return Plane((0.0, 0.0), (0.0, 1.0), path=_path(0.01, 0.05))

    msh, ft = _two_blocks()
    s = _solver(msh, ft)
    c = PenaltyContact(s)
    pa = c.add_pair(wall(), ft, 1, **A)
    pb = c.add_pair(wall(), ft, 3, **B)
    both = _run(s, c, [pa, pb])
    alone = []
    for tag, prm in ((1, A), (3, B)):
        msh, ft = _two_blocks()
        s = _solver(msh, ft)
        c1 = PenaltyContact(s, prm["penalty"], friction=prm["friction"], law=prm["law"],
                            tangential_penalty=prm["tangential_penalty"])
        alone.append(_run(s, c1, [c1.add_tool(wall(), ft, tag)]))
    for i in range(2):
        F2 = np.array([r["F"][i] for r in both])
        F1 = np.array([r["F"][0] for r in alone[i]])
        assert np.max(np.abs(F2 - F1)) <= 1e-9 * np.max(np.abs(F1)), i
    Fa, Fb = both[-1]["F"]
    assert Fa[1] > 1.2 * Fb[1]                                 # the penalties differ
    assert Fa[0] == pytest.approx(0.3 * Fa[1], rel=1e-9)       # Coulomb, mu = 0.3, slipping
    assert abs(Fb[0]) == pytest.approx(0.1 * Fb[1], rel=2e-3)  # quasi-Coulomb, mu = 0.1
    assert abs(pa.tangential_force()) == pytest.approx(0.3 * pa.normal_force(), rel=1e-9)
    assert c.max_penetration() == pytest.approx(max(pa.max_penetration(), pb.max_penetration()))
    assert pb.max_penetration() > pa.max_penetration() > 0     # softer penalty, deeper


def test_pair_parameter_errors():
    msh, ft = _block()
    s = _solver(msh, ft)
    c = PenaltyContact(s)
    wall = Plane()
    with pytest.raises(ValueError, match="contact-wide penalty"):
        c.add_tool(wall, ft, 1)
    with pytest.raises(ValueError, match="law"):
        c.add_pair(wall, ft, 1, penalty=1e3, law="tresca")
    with pytest.raises(ValueError, match="penalty must be > 0"):
        c.add_pair(wall, ft, 1, penalty=0.0)
    with pytest.raises(ValueError, match="friction"):
        c.add_pair(wall, ft, 1, penalty=1e3, friction=-0.1)
    with pytest.raises(ValueError, match="penalty must be > 0"):
        PenaltyContact(s, -1.0)
