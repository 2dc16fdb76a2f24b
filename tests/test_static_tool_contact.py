"""The static solver's compiled tool contact (fenics_plast.solvers.static_tool_contact) held to its
definition, the UFL contact forms (fenics_plast.contact.ContactPair).

Each case runs a block against a tool with friction as forms for a few increments (so that the history
holds tractions, some nodes stick and some slip), then gives the same state and history to a solver with
the compiled contact and compares, at a state off equilibrium: the assembled residual and Jacobian of
the whole problem, the pair's forces and status. Cases: plane strain against a circle (coulomb,
quasi-coulomb), axisymmetric against a circle, 3-D against a sphere (coulomb, quasi-coulomb) and 2-D
against a meshed circle (a tool whose gap is computed at the nodes). Then the node law's tangent against
central differences of its forces, and a run of each route to the same forces in the same Newton
iterations.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from dolfinx import mesh as dm
from mpi4py import MPI

from fenics_plast.checkpoint import Keyed, KeyedTable
from fenics_plast.contact import PenaltyContact
from fenics_plast.kinematics import Kinematics
from fenics_plast.material import Hardening, Material
from fenics_plast.meshed_tools import MeshedTool
from fenics_plast.solvers import contact_kernels as ck
from fenics_plast.solvers.static import StaticSolver
from fenics_plast.solvers.static_tool_contact import node_forces
from fenics_plast.solvers.surface_gaps import build_surface
from fenics_plast.tools import Circle, Sphere, piecewise_path

EPS = 1e4           # normal and tangential penalty [N/mm^3]
MU = 0.3
BOTTOM, TOP = 1, 2
PRESS, SLIDE = 0.03, 0.01      # the tool's travel up, then along x [mm]

pytestmark = pytest.mark.skipif(MPI.COMM_WORLD.size > 1, reason="dense comparisons in serial")


def _block(dim, kind):
    """A 2 x 1 (x 1) block on [0, 2] x [0.5, 1.5] (x [0, 1]) (axisymmetric: [0.5, 2.5] in r), its bottom
    (BOTTOM) and top (TOP) tagged; a plastic q1p0 solver with the top held."""
    comm = MPI.COMM_WORLD
    if dim == 2:
        x0 = 0.5 if kind == "axisymmetric" else 0.0
        msh = dm.create_rectangle(comm, [np.array([x0, 0.5]), np.array([x0 + 2.0, 1.5])], [12, 3],
                                  dm.CellType.quadrilateral)
    else:
        msh = dm.create_box(comm, [np.array([0.0, 0.0, 0.5]), np.array([2.0, 1.0, 1.5])], [8, 4, 2],
                            dm.CellType.hexahedron)
    fdim = dim - 1
    msh.topology.create_connectivity(fdim, dim)
    bot = dm.locate_entities_boundary(msh, fdim, lambda x: np.isclose(x[dim - 1], 0.5))
    top = dm.locate_entities_boundary(msh, fdim, lambda x: np.isclose(x[dim - 1], 1.5))
    idx = np.concatenate([bot, top]).astype(np.int32)
    val = np.concatenate([np.full(len(bot), BOTTOM, np.int32), np.full(len(top), TOP, np.int32)])
    o = np.argsort(idx)
    ft = dm.meshtags(msh, fdim, idx[o], val[o])
    material = Material(1000.0, 0.3, Hardening("linear", yield_stress=20.0, modulus=200.0))
    s = StaticSolver(Kinematics(msh, kind), material, element="q1p0",
                     rtol=1e-12, atol=1e-10, verbose=False)
    for c in range(dim):
        s.add_dirichlet(c, ft, TOP, 0.0)
    return s, ft


def _meshed_circle(center, radius, path, n=256):
    a = -np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)         # clockwise: the normals (left) point out
    V = np.stack([center[0] + radius * np.cos(a), center[1] + radius * np.sin(a)], axis=1)
    F = np.stack([np.arange(n), (np.arange(n) + 1) % n], axis=1)
    surface = build_surface(V, F, flip=False)
    return MeshedTool(surface, False, path, "meshed_circle")


def _tool(case):
    """The tool of a case: below the block, pressed up by PRESS (lam 0 -> 0.5), then slid by SLIDE along x
    (lam 0.5 -> 1)."""
    dim = 3 if case.startswith("3d") else 2
    R = 20.0
    if dim == 3:
        path = piecewise_path([0.0, 0.5, 1.0], [0.0, 0.0, SLIDE], [0.0, 0.0, 0.0], [0.0, PRESS, PRESS])
        return Sphere((1.1, 0.45, 0.5 - R + 0.001), R, path=path)
    path = piecewise_path([0.0, 0.5, 1.0], [0.0, 0.0, SLIDE], [0.0, PRESS, PRESS])
    cx = 1.6 if case == "axisymmetric" else 1.1
    if case == "meshed":
        return _meshed_circle((cx, 0.5 - R + 0.001), R, path)
    return Circle((cx, 0.5 - R + 0.001), R, path=path)


CASES = [("plane_strain", "coulomb"), ("plane_strain", "quasi-coulomb"), ("axisymmetric", "coulomb"),
         ("3d", "coulomb"), ("3d", "quasi-coulomb"), ("meshed", "coulomb")]


def _setup(case, law, compiled):
    kind = {"meshed": "plane_strain", "3d": "3d"}.get(case, case)
    s, ft = _block(3 if case == "3d" else 2, kind)
    c = PenaltyContact(s, compiled=compiled)
    pair = c.add_pair(_tool(case), ft, BOTTOM, penalty=EPS, friction=MU, law=law)
    c.attach()
    s.setup()
    return s, c, pair


def _tables(state):
    """A state dict as a checkpoint reads it back (its keyed arrays as tables)."""
    return {k: KeyedTable(k, v.values, v.keys) if isinstance(v, Keyed) else v for k, v in state.items()}


def _dense(A):
    return A.convert("dense").getDenseArray().copy()


def _residual_and_jacobian(s, x):
    b, A = s.b.duplicate(), s.A
    s.snes.computeFunction(x, b)
    s.snes.computeJacobian(x, A, A)
    return b.array.copy(), _dense(A)


@pytest.mark.parametrize("case,law", CASES, ids=[f"{c}-{l}" for c, l in CASES])
def test_compiled_contact_equals_the_forms(case, law):
    """Same state and history: the same residual (to 1e-10 of its size) and Jacobian (to 1e-8: dN/dx of a
    curved tool is a central difference), forces and status, with nodes in stick and in slip."""
    forms, cf, pf = _setup(case, law, compiled=False)
    forms.run(increments=16, max_increment=0.05, lam_end=0.8, callback=lambda sol: cf.commit() or False)
    fast, cc, pc = _setup(case, law, compiled=True)
    # the same state, committed state and history, through the checkpoints' state (either route reads the
    # other's)
    fast.restart.load_state(_tables(forms.restart.state_dict()))
    cc.load_state(_tables(cf.state_dict()))
    lam = 0.81
    forms.set_load(lam)
    fast.set_load(lam)
    rng = np.random.default_rng(1)
    x = forms.x.duplicate()
    forms.w.x.array[:] += 2e-5 * rng.standard_normal(len(forms.w.x.array))     # off equilibrium
    forms.w.x.scatter_forward()
    x.array[:] = forms.w.x.array[: len(x.array)]
    rf, Jf = _residual_and_jacobian(forms, x)
    rc, Jc = _residual_and_jacobian(fast, x)
    assert np.abs(rc - rf).max() <= 1e-10 * np.abs(rf).max()       # the gaps to round-off x penalty
    assert np.abs(Jc - Jf).max() <= 1e-8 * np.abs(Jf).max()
    contact, slipping = pf.status()
    assert pc.status() == (contact, slipping)
    assert 0 < slipping < contact, "the case should hold nodes in stick and in slip"
    np.testing.assert_allclose(pc.force(), pf.force(), rtol=1e-11, atol=1e-11 * np.abs(pf.force()).max())
    assert pc.normal_force() == pytest.approx(pf.normal_force(), rel=1e-11)
    np.testing.assert_allclose(pc.tangential_force(), pf.tangential_force(), rtol=1e-10,
                               atol=1e-10 * abs(pf.normal_force()))
    assert pc.max_penetration() == pytest.approx(pf.max_penetration(), rel=1e-11)


@pytest.mark.parametrize("law", [ck.COULOMB, ck.QUASI_COULOMB], ids=["coulomb", "quasi-coulomb"])
@pytest.mark.parametrize("dim", [2, 3])
def test_node_tangent_is_the_derivative_of_its_forces(dim, law):
    """K = df/dx of :func:`node_forces` against central differences, the geometry of a sphere (circle) of radius
    2 whose gap and normal move with x, at nodes in stick and in slip."""
    rng = np.random.default_rng(7)
    n = 40
    R = 2.0

    def geometry(x):
        r = np.linalg.norm(x, axis=1)
        N = x / r[:, None]
        dN = (np.eye(dim)[None] - N[:, :, None] * N[:, None, :]) / r[:, None, None]
        return r - R, N, dN

    x = rng.standard_normal((n, dim))
    x *= (R - 1e-3 * rng.random(n))[:, None] / np.linalg.norm(x, axis=1)[:, None]        # pressed in
    s = 1e-3 * rng.standard_normal((n, dim))
    t_n = 5.0 * rng.standard_normal((n, dim))
    N_n = x / np.linalg.norm(x, axis=1)[:, None]
    p_n = 10.0 * rng.random(n) + 5.0
    area = rng.random(n) + 0.5
    out = [np.zeros((n, dim)), np.zeros((n, dim, dim)), np.zeros((n, dim)), np.zeros(n), np.zeros(n)]

    def forces(x, s):
        f, K, t, p, slip = (a.copy() for a in out)
        node_forces(*geometry(x), s, t_n, N_n, p_n, area, EPS, EPS, MU, law, f, K, t, p, slip)
        return f, K, slip

    f, K, slip = forces(x, s)
    assert 0 < slip.sum() < n
    h = 1e-7
    for j in range(dim):
        e = np.zeros(dim)
        e[j] = h
        fp, _, _ = forces(x + e, s + e)           # the slip moves with the node
        fm, _, _ = forces(x - e, s - e)
        np.testing.assert_allclose(K[:, :, j], (fp - fm) / (2 * h), rtol=0, atol=2e-5 * np.abs(K).max())


@pytest.mark.parametrize("law", ["coulomb", "quasi-coulomb"])
def test_both_routes_run_alike(law):
    """The plane-strain case to the end from the start: the same Newton iterations in every increment and the
    same force history to 1e-9."""
    runs = {}
    for compiled in (False, True):
        s, c, pair = _setup("plane_strain", law, compiled)
        rec = []

        def commit(sol, c=c, pair=pair, rec=rec):
            rec.append((len(sol.increments[-1]["norms"]), *pair.force()))
            c.commit()
            return False
        s.run(increments=10, max_increment=0.1, callback=commit)
        runs[compiled] = np.array(rec)
    assert np.array_equal(runs[True][:, 0], runs[False][:, 0])
    scale = np.abs(runs[False][:, 1:]).max()
    assert np.abs(runs[True][:, 1:] - runs[False][:, 1:]).max() <= 1e-9 * scale
    assert math.isfinite(scale) and scale > 1.0
