"""Contact in explicit analyses (fenics_plast.solvers.explicit_contact, contact_kernels.contact_forces).

Small elastic bars (2 x 10 mm, a few cells, axisymmetric and plane strain) flying onto a rigid
plane (tools.Plane) at low speed, against closed forms: the energy balance KE + W_int + E_c = KE0, the wall's
impulse equals the momentum change, the elastic bar rebounds after 2 L / c with the 1-D contact
force rho c v0 A; a bar at rest on a wall stays at rest; a sliding bar's tangential force is mu
times its normal force; compiled and Python gaps, the fused and the UFL route, chunked and
step-by-step loops, serial and ``mpirun -n 2`` agree; checkpoints resume exactly; the stable step
accounts for the penalty.

Run as a script (``python tests/test_explicit_contact.py OUT.npz``) it writes the result of
:func:`mpi_case` for the serial-vs-MPI test.
"""
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from fenics_plast.kinematics import Kinematics  # noqa: E402
from fenics_plast.material import Hardening, Material  # noqa: E402
from fenics_plast.meshing import bar_mesh  # noqa: E402
from fenics_plast.solvers import contact_kernels as ck  # noqa: E402
from fenics_plast.solvers.explicit import ExplicitDynamics  # noqa: E402
from fenics_plast.tools import Circle, Plane, Profile, piecewise_path  # noqa: E402

E, RHO, R, L = 200e3, 7.8e-9, 2.0, 10.0        # MPa, tonne/mm^3, mm, mm
SERIAL = MPI.COMM_WORLD.size == 1


def quiet(msg):
    pass


def bar(geometry="axisymmetric", route="fused", nu=0.0, nz=20, comm=MPI.COMM_WORLD, plastic=False, axis_bc=True):
    """A 2 x 10 mm bar (x = r or x, y = z), 2 x nz cells, elastic (or linear hardening); its groups
    axis (x = 0), bottom (y = 0), top (y = L), outer (x = R). Returns (solver, facet tags, tag ids)."""
    mesh, _, ft, tags = bar_mesh(comm, R, L, 2, nz)
    kin = Kinematics(mesh, geometry)
    hard = Hardening("linear", yield_stress=300.0, modulus=1000.0) if plastic else None
    bcs = [(0, ft.find(tags["axis"]))] if axis_bc else []
    s = ExplicitDynamics(mesh, kin, Material(E, nu, hard), RHO, bcs, log=quiet, internal_force=route)
    return s, ft, tags


def momentum(s):
    """Total momentum (x, y) [N s] (2 pi r included in axisymmetry)."""
    v = s.v.x.array[: s.n_own].reshape(-1, 2)
    return s.comm.allreduce((s.mass.reshape(-1, 2) * v).sum(axis=0), op=MPI.SUM)


def cross_section(geometry):
    return math.pi * R ** 2 if geometry == "axisymmetric" else R


class PythonGap:
    """A tool whose gap the solver cannot compile (gap_np called every step)."""

    name = "python"

    def __init__(self, tool):
        self.tool = tool

    def gap_np(self, x, t):
        return self.tool.gap_np(x, t)

    def translation(self, t, use_ufl=False):
        return self.tool.translation(t, use_ufl=False)


# ----------------------------------------------------------------------------------------------


