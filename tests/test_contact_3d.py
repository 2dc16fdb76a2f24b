"""Penalty contact with friction in 3-D (hexahedra): static (fenics_plast.contact) and explicit
(fenics_plast.solvers.explicit_contact, contact_kernels.contact_forces_3d).

Static: an elastic block pressed by a rigid plane in uniaxial strain (rollers on the sides), the
contact force against the closed form with the penalty's compliance; a block pressed and then
dragged by the plane 30 degrees off x: the tangential force vector saturates at mu times the
normal force (Coulomb to round-off, Quasi-Coulomb with the last increment's normal force), along
the plane's motion; a revolved flat punch presses the block as a plane does (slow).
Explicit: the compiled 3-D gaps (plane, sphere, cylinder, torus) against the tools' numpy gaps; the
3-D kernel on a problem in the x-y plane equals the 2-D kernel; a block dropped at an angle onto a
plane with Coulomb friction: impulse = momentum change, energy balance with the contact work,
tangential force mu times the normal force while every contact node slips; a tool without a
compiled gap (RevolvedProfile through gap_np, step by step) equals the compiled plane (in chunks).

Default tests: ~7 s with a warm JIT cache, ~35-45 s cold (the 3-D static forms).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx import mesh as dm
from mpi4py import MPI

from fenics_plast.contact import PenaltyContact
from fenics_plast.kinematics import Kinematics
from fenics_plast.material import Material
from fenics_plast.solvers import contact_kernels as ck
from fenics_plast.solvers.explicit_contact import tool_kind
from fenics_plast.solvers.static import StaticSolver
from fenics_plast.tools import Circle, Cylinder, Plane, RevolvedProfile, Sphere, Torus, piecewise_path

E, NU = 1000.0, 0.3            # MPa (static blocks)
EPS = 1e4                      # normal and tangential penalty [N/mm^3]
MU = 0.3
#: face tags of the box [0, Lx] x [0, Ly] x [0, Lz]
BOTTOM, TOP, XMIN, XMAX, YMIN, YMAX = 1, 2, 3, 4, 5, 6


def box(size, cells, comm=MPI.COMM_WORLD):
    """Hexahedral box [0, size] with its six faces tagged (BOTTOM z = 0, TOP, XMIN, ...)."""
    msh = dm.create_box(comm, [np.zeros(3), np.asarray(size, dtype=float)], list(cells), dm.CellType.hexahedron)
    msh.topology.create_connectivity(2, 3)
    where = {BOTTOM: (2, 0.0), TOP: (2, size[2]), XMIN: (0, 0.0), XMAX: (0, size[0]),
             YMIN: (1, 0.0), YMAX: (1, size[1])}
    idx, val = [], []
    for tag, (axis, c) in where.items():
        f = dm.locate_entities_boundary(msh, 2, lambda x, a=axis, c=c: np.isclose(x[a], c))
        idx.append(f)
        val.append(np.full(len(f), tag, np.int32))
    idx, val = np.concatenate(idx).astype(np.int32), np.concatenate(val)
    o = np.argsort(idx, kind="stable")
    # an edge facet belongs to one face only here (faces do not share facets)
    return msh, dm.meshtags(msh, 2, idx[o], val[o])


def static_block(size=(2.0, 1.0, 1.0), cells=(4, 2, 2), rollers=False):
    msh, ft = box(size, cells)
    s = StaticSolver(Kinematics(msh, "3d"), Material(E, NU, None), element="q1p0", rtol=1e-13, atol=1e-11,
                     verbose=False)
    s.add_dirichlet(2, ft, TOP, 0.0)
    if rollers:
        for comp, tags in ((0, (XMIN, XMAX)), (1, (YMIN, YMAX))):
            for tag in tags:
                s.add_dirichlet(comp, ft, tag, 0.0)
    else:
        s.add_dirichlet(0, ft, TOP, 0.0)
        s.add_dirichlet(1, ft, TOP, 0.0)
    return s, ft


# ----------------------------------------------------------------------------------------------
# static


def test_static_uniaxial_strain_against_closed_form():
    """Plane z = 0 moving up by D into a 2 x 1 x 1 block on rollers, top fixed: uniaxial strain,
    sigma = M (D - sigma / eps) / H (M = lambda + 2 mu; the penalty's compliance in series), to the
    strain's finite-strain order (D / H = 1e-4)."""
    H, D = 1.0, 1e-4
    s, ft = static_block(rollers=True)
    c = PenaltyContact(s, EPS)
    pair = c.add_tool(Plane((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), path=piecewise_path([0.0, 1.0], dz=[0.0, D])), ft,
                      BOTTOM)
    c.attach()
    s.setup()
    s.run(increments=2, max_increment=0.5, callback=lambda sol: c.commit() or False)
    M = E * (1 - NU) / ((1 + NU) * (1 - 2 * NU))
    sigma = M * D / (H + M / EPS)
    F = pair.force()
    assert F[2] == pytest.approx(sigma * 2.0, rel=3e-4)
    assert abs(F[0]) < 1e-9 * F[2] and abs(F[1]) < 1e-9 * F[2]
    assert pair.normal_force() == pytest.approx(F[2], rel=1e-12)
    assert pair.status() == (15, 15)                     # every bottom node, frictionless: "slipping"
    assert c.max_penetration() == pytest.approx(sigma / EPS, rel=3e-4)
    without_penalty = M * D / H
    assert abs(F[2] / 2.0 - without_penalty) > 0.1 * without_penalty      # the compliance matters here


def drag_block(law, angle_deg=30.0, D=0.01, slide=0.05, compiled=True):
    """Block (top fixed) pressed by the plane z = 0 moving up by D (lam 0 -> 0.5), then dragged by
    ``slide`` along (cos a, sin a, 0) (lam 0.5 -> 1). Records per increment: force, tangential force
    vector, normal force, status before the commit, normal force of the previous commit."""
    s, ft = static_block()
    a = math.radians(angle_deg)
    path = piecewise_path([0.0, 0.5, 1.0], [0.0, 0.0, slide * math.cos(a)], [0.0, 0.0, slide * math.sin(a)],
                          [0.0, D, D])
    c = PenaltyContact(s, EPS, friction=MU, law=law, compiled=compiled)
    pair = c.add_tool(Plane((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), path=path), ft, BOTTOM)
    c.attach()
    s.setup()
    rec = []
    prev = {"N": 0.0}
    # int |t| w dA0: mu N in slip (the norm of the vector sum is below it where the nodes' slip
    # directions differ)
    t_norm = fem.form(ufl.sqrt(ufl.dot(pair.t_vec, pair.t_vec)) * pair.omega * pair.ds) if not compiled else None

    def t_norm_sum():
        if t_norm is not None:
            return s.comm.allreduce(fem.assemble_scalar(t_norm), op=MPI.SUM)
        pair.evaluate()
        return s.comm.allreduce(float(np.dot(pair.area, np.linalg.norm(pair.t, axis=1))), op=MPI.SUM)

    def cb(sol):
        rec.append(dict(lam=sol.lam_converged, F=pair.force(), Ft=pair.tangential_force(), N=pair.normal_force(),
                        Ft_sum=t_norm_sum(),
                        status=pair.status(), N_prev=prev["N"],
                        norms=list(sol.increments[-1]["norms"])))
        c.commit()
        prev["N"] = pair.normal_force()
        return False

    s.run(increments=10, max_increment=0.1, callback=cb)
    return rec, np.array([math.cos(a), math.sin(a), 0.0])


@pytest.mark.parametrize("law", ["coulomb", "quasi-coulomb"])
def test_static_drag_saturates_at_mu_times_normal_force(law):
    rec, direction = drag_block(law)
    final = rec[-1]
    N, Ft = final["N"], final["Ft"]
    assert N > 10.0                                          # pressed: ~19.6 N
    assert final["status"] == (15, 15)                       # every bottom node slides
    bound = MU * (N if law == "coulomb" else final["N_prev"])
    assert final["Ft_sum"] == pytest.approx(bound, rel=1e-9)               # every node on its bound
    assert bound * (1 - 1e-5) < np.linalg.norm(Ft) <= bound * (1 + 1e-12)  # nearly parallel
    assert np.linalg.norm(Ft) == pytest.approx(MU * N, rel=2e-3)
    np.testing.assert_allclose(final["F"][:2], Ft[:2], rtol=1e-12, atol=1e-12 * N)    # tangent plane = x-y
    assert abs(Ft[2]) < 1e-12 * N
    # along the plane's motion (it drags the body): within a degree (the block's shear is not isotropic)
    cosine = Ft @ direction / np.linalg.norm(Ft)
    assert math.degrees(math.acos(min(cosine, 1.0))) < 1.0
    for r in rec:                                            # never above the Coulomb limit
        b = MU * (r["N"] if law == "coulomb" else r["N_prev"])
        assert r["Ft_sum"] <= b * (1 + 1e-9) + 1e-12
    # Newton ends quadratically in slip (Coulomb: consistent tangent of the vector return map)
    norms = rec[-1]["norms"]
    assert norms[-1] < 1e-10 and len(norms) <= 6


@pytest.mark.slow
def test_static_revolved_flat_punch_equals_plane():
    """A revolved flat punch (face radius 5, edge arc) pressing the block: its face covers the
    bottom, so the forces equal those of the plane to round-off (slow: 12 s of JIT on a cold
    cache; the UFL gap itself is checked in tests/test_tools_3d.py)."""
    D = 1e-3
    forces = []
    for tool in (Plane((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), path=piecewise_path([0.0, 1.0], dz=[0.0, D])),
                 RevolvedProfile([("line", (5.0, -30.0), (5.0, -1.0)), ("arc", (4.0, -1.0), 1.0, 0.0, 90.0),
                                  ("line", (4.0, 0.0), (0.0, 0.0))], (1.0, 0.5, 0.0), (0.0, 0.0, 1.0),
                                 body_side="right", path=piecewise_path([0.0, 1.0], dz=[0.0, D]))):
        s, ft = static_block(rollers=True)
        c = PenaltyContact(s, EPS)
        pair = c.add_tool(tool, ft, BOTTOM)
        c.attach()
        s.setup()
        s.run(increments=1, max_increment=1.0, callback=lambda sol: c.commit() or False)
        forces.append(pair.force())
    assert forces[0][2] > 1.0
    np.testing.assert_allclose(forces[1], forces[0], rtol=1e-10, atol=1e-10 * forces[0][2])


# ----------------------------------------------------------------------------------------------
# explicit: the compiled kernel


def _kernel(u, du, X, tools, kinds, params, gN, laws, trans, mu=0.3, steps=1):
    """contact_forces on random nodes, all pairs' nodes interleaved; returns (fcon, state arrays)."""
    n, d = X.shape
    npair = len(tools)
    dofs = np.arange(d * n, dtype=np.int64).reshape(n, d)
    cpair = (np.arange(n) % npair).astype(np.int64)
    hist = [np.full((n, d), 0.3), np.tile(np.eye(d)[-1], (n, 1)), np.full(n, 50.0), np.zeros(n), np.zeros(n)]
    fc, acc, pen, fcon = np.zeros((n, d)), np.zeros((npair, 2 + d)), np.zeros(npair), np.zeros(d * n)
    for _ in range(steps):
        c = ck.ContactArrays(X, dofs, cpair, np.full(n, 0.7), np.asarray(kinds, np.int64),
                             np.asarray(params, dtype=float), np.full(npair, 1e3), np.full(npair, 2e3),
                             np.full(npair, mu), np.asarray(laws, np.int64), gN, np.zeros((n, d)), *hist, fc,
                             acc, pen)
        ck.contact_forces(u, du, 1e-3, c, trans[0], trans[1], fcon)
    return fcon, hist, fc, acc, pen


@pytest.mark.parametrize("law", [ck.COULOMB, ck.QUASI_COULOMB])
def test_compiled_3d_gaps_match_gap_np(law):
    """Plane, sphere, cylinder, torus and revolved profile compiled == GENERIC with the tools' gap_np
    (forces, history, energies, impulses)."""
    rng = np.random.default_rng(1)
    path = piecewise_path([0.0, 1.0], [0.0, 0.5], [0.0, -1.0], [0.0, 0.3])
    tools = [Plane((0.1, -0.2, 0.3), (0.3, 1.0, -0.2), path=path),
             Sphere((0.2, -1.0, 0.1), 0.9, path=path),
             Cylinder((0.0, 0.1, -0.2), (1.0, 0.3, 0.2), 0.8, path=path),
             Torus((0.1, 0.0, 0.0), (0.2, 0.1, 1.0), 0.9, 0.4, path=path),
             RevolvedProfile([("line", (0.0, 0.2), (0.5, 0.2)), ("arc", (0.5, 0.0), 0.2, 90, 0),
                              ("line", (0.7, 0.0), (0.7, -1.5))], (0.0, 0.1, 0.0), (0.1, 0.2, 1.0),
                             body_side="left", path=path)]
    n = 400
    X = np.ascontiguousarray(rng.uniform(-1.2, 1.2, (n, 3)))
    u = rng.uniform(-0.1, 0.1, 3 * n)
    du = rng.uniform(-0.01, 0.01, 3 * n)
    t0, t1 = 0.1, 0.2
    trans = np.array([[tool.translation(t, use_ufl=False) for tool in tools] for t in (t0, t1)])
    kp = [tool_kind(tool) for tool in tools]
    assert [k for k, _ in kp] == [tool.shape.code for tool in tools]
    x = X + u.reshape(-1, 3)
    cpair = np.arange(n) % len(tools)
    gN = np.zeros((n, 4))
    for i, tool in enumerate(tools):
        g, N = tool.gap_np(x[cpair == i], t1)
        gN[cpair == i] = np.column_stack([g, N])
        assert (g < 0).sum() > 5 and (g > 0).sum() > 5
    laws = [law] * len(tools)
    width = max(p.size for _, p in kp)
    params = [np.pad(p, (0, width - p.size)) for _, p in kp]
    compiled = _kernel(u, du, X, tools, [k for k, _ in kp], params, np.zeros((n, 4)), laws, trans)
    generic = _kernel(u, du, X, tools, [ck.GENERIC] * len(tools), np.zeros((len(tools), 8)), gN, laws, trans)
    for a, b in zip(compiled, generic):
        for aa, bb in zip(a if isinstance(a, list) else [a], b if isinstance(b, list) else [b]):
            np.testing.assert_allclose(aa, bb, rtol=1e-12, atol=1e-12 * max(np.abs(bb).max(), 1.0))
    fcon, hist, fc, acc, pen = compiled
    t = hist[0]
    # tangential tractions in the tangent plane, within the Coulomb bound, slip where they sit on it
    plane_normal = hist[1] if law == ck.COULOMB else np.broadcast_to([0.0, 0.0, 1.0], t.shape)  # quasi: old N
    assert np.abs(np.einsum("ij,ij->i", t, plane_normal)).max() < 1e-12 * np.abs(t).max()
    bound = 0.3 * (hist[2] if law == ck.COULOMB else 50.0 * (gN[:, 0] < 0))
    assert np.all(hist[3] <= bound * (1 + 1e-12) + 1e-300)
    on = hist[4] > 0
    assert on.sum() > 10 and np.allclose(hist[3][on], bound[on], rtol=1e-12)


def test_3d_kernel_in_the_xy_plane_equals_the_2d_kernel():
    """A 2-D problem embedded in 3-D (z = 0, no z motion, tools' normals in the x-y plane): the 3-D
    kernel's vector return map gives the 2-D kernel's forces, history and energies (2-D is the
    special case P_T = T T^T), over several steps with both laws."""
    rng = np.random.default_rng(4)
    n = 60
    X2 = rng.uniform(-1.0, 1.0, (n, 2))
    X3 = np.column_stack([X2, np.zeros(n)])
    two_d = [Plane((0.1, -0.2), (0.3, 1.0)), Circle((0.2, -1.0), 0.9)]
    three_d = [Plane((0.1, -0.2, 0.0), (0.3, 1.0, 0.0)), Cylinder((0.2, -1.0, 0.0), (0, 0, 1), 0.9)]  # == circle
    for law in (ck.COULOMB, ck.QUASI_COULOMB):
        out = []
        for X, tools, d in ((X2, two_d, 2), (X3, three_d, 3)):
            kinds = [tool.shape.code for tool in tools]
            params = [np.pad(tool.params, (0, 8 - tool.params.size)) for tool in tools]
            r = np.random.default_rng(7)
            dofs = np.arange(d * n, dtype=np.int64).reshape(n, d)
            cpair = (np.arange(n) % 2).astype(np.int64)
            # gN, dd_node, t_hist, N_hist, p_hist, t_scal, slip, fc, acc, pen; N_hist starts as a unit vector
            # (a run's first call, at t0 with du = 0, sets it so)
            st = [np.zeros((n, 1 + d)), np.zeros((n, d)), np.zeros((n, d)), np.tile(np.eye(d)[1], (n, 1)),
                  np.zeros(n), np.zeros(n), np.zeros(n), np.zeros((n, d)), np.zeros((2, 2 + d)), np.zeros(2)]
            u = np.zeros(d * n)
            rows = []
            for step in range(30):
                du = np.zeros((n, d))
                du[:, :2] = r.uniform(-0.01, 0.01, (n, 2)) + [0.004, -0.003]
                du = du.ravel()
                u += du
                tr = np.zeros((2, 2, d))
                tr[1, :, :2] = r.uniform(-0.01, 0.01, (2, 2))
                fcon = np.zeros(d * n)
                c = ck.ContactArrays(np.ascontiguousarray(X), dofs, cpair, np.full(n, 0.7),
                                     np.array(kinds, np.int64), np.array(params), np.array([1e3, 2e3]),
                                     np.array([2e3, 1e3]), np.array([0.3, 0.2]), np.array([law, law], np.int64), *st)
                ck.contact_forces(u, du, 1e-3, c, tr[0], tr[1], fcon)
                ix = np.arange(n)[:, None] * d + np.arange(2)
                rows.append(np.concatenate([fcon[ix].ravel(), st[2][:, :2].ravel(), st[7][:, :2].ravel(),
                                            st[4], np.abs(st[5]), st[6], st[8][:, :4].ravel(), st[9]]))
                if d == 3:
                    assert np.abs(fcon.reshape(-1, 3)[:, 2]).max() == 0.0
            out.append(np.array(rows))
        assert out[0][:, -2:].max() > 0 and (out[0] != 0).sum() > 1000
        np.testing.assert_allclose(out[1], out[0], rtol=1e-11, atol=1e-12 * np.abs(out[0]).max())


# ----------------------------------------------------------------------------------------------
# explicit: a block dropped onto a plane


def test_explicit_block_slides_on_plane():
    """A 2 x 2 x 2 mm steel block (8 hexahedra) lands at 1 m/s with a tangential speed 5 m/s 30
    degrees off x on a fixed plane, Coulomb mu = 0.3: the contact impulse is the momentum change,
    KE + W_int + E_c = KE0, and while every contact node slips the tangential force is mu times the
    normal force, against the sliding direction."""
    from fenics_plast.solvers.explicit import ExplicitDynamics
    E_s, rho = 200e3, 7.8e-9
    msh, ft = box((2.0, 2.0, 2.0), (2, 2, 2), comm=MPI.COMM_SELF)
    s = ExplicitDynamics(msh, Kinematics(msh, "3d"), Material(E_s, 0.3, None), rho, [], log=lambda m: None)
    a = math.radians(30.0)
    vt, vz = 5e3, -1e3                                                  # mm/s
    direction = np.array([math.cos(a), math.sin(a), 0.0])
    s.set_velocity(tuple(vt * direction + [0.0, 0.0, vz]))
    pair = s.add_contact(Plane((0.0, 0.0, -1e-7), (0.0, 0.0, 1.0)), ft, BOTTOM, penalty=2e5, friction=MU,
                         law="coulomb")
    assert s.contact.chunkable

    def momentum():
        return (s.mass.reshape(-1, 3) * s.v.x.array[: s.n_own].reshape(-1, 3)).sum(axis=0)

    checked = []

    def on_row(so, t):
        on, slip = pair.status()
        if on > 0 and slip == on:
            Ft, N = pair.tangential_force(), pair.normal_force()
            c = so.contact
            checked.append(t)
            assert np.dot(c.area[pair.sl], c.t_scal[pair.sl]) == pytest.approx(MU * N, rel=1e-10)
            assert MU * N * (1 - 1e-2) < np.linalg.norm(Ft) <= MU * N * (1 + 1e-12)      # nearly parallel
            np.testing.assert_allclose(pair.force(), Ft + [0.0, 0.0, N], rtol=1e-12, atol=1e-12 * N)
            assert -Ft @ direction > 0.99 * np.linalg.norm(Ft)

    s.initialize()
    p0 = momentum()
    s.run(4 * 2.0 / math.sqrt(E_s / rho), rows=41, progress=0, on_row=on_row)
    assert len(checked) > 5
    imp = pair.impulse()
    np.testing.assert_allclose(imp, momentum() - p0, rtol=1e-9, atol=1e-9 * np.abs(imp).max())
    assert imp[2] > 0 and -imp @ direction == pytest.approx(MU * imp[2], rel=0.05)
    e = s.energies()
    assert e["contact_work"] > 0.0 and e["balance_error"] < 0.01
    assert abs(e["kinetic"] + e["internal_work"] + e["contact_work"] - s.KE0) < 0.01 * s.KE0
    assert pair.max_penetration_run() < 1e-3


def test_explicit_generic_tool_equals_compiled_plane():
    """The same drop against a RevolvedProfile disc whose gap_np is its own (a generic tool: gap_np every
    step, step by step) and against the equal Plane (compiled, in chunks): same motion and contact
    to round-off."""
    from fenics_plast.solvers.explicit import ExplicitDynamics

    class NumpyDisc(RevolvedProfile):
        def gap_np(self, x, t):
            return super().gap_np(x, t)
    E_s, rho = 200e3, 7.8e-9
    out = []
    for tool in (Plane((0.0, 0.0, -1e-7), (0.0, 0.0, 1.0)),
                 NumpyDisc([("line", (0.0, 0.0), (10.0, 0.0))], (1.0, 1.0, -1e-7), (0.0, 0.0, 1.0))):
        msh, ft = box((2.0, 2.0, 2.0), (2, 2, 2), comm=MPI.COMM_SELF)
        s = ExplicitDynamics(msh, Kinematics(msh, "3d"), Material(E_s, 0.3, None), rho, [], log=lambda m: None)
        s.set_velocity((3e3, -2e3, -1e3))
        pair = s.add_contact(tool, ft, BOTTOM, penalty=2e5, friction=MU, law="quasi-coulomb")
        assert s.contact.chunkable == isinstance(tool, Plane)
        s.run(2.0 / math.sqrt(E_s / rho), rows=3, progress=0)
        out.append((s.u.x.array.copy(), pair.force(), pair.impulse(), pair.contact_work()))
    assert out[0][3] > 0 and np.abs(out[0][1]).max() > 0
    for a, b in zip(*out):
        np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-12 * np.abs(a).max())
