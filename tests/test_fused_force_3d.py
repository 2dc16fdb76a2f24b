"""The explicit solver's fused internal-force pass on hexahedra against the UFL residual.

The UFL residual ``Kinematics.internal_virtual_work`` (geometry "3d", assembled by dolfinx: the
explicit solver's ``internal_force = "ufl"`` route) is the definition; the fused pass
(fenics_plast/solvers/fused_force.py with the hexahedral kernels of fused_force_hex.py) must give
the same force, stress and state to 1e-12 on a deformed, yielding state of distorted hexahedra, for
both elements and both material models (the 3-D twin of tests/test_fused_force.py).
"""
import numpy as np
import pytest
from mpi4py import MPI

from fenics_plast.kinematics import Kinematics
from fenics_plast.material import Hardening, Material
from fenics_plast.solvers.explicit import ExplicitDynamics
from test_fused_force import two_increments

RHO = 8.93e-9   # tonne/mm^3


def distorted_box(comm, n=(3, 3, 4), size=(3.0, 3.0, 8.0), amplitude=0.12):
    """A box of hexahedra whose interior nodes are moved by a smooth field (non-parallel faces,
    warped faces), [mm]."""
    import dolfinx
    mesh = dolfinx.mesh.create_box(comm, [np.zeros(3), np.array(size)], list(n),
                                   cell_type=dolfinx.mesh.CellType.hexahedron)
    x = mesh.geometry.x
    h = np.array(size) / np.array(n)
    s = x[:, :3] / np.array(size)
    bump = np.sin(np.pi * s[:, 0]) * np.sin(np.pi * s[:, 1]) * np.sin(np.pi * s[:, 2])
    x[:, 0] += amplitude * h[0] * bump * np.cos(3.0 * s[:, 2])
    x[:, 1] += amplitude * h[1] * bump * np.sin(2.0 * s[:, 0] + 1.0)
    x[:, 2] += amplitude * h[2] * bump * np.cos(2.5 * s[:, 1])
    return mesh


def _solver(mesh, element, route, model):
    kin = Kinematics(mesh, "3d")
    mat = Material(117e3, 0.35, Hardening("linear", yield_stress=400.0, modulus=100.0), model=model)
    return ExplicitDynamics(mesh, kin, mat, RHO, (), element=element, internal_force=route, log=lambda m: None)


def field_3d(X, scale):
    """A smooth, non-homogeneous 3-D displacement field [mm] (bulge, shortening, shear, twist)."""
    x, y, z = X[:, 0], X[:, 1], X[:, 2]
    u = np.empty((len(x), 3))
    u[:, 0] = scale * (0.08 * x * (1.0 + 0.3 * z / 8.0) + 0.01 * z - 0.02 * y * z / 8.0)
    u[:, 1] = scale * (0.07 * y * (1.0 + 0.2 * z / 8.0) + 0.02 * x * z / 8.0 + 0.005 * x)
    u[:, 2] = scale * (-0.06 * z - 0.004 * z * z / 8.0 + 0.02 * x + 0.01 * y)
    return u.reshape(-1)


@pytest.mark.parametrize("element,model", [("q1p0", "isochoric"), ("q1", "isochoric"), ("q1p0", "seed"),
                                           ("q1", "seed")])
def test_fused_force_3d_equals_ufl_residual(element, model):
    mesh = distorted_box(MPI.COMM_SELF)
    fused = two_increments(_solver(mesh, element, "fused", model), field_3d)
    ufl = two_increments(_solver(mesh, element, "ufl", model), field_3d)
    assert fused.bs == 3 and fused.qmap.nq == 8
    assert fused.qmap.eqps.max() > 0.02, "the test state must be plastic"
    fmax = np.abs(ufl.f).max()
    assert np.abs(fused.f - ufl.f).max() <= 1e-12 * fmax
    for name in ("tau_values", "binv", "eqps"):
        a, b = getattr(fused.qmap, name), getattr(ufl.qmap, name)
        assert np.abs(a - b).max() <= 1e-12 * max(np.abs(b).max(), 1.0), name
    if element == "q1p0":
        n = fused.theta_cells.size
        assert np.abs(fused.theta_cells - ufl.theta.x.array[:n]).max() <= 1e-13


def test_taylor_3d_run_same_with_either_route():
    """2 us of the quarter-bar Taylor impact (53 steps, plastic at the face): same displacements."""
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from explicit_3d_cases import taylor_3d
    out = {}
    for route in ("fused", "ufl"):
        s = taylor_3d(MPI.COMM_SELF, internal_force=route)
        s.run(2e-6, rows=2, progress=0)
        out[route] = (s.u.x.array.copy(), s.max_eqps(), s.step_count)
    assert out["fused"][2] == out["ufl"][2] and out["fused"][1] > 0.2
    assert np.abs(out["fused"][0] - out["ufl"][0]).max() <= 1e-10 * np.abs(out["ufl"][0]).max()
    assert out["fused"][1] == pytest.approx(out["ufl"][1], rel=1e-10)
