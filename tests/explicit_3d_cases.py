"""3-D explicit cases shared by tests/test_explicit_3d.py, tests/mpi_explicit_3d.py and
benchmarks/bench_taylor_3d.py: a quarter of a round bar of hexahedra (a box mapped onto the quarter
disc, no O-grid) hitting a rigid frictionless wall (a Taylor impact), until the scene format and
meshes/round_bar_quarter.geo of issue #14 land. Units mm, N, MPa, s, tonne/mm^3.
"""
from __future__ import annotations

import numpy as np

RHO = 8.93e-9            # copper [tonne/mm^3]
V0 = 227e3               # impact speed [mm/s]


def quarter_bar(comm, n_r, n_z, radius=3.2, length=32.4):
    """(mesh, facets) of a quarter bar 0 <= x, y, x^2 + y^2 <= radius^2, 0 <= z <= length with
    n_r x n_r x n_z hexahedra: the unit square mapped onto the quarter disc by the elliptical grid
    map (x, y) = R (s sqrt(1 - t^2 / 2), t sqrt(1 - s^2 / 2)). facets: {"x0", "y0", "bottom"} local
    boundary facet indices of the planes x = 0, y = 0 and z = 0."""
    import dolfinx
    mesh = dolfinx.mesh.create_box(comm, [np.zeros(3), np.array([1.0, 1.0, length])], [n_r, n_r, n_z],
                                   cell_type=dolfinx.mesh.CellType.hexahedron)
    x = mesh.geometry.x
    s, t = x[:, 0].copy(), x[:, 1].copy()
    x[:, 0] = radius * s * np.sqrt(1.0 - 0.5 * t * t)
    x[:, 1] = radius * t * np.sqrt(1.0 - 0.5 * s * s)
    fdim = mesh.topology.dim - 1
    tol = 1e-9 * length
    facets = {name: dolfinx.mesh.locate_entities_boundary(mesh, fdim, lambda X, k=k: np.abs(X[k]) < tol)
              for name, k in (("x0", 0), ("y0", 1), ("bottom", 2))}
    return mesh, facets


def taylor_3d(comm, n_r=4, n_z=24, element="q1p0", model="isochoric", internal_force="fused", **kw):
    """The explicit solver of the quarter bar (copper, linear hardening) moving at V0 toward the
    wall z = 0: symmetry on x = 0 and y = 0, the wall holds u_z on z = 0."""
    from fenics_plast.kinematics import Kinematics
    from fenics_plast.material import Hardening, Material
    from fenics_plast.solvers.explicit import ExplicitDynamics
    mesh, facets = quarter_bar(comm, n_r, n_z)
    mat = Material(117e3, 0.35, Hardening("linear", yield_stress=400.0, modulus=100.0), model=model)
    s = ExplicitDynamics(mesh, Kinematics(mesh, "3d"), mat, RHO,
                         [(0, facets["x0"]), (1, facets["y0"]), (2, facets["bottom"])], element=element,
                         internal_force=internal_force, log=lambda m: None, **kw)
    s.set_velocity((0.0, 0.0, -V0))
    return s
