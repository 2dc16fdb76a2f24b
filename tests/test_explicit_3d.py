"""Explicit dynamics on hexahedra (geometry "3d"): stable step, an elastic wave against its closed
form, a short Taylor impact (energy balance, both elements, checkpoint round trip) and serial vs
``mpirun -n 2``. The cases: tests/explicit_3d_cases.py.
"""
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from fenics_plast.kinematics import Kinematics
from fenics_plast.material import Material
from fenics_plast.solvers import hex_step
from fenics_plast.solvers.explicit import ExplicitDynamics
from fenics_plast.solvers.fused_force_hex import HEX_VERTICES

sys.path.insert(0, str(Path(__file__).resolve().parent))
from explicit_3d_cases import quarter_bar, taylor_3d  # noqa: E402
from scene_runs import needs_mpirun, serial_and_two_ranks  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
E, NU, RHO = 200e3, 0.3, 7.8e-9


def _lame(E, nu):
    return E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))


@pytest.mark.parametrize("fbar", [True, False])
def test_hex_step_unit_cube_and_flattened_hex(fbar):
    """Unit cube: V / A_max = 1 and the exact element step is that of its breathing mode,
    2 / omega = sqrt((lambda + 2 mu) / (3 lambda + 2 mu)) h / c, which the size estimate kappa h / c
    equals (nu = 0.3); a 1 x 1 x 0.01 plate: element step t / c to 1e-3, size estimate below it."""
    lam, mu = _lame(E, NU)
    c = math.sqrt((lam + 2 * mu) / RHO)
    one = np.arange(8)[None]
    kappa = float(hex_step.size_factor(lam, mu))
    for dims, size, exact, rel in (((1.0, 1.0, 1.0), 1.0, math.sqrt((lam + 2 * mu) / (3 * lam + 2 * mu)) / c, 1e-10),
                                   ((1.0, 1.0, 0.01), 0.01, 0.01 / c, 1e-3)):
        x = HEX_VERTICES * np.array(dims)
        assert hex_step.hex_size(x, one)[0] == pytest.approx(size, rel=1e-12)
        mass = np.full((1, 8), RHO * np.prod(dims) / 8.0)
        e = hex_step.hex_eig_dt(x, one, [0], mass, [lam], [mu], fbar)[0]
        assert e == pytest.approx(exact, rel=rel)
        assert kappa * size / c <= e * (1 + 1e-12)
    assert kappa == pytest.approx(math.sqrt((lam + 2 * mu) / (3 * lam + 2 * mu)), rel=1e-14)


def test_stable_step_of_a_box_mesh_is_the_element_step():
    """A mesh of 0.5 mm cubes: the stable step (policy "element") is the cube's breathing-mode step,
    the same with the "size" policy (kappa h / c is exact on cubes)."""
    import dolfinx
    mesh = dolfinx.mesh.create_box(MPI.COMM_WORLD, [np.zeros(3), np.array([2.0, 1.0, 1.5])], [4, 2, 3],
                                   cell_type=dolfinx.mesh.CellType.hexahedron)
    lam, mu = _lame(E, NU)
    c = math.sqrt((lam + 2 * mu) / RHO)
    breathing = 0.5 * math.sqrt((lam + 2 * mu) / (3 * lam + 2 * mu)) / c
    for policy in ("element", "size"):
        s = ExplicitDynamics(mesh, Kinematics(mesh, "3d"), Material(E, NU, None), RHO, (), stable_step=policy,
                             log=lambda m: None)
        assert s.stable_dt() == pytest.approx(breathing, rel=1e-10), policy


