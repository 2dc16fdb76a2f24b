"""The explicit solver's fused internal-force pass against the UFL residual assembled by dolfinx.

Both routes compute R_u = int (J/theta) tau : (Grad v F^-1) w dV with the same material kernels;
the fused pass (fenics_plast/solvers/fused_force.py) must agree with the UFL form to round-off on
a deformed, yielding state, for both elements and both 2-D geometries, and a short Taylor run must
give the same answer with either route.
"""
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from fenics_plast.kinematics import Kinematics
from fenics_plast.material import Hardening, Material
from fenics_plast.meshing import bar_mesh
from fenics_plast.solvers.explicit import ExplicitDynamics

REPO = Path(__file__).resolve().parent.parent
RHO = 8.93e-9   # tonne/mm^3


def _solver(mesh, geometry, element, route, model):
    kin = Kinematics(mesh, geometry)
    mat = Material(117e3, 0.35, Hardening("linear", yield_stress=400.0, modulus=100.0), model=model)
    return ExplicitDynamics(mesh, kin, mat, RHO, (), element=element, internal_force=route, log=lambda m: None)


def _field(X, scale):
    """A smooth, non-homogeneous displacement field [mm] (radial bulge, axial shortening, shear)."""
    r, z = X[:, 0], X[:, 1]
    u = np.empty((len(r), 2))
    u[:, 0] = scale * (0.08 * r * (1.0 + 0.3 * z / 8.0) + 0.01 * z)
    u[:, 1] = scale * (-0.06 * z - 0.004 * z * z / 8.0 + 0.02 * r)
    return u.reshape(-1)


def two_increments(s, field=None):
    """Increment 1: 0 -> U1 (yields), increment 2: U1 -> U2, as the explicit step applies them;
    ``field(X, scale)``: the displacement field (default :func:`_field`)."""
    field = _field if field is None else field
    U1, U2 = field(s.reference_positions, 1.0), field(s.reference_positions, 1.04)
    s.u.x.array[:] = U1
    s.internal_force()
    s.u_n.x.array[:] = U1
    if s.theta is not None:
        s.theta_n.x.array[:] = s.theta.x.array
    s.u.x.array[:] = U2
    s.internal_force()
    return s


@pytest.mark.parametrize("geometry,element,model", [
    ("axisymmetric", "q1p0", "isochoric"),
    ("axisymmetric", "q1", "isochoric"),
    ("axisymmetric", "q1p0", "seed"),
    ("plane_strain", "q1p0", "isochoric"),
])
def test_fused_force_equals_ufl_residual(geometry, element, model):
    mesh, _, _, _ = bar_mesh(MPI.COMM_SELF, 3.0, 8.0, 3, 5)
    fused = two_increments(_solver(mesh, geometry, element, "fused", model))
    ufl = two_increments(_solver(mesh, geometry, element, "ufl", model))
    assert fused.qmap.eqps.max() > 0.02, "the test state must be plastic"
    fmax = np.abs(ufl.f).max()
    assert np.abs(fused.f - ufl.f).max() <= 1e-12 * fmax
    for name in ("tau_values", "binv", "eqps"):
        a, b = getattr(fused.qmap, name), getattr(ufl.qmap, name)
        assert np.abs(a - b).max() <= 1e-12 * max(np.abs(b).max(), 1.0), name


def test_taylor_run_same_with_either_route():
    """10 us of the Taylor bar (132 steps, plastic from the first steps): same displacements."""
    from fenics_plast.problem import load_problem
    from fenics_plast.runner_explicit import build_explicit
    out = {}
    for route in ("fused", "ufl"):
        problem = load_problem(REPO / "demos" / "taylor_bar.toml",
                               [f"analysis.internal_force={route}", "analysis.end_time=10"])
        s = build_explicit(problem, MPI.COMM_SELF).solver
        s.run(10e-6, rows=2, progress=0)
        out[route] = (s.u.x.array.copy(), s.max_eqps(), s.step_count)
    uf, uu = out["fused"][0], out["ufl"][0]
    assert out["fused"][2] == out["ufl"][2]
    assert out["fused"][1] > 0.5
    assert np.abs(uf - uu).max() <= 1e-10 * np.abs(uu).max()
    assert out["fused"][1] == pytest.approx(out["ufl"][1], rel=1e-10)


def test_route_is_validated():
    mesh, _, _, _ = bar_mesh(MPI.COMM_SELF, 3.0, 8.0, 2, 2)
    with pytest.raises(ValueError, match="internal_force"):
        _solver(mesh, "axisymmetric", "q1p0", "numba", "isochoric")