def test_compiled_gaps_match_gap_np():
    """contact_forces with the compiled gap formulas (plane, circle, profile) == with the gaps of gap_np."""
    rng = np.random.default_rng(1)
    n = 40
    X = np.ascontiguousarray(rng.uniform(-1.0, 1.0, (n, 2)))
    u = rng.uniform(-0.1, 0.1, 2 * n)
    du = rng.uniform(-0.01, 0.01, 2 * n)
    dofs = np.arange(2 * n, dtype=np.int64).reshape(n, 2)
    tools = [Plane((0.1, -0.2), (0.3, 1.0), path=lambda t, use_ufl: (0.5 * t, -t)),
             Circle((0.2, -1.0), 0.9, path=lambda t, use_ufl: (t, 2 * t)),
             Profile([("line", (-1.0, -0.5), (0.0, -0.5)), ("arc", (0.0, -0.8), 0.3, 90, 0),
                      ("line", (0.3, -0.8), (0.3, -2.0))], path=lambda t, use_ufl: (t, 0.5 * t))]
    for tool in tools:
        t0, t1 = 0.1, 0.2
        tr = np.array([[tool.translation(t0, use_ufl=False)], [tool.translation(t1, use_ufl=False)]])
        g, N = tool.gap_np(X + u.reshape(-1, 2), t1)
        assert (g < 0).sum() > 5 and (g > 0).sum() > 5
        out = []
        for k, gN in ((tool.shape.code, np.zeros((n, 3))), (ck.GENERIC, np.column_stack([g, N]))):
            hist = [np.full((n, 2), 0.3), np.tile([0.0, 1.0], (n, 1)), np.full(n, 50.0), np.zeros(n), np.zeros(n)]
            fc, acc, pen, fcon = np.zeros((n, 2)), np.zeros((1, 4)), np.zeros(1), np.zeros(2 * n)
            c = ck.ContactArrays(X, dofs, np.zeros(n, np.int64), np.full(n, 0.7), np.array([k]), np.array([tool.params]),
                                 np.array([1e3]), np.array([2e3]), np.array([0.3]), np.array([ck.COULOMB]), gN,
                                 np.zeros((n, 2)), *hist,
                                 fc, acc, pen)
            ck.contact_forces(u, du, 1e-3, c, tr[0], tr[1], fcon)
            out.append((fcon.copy(), acc.copy(), pen.copy()))
        for a, b in zip(*out):
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * np.abs(b).max())


@pytest.mark.parametrize("geometry", ["axisymmetric", "plane_strain"])
def test_elastic_bar_bounces_off_wall(geometry):
    """nu = 0 bar at v0 = 1 m/s onto a fixed frictionless wall: contact force rho c v0 A while the
    wave runs (1-D theory), contact for 2 L / c, rebound with the momentum reversed; energy balance
    KE + W_int + E_c = KE0 and impulse = momentum change."""
    s, ft, tags = bar(geometry)
    v0 = 1e3                                                        # mm/s
    s.set_velocity((0.0, -v0))
    pair = s.add_contact(Plane(), ft, tags["bottom"], penalty=2e5)
    c = math.sqrt(E / RHO)
    rows = []
    s.initialize()
    p0 = momentum(s)
    s.run(3.0 * L / c, rows=61, progress=0,
          on_row=lambda so, t: rows.append((t, pair.force()[1], so.energies()["balance_error"])))
    rows = np.array(rows)
    F0 = RHO * c * v0 * cross_section(geometry)
    assert np.interp(L / c, rows[:, 0], rows[:, 1]) == pytest.approx(F0, rel=0.03)
    t_off = rows[rows[:, 1] > 0, 0].max()
    assert 1.0 <= t_off / (2 * L / c) <= 1.1
    assert rows[-1, 1] == 0.0                                       # separated
    e = s.energies()
    assert e["balance_error"] < 0.01 and rows[:, 2].max() < 0.01
    assert abs(e["kinetic"] + e["internal_work"] + e["contact_work"] - s.KE0) < 0.01 * s.KE0
    assert e["external_work"] == 0.0 and e["contact_stored"] == 0.0
    p1 = momentum(s)
    assert p1[1] > 0.95 * abs(p0[1])                                # rebound
    imp = pair.impulse()
    assert imp[1] == pytest.approx(p1[1] - p0[1], rel=1e-9)
    assert pair.max_penetration_run() < 1e-3 and pair.max_penetration() == 0.0