def test_longitudinal_wave_in_laterally_held_bar():
    """A bar 0.5 x 0.5 x 50 mm whose lateral faces are symmetry planes (uniaxial strain) moving at
    v0 hits a rigid wall: the front runs at c = sqrt((lambda + 2 mu) / rho) and the stress behind it
    is sigma_zz = -rho c v0."""
    import dolfinx
    L, a = 50.0, 0.5
    comm = MPI.COMM_WORLD
    mesh = dolfinx.mesh.create_box(comm, [np.zeros(3), np.array([a, a, L])], [1, 1, 100],
                                   cell_type=dolfinx.mesh.CellType.hexahedron)
    fdim = 2
    tol = 1e-9
    face = {k: dolfinx.mesh.locate_entities_boundary(mesh, fdim, f) for k, f in (
        ("x", lambda X: (np.abs(X[0]) < tol) | (np.abs(X[0] - a) < tol)),
        ("y", lambda X: (np.abs(X[1]) < tol) | (np.abs(X[1] - a) < tol)),
        ("bottom", lambda X: np.abs(X[2]) < tol))}
    lam, mu = _lame(E, NU)
    c = math.sqrt((lam + 2 * mu) / RHO)
    s = ExplicitDynamics(mesh, Kinematics(mesh, "3d"), Material(E, NU, None), RHO,
                         [(0, face["x"]), (1, face["y"]), (2, face["bottom"])], log=lambda m: None)
    v0 = 1e-4 * c
    s.set_velocity((0.0, 0.0, -v0))
    n = s.V.dofmap.index_map.size_local
    X = s.reference_positions[:n]
    line = np.flatnonzero((np.abs(X[:, 0]) < tol) & (np.abs(X[:, 1]) < tol))
    front = {}

    def on_row(sol, t):
        z = np.concatenate(comm.allgather(X[line, 2]))
        vz = np.concatenate(comm.allgather(sol.v.x.array.reshape(-1, 3)[line, 2]))
        o = np.argsort(z)
        z, vz = z[o], vz[o]
        k = np.nonzero(vz < -0.5 * v0)[0][0]
        front[t] = z[k - 1] + (z[k] - z[k - 1]) * (-0.5 * v0 - vz[k - 1]) / (vz[k] - vz[k - 1])

    s.run(0.6 * L / c, rows=4, on_row=on_row, progress=0)
    ts = sorted(front)[1:]
    c_num = np.polyfit(ts, [front[t] for t in ts], 1)[0]
    assert c_num == pytest.approx(c, rel=0.01)
    tz = s.qmap.cell_mean(s.qmap.tau_values[:, 2, 2])
    D0 = tz.function_space
    xc = D0.tabulate_dof_coordinates()[: D0.dofmap.index_map.size_local]
    zf = front[ts[-1]]
    sel = (xc[:, 2] > 0.2 * zf) & (xc[:, 2] < 0.8 * zf)
    num = comm.allreduce(float(tz.x.array[: len(xc)][sel].sum()), op=MPI.SUM)
    cnt = comm.allreduce(int(sel.sum()), op=MPI.SUM)
    assert cnt > 10
    assert num / cnt == pytest.approx(-RHO * c * v0, rel=0.01)
    assert s.energies()["balance_error"] < 1e-3


@pytest.mark.parametrize("element", ["q1p0", "q1"])
def test_taylor_3d_energy_balance(element):
    """5 us of a quarter-bar Taylor impact at 227 m/s: plastic at the face, energy balance within 1 %."""
    s = taylor_3d(MPI.COMM_WORLD, element=element)
    s.run(5e-6, rows=2, progress=0)
    e = s.energies()
    assert s.max_eqps() > 0.3
    assert e["balance_error"] < 0.01
    assert e["plastic"] > 0.0 and e["kinetic"] < e["kinetic"] + e["internal_work"]


def test_taylor_3d_checkpoint_round_trip():
    """state_dict after 20 steps -> a new solver -> load_state -> 20 more steps == 40 steps straight."""
    from fenics_plast.checkpoint import Keyed, KeyedTable
    a = taylor_3d(MPI.COMM_WORLD)
    a.initialize()
    dt = 0.8 * a.stable_dt()
    for _ in range(40):
        a.step(dt)
    b = taylor_3d(MPI.COMM_WORLD)
    b.initialize()
    for _ in range(20):
        b.step(dt)
    state = {key: KeyedTable(key, v.values, v.keys) if isinstance(v, Keyed) else v
             for key, v in b.restart.state_dict().items()}
    c = taylor_3d(MPI.COMM_WORLD)
    c.restart.load_state(state)
    for _ in range(20):
        c.step(dt)
    assert a.max_eqps() > 0.1
    assert np.array_equal(a.u.x.array, c.u.x.array) and np.array_equal(a.v.x.array, c.v.x.array)
    assert np.array_equal(a.qmap.eqps, c.qmap.eqps)


def test_quarter_bar_mesh():
    mesh, facets = quarter_bar(MPI.COMM_WORLD, 3, 4)
    x = mesh.geometry.x
    r = np.hypot(x[:, 0], x[:, 1])
    assert r.max() == pytest.approx(3.2, rel=1e-12) and x[:, :2].min() >= -1e-15
    assert all(MPI.COMM_WORLD.allreduce(len(f), op=MPI.SUM) > 0 for f in facets.values())


@needs_mpirun
def test_serial_vs_mpi_3d(tmp_path):
    a, b = serial_and_two_ranks(REPO / "tests" / "mpi_explicit_3d.py", ["2"], tmp_path)
    assert int(b["ranks"]) == 2
    assert int(a["steps"]) == int(b["steps"])
    np.testing.assert_allclose(a["X"], b["X"], atol=1e-12)
    assert float(a["max_eqps"]) > 0.1
    assert np.abs(a["u"] - b["u"]).max() <= 1e-10 * np.abs(a["u"]).max()
    for k in ("kinetic", "internal_work", "elastic", "max_eqps"):
        assert float(b[k]) == pytest.approx(float(a[k]), rel=1e-10), k