def test_bar_at_rest_on_wall_stays_at_rest():
    """Touching (gap 0 up to the mesh's round-off), no load, with friction: nothing moves. Under its
    own weight (nodal forces -m_i g) it stays put to the static settlement, and the wall carries
    the weight on average (impulse / time)."""
    s, ft, tags = bar("axisymmetric", nz=10)
    pair = s.add_contact(Plane(), ft, tags["bottom"], penalty=2e5, friction=0.3, law="coulomb")
    s.run(2e-6, progress=0)
    assert s.step_count > 10
    assert np.abs(s.u.x.array).max() < 1e-12 and np.abs(pair.force()).max() < 1e-9     # round-off
    # under gravity, for about 5 wave round trips
    s, ft, tags = bar("axisymmetric", nz=10)
    pair = s.add_contact(Plane(), ft, tags["bottom"], penalty=2e5, friction=0.3, law="coulomb")
    g = 9.81e3                                                       # mm/s^2
    weight = np.zeros(s.n_own)
    weight[1::2] = -g * s.mass[1::2]
    s.add_external_force(lambda t: weight)
    T = 60 * L / math.sqrt(E / RHO)                                  # 15 periods 4 L / c of the bar on the wall
    s.run(T, progress=0)
    W = g * RHO * math.pi * R ** 2 * L
    settle = RHO * g * L ** 2 / (2 * E) + W / (2e5 * math.pi * R ** 2)  # static compression + penetration
    assert np.abs(s.u.x.array).max() < 3 * settle
    assert pair.impulse()[1] == pytest.approx(W * T + momentum(s)[1], rel=1e-9)
    assert pair.impulse()[1] == pytest.approx(W * T, rel=0.03)
    assert s.energies()["load_work"] > 0


@pytest.mark.parametrize("law", ["coulomb", "quasi-coulomb"])
def test_sliding_bar_friction_is_mu_times_normal_force(law):
    """A plane-strain bar lands on the wall at an angle (vx = 5 |vy|) and slides: while every contact
    node slips, the tangential force is -mu times the normal force (coulomb: to round-off), and
    the tangential impulse is -mu times the normal one."""
    mu, vx, vy = 0.3, 5e3, -1e3
    s, ft, tags = bar("plane_strain", nu=0.3, axis_bc=False)
    s.set_velocity((vx, vy))
    pair = s.add_contact(Plane(), ft, tags["bottom"], penalty=2e5, friction=mu, law=law)
    checked = []

    def on_row(so, t):
        on, slip = pair.status()
        F = pair.force()
        if on > 0 and slip == on:
            checked.append(t)
            if law == "coulomb":
                assert F[0] == pytest.approx(-mu * F[1], rel=1e-10)
                assert pair.tangential_force() == pytest.approx(-mu * pair.normal_force(), rel=1e-10)

    s.initialize()
    p0 = momentum(s)
    s.run(2.5 * L / math.sqrt(E / RHO), rows=31, progress=0, on_row=on_row)
    assert len(checked) > 10
    imp = pair.impulse()
    p1 = momentum(s)
    np.testing.assert_allclose(imp, p1 - p0, rtol=1e-9)
    assert imp[0] == pytest.approx(-mu * imp[1], rel=1e-9 if law == "coulomb" else 0.05)
    assert p1[0] > 0                                                # still sliding
    e = s.energies()
    assert e["contact_work"] > 0.05 * s.KE0                         # frictional dissipation
    assert e["balance_error"] < 0.01


def test_moving_wall_pushes_bar():
    """A wall moving up at 1 m/s into a bar at rest: the tool's work enters the external work,
    KE + W_int + E_c = W_tool, impulse = momentum."""
    s, ft, tags = bar("axisymmetric", nu=0.3)
    V, T = 1e3, 4e-6
    wall = Plane(point=(0.0, -1e-6), path=piecewise_path([0.0, T], [0.0, 0.0], [0.0, V * T]))
    pair = s.add_contact(wall, ft, tags["bottom"], penalty=2e5)
    s.run(T, rows=5, progress=0)
    e = s.energies()
    assert e["tool_work"] > 0 and e["external_work"] == pytest.approx(e["tool_work"])
    assert e["balance_error"] < 0.01
    assert pair.impulse()[1] == pytest.approx(momentum(s)[1], rel=1e-9)


@pytest.mark.parametrize("variant", ["python_gap", "ufl", "circle"])
def test_routes_and_gaps_agree(variant):
    """A plastic bar with friction against a moving wall (or a circle): the compiled gap in chunks
    == the Python gap step by step (same kernels: round-off only); fused == UFL route."""
    def run(route, python_gap):
        s, ft, tags = bar("axisymmetric", route=route, nu=0.3, nz=10, plastic=True, comm=MPI.COMM_SELF)
        s.set_velocity((0.0, -20e3))
        if variant == "circle":
            tool = Circle((0.0, -30.0), 30.0, path=lambda t, use_ufl: (0.0, 1e3 * t))
        else:
            tool = Plane(path=piecewise_path([0.0, 1e-5], [0.0, 0.01], [0.0, 0.005]))
        pair = s.add_contact(PythonGap(tool) if python_gap else tool, ft, tags["bottom"], penalty=2e5,
                             friction=0.2, law="quasi-coulomb")
        s.run(4e-6, rows=3, progress=0)
        assert s.contact.chunkable != python_gap
        return s.u.x.array.copy(), pair.force(), s.energies(), s.max_eqps()

    ref = run("fused", False)
    other = run("ufl", False) if variant == "ufl" else run("fused", True)
    tol = 1e-10 if variant == "ufl" else 1e-12
    assert ref[3] > 0.005                                           # plastic
    assert np.abs(ref[0] - other[0]).max() <= tol * np.abs(ref[0]).max()
    np.testing.assert_allclose(ref[1], other[1], rtol=tol * 100, atol=tol * np.abs(ref[1]).max() * 100)
    for k in ("kinetic", "internal_work", "contact_work", "tool_work"):
        assert other[2][k] == pytest.approx(ref[2][k], rel=1e-9, abs=1e-12), k


def test_checkpoint_resume_with_contact_and_drivers():
    """state_dict after 30 steps -> a new solver -> load_state -> 30 more steps == 60 steps straight
    (contact with friction, prescribed velocity, traction)."""
    from fenics_plast.checkpoint import Keyed, KeyedTable

    def make():
        s, ft, tags = bar("axisymmetric", nu=0.3, nz=10, plastic=True, comm=MPI.COMM_SELF)
        s.set_velocity((0.0, -10e3))
        wall = Plane(path=piecewise_path([0.0, 1e-5], [0.0, 0.01], [0.0, 0.0]))
        s.add_contact(wall, ft, tags["bottom"], penalty=2e5, friction=0.2, law="coulomb")
        k = s.add_prescribed_velocity(1, s.boundary_dofs(ft.find(tags["top"])), lambda t: -10e3 + 1e9 * t)
        s.add_traction(ft, tags["outer"], (lambda t: -2.0 * t / 1e-6, 0.0))
        return s, k

    a, k = make()
    a.initialize()
    dt = 0.8 * a.stable_dt()
    for _ in range(60):
        a.step(dt)
    b, _ = make()
    b.initialize()
    for _ in range(30):
        b.step(dt)
    state = {key: KeyedTable(key, v.values, v.keys) if isinstance(v, Keyed) else v
             for key, v in b.restart.state_dict().items()}
    c, _ = make()
    c.restart.load_state(state)
    for _ in range(30):
        c.step(dt)
    assert np.array_equal(a.u.x.array, c.u.x.array) and np.array_equal(a.v.x.array, c.v.x.array)
    np.testing.assert_array_equal(a.contact.pairs[0].force(), c.contact.pairs[0].force())
    np.testing.assert_array_equal(a.reaction(k), c.reaction(k))
    ea, ec = a.energies(), c.energies()
    for key in ea:
        assert ec[key] == pytest.approx(ea[key], rel=1e-12, abs=1e-15), key


def test_penalty_enters_the_stable_step():
    """dt_stable combines the element limit and 2 sqrt(m / (eps A)); a penalty whose own limit equals
    the element's runs stable at dt_safety 0.8 (the plain minimum of the two does not)."""
    s, ft, tags = bar("axisymmetric", nz=10)
    dte = s.stable_dt()
    probe = s.add_contact(Plane(), ft, tags["bottom"], penalty=1.0)
    eps = (probe.dt_stable / dte) ** 2                              # dt_c = dt_e
    s, ft, tags = bar("axisymmetric", nz=10)
    s.set_velocity((0.0, -1e3))
    pair = s.add_contact(Plane(), ft, tags["bottom"], penalty=eps)
    assert pair.dt_stable == pytest.approx(dte, rel=1e-9)
    assert s.stable_dt() == pytest.approx(dte / math.sqrt(2.0), rel=1e-9)
    s.run(2.5 * L / math.sqrt(E / RHO), dt_safety=0.8, progress=0)
    assert s.energies()["balance_error"] < 0.02


def test_contact_arguments_are_validated():
    s, ft, tags = bar("plane_strain", nz=4)
    with pytest.raises(ValueError, match="law"):
        s.add_contact(Plane(), ft, tags["bottom"], penalty=1e3, law="sticky")
    with pytest.raises(ValueError, match="penalty"):
        s.add_contact(Plane(), ft, tags["bottom"], penalty=0.0)
    with pytest.raises(ValueError, match="no facets"):
        s.add_contact(Plane(), ft, 999, penalty=1e3)
    s.initialize()
    with pytest.raises(RuntimeError, match="before the first step"):
        s.add_contact(Plane(), ft, tags["bottom"], penalty=1e3)


# ----------------------------------------------------------------------------------------------
# serial vs mpirun -n 2


def mpi_case(comm=MPI.COMM_WORLD):
    """A plastic bar pushed by a prescribed top velocity onto a wall with friction, a lateral
    traction on its side; returns (positions, displacements) on rank 0 and the scalars."""
    s, ft, tags = bar("axisymmetric", nu=0.3, nz=12, comm=comm, plastic=True)
    s.set_velocity((0.0, -20e3))
    wall = Plane(path=piecewise_path([0.0, 1e-5], [0.0, 0.02], [0.0, 0.0]))
    pair = s.add_contact(wall, ft, tags["bottom"], penalty=2e5, friction=0.2, law="coulomb")
    k = s.add_prescribed_velocity(1, s.boundary_dofs(ft.find(tags["top"])), -20e3)
    s.add_traction(ft, tags["outer"], (-5.0, 0.0))
    s.run(5e-6, rows=3, progress=0)
    e = s.energies()
    n = s.V.dofmap.index_map.size_local
    X, u = comm.gather(s.reference_positions[:n], root=0), comm.gather(s.u.x.array.reshape(-1, 2)[:n], root=0)
    out = dict(force=pair.force(), reaction=s.reaction(k), impulse=pair.impulse(), steps=s.step_count,
               pen=pair.max_penetration_run(), eqps=s.max_eqps(), ranks=comm.size,
               **{f"e_{key}": v for key, v in e.items()})
    if comm.rank == 0:
        X, u = np.concatenate(X), np.concatenate(u)
        order = np.lexsort((np.round(X[:, 0], 9), np.round(X[:, 1], 9)))
        out.update(X=X[order], u=u[order])
    return out


@pytest.mark.skipif(not SERIAL, reason="starts its own mpirun")
@pytest.mark.skipif(shutil.which("mpirun") is None and not Path("/usr/bin/mpirun").exists(), reason="no mpirun")
def test_contact_serial_vs_mpi(tmp_path):
    mpirun = "/usr/bin/mpirun" if Path("/usr/bin/mpirun").exists() else shutil.which("mpirun")
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_", "OPAL_"))}
    out = tmp_path / "mpi.npz"
    p = subprocess.run([mpirun, "--allow-run-as-root", "--oversubscribe", "-n", "2", sys.executable, __file__,
                        str(out)], cwd=REPO, timeout=300, env=env, capture_output=True, text=True)
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    a, b = mpi_case(MPI.COMM_SELF), np.load(out)
    assert int(b["ranks"]) == 2 and int(b["steps"]) == a["steps"]
    np.testing.assert_allclose(b["X"], a["X"], atol=1e-12)
    assert np.abs(b["u"] - a["u"]).max() <= 1e-9 * np.abs(a["u"]).max()
    assert a["eqps"] > 0.01 and a["pen"] > 0
    for key in ("force", "reaction", "impulse", "pen", "eqps", "e_kinetic", "e_internal_work", "e_contact_work",
                "e_prescribed_work", "e_load_work", "e_tool_work"):
        np.testing.assert_allclose(b[key], a[key], rtol=1e-8, atol=1e-12, err_msg=key)


if __name__ == "__main__":
    res = mpi_case()
    if MPI.COMM_WORLD.rank == 0:
        np.savez(sys.argv[1], **res)
