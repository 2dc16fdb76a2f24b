"""fenics_plast.dolfinx_compat: the one module that knows dolfinx 0.5.2 from 0.9.

Each helper is checked against what it must mean on either version (shapes, shared memory, the
quadrature rule against the quadrature space's points, the lifting's sign), and a scan of the sources
holds the rest of the project to it: no version switch and no call that exists on one version only
outside the module."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx import mesh as dm
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

from fenics_plast import dolfinx_compat as dc

ROOT = Path(__file__).resolve().parent.parent

# calls and names of one dolfinx version only: outside dolfinx_compat they would break the other
ONE_VERSION_ONLY = {
    r"\bdolfinx\.__version__": "a version switch",
    r"\bLEGACY\b": "a version switch",
    r"\bfem\.FunctionSpace\(": "0.5 only (0.9: fem.functionspace)",
    r"\bfem\.functionspace\(": "0.9 only",
    r"\bVectorFunctionSpace\b": "0.5 only",
    r"\bufl\.(FiniteElement|VectorElement|TensorElement|MixedElement)\b": "0.5 only (0.9: basix.ufl)",
    r"\bbasix\.ufl\b": "0.9 only",
    r"\.list\.array\b": "0.5 only (0.9: 2-D dofmap arrays)",
    r"geometry\.dofmap\.(array|links)\b": "0.5 only",
    r"\.vector\.(copy|duplicate|array|getArray)\b|\bcopy\([^)]*\.vector\)": "0.5 only (0.9: x.petsc_vec)",
    r"\.x\.petsc_vec\b": "0.9 only",
    r"\batan_2\b": "0.5 only (0.9: atan2)",
    r"\bScatterMode\.add\b|cpp\.la\b": "0.5 only (0.9: la.InsertMode)",
    r"apply_lifting\(.*\bscale=": "0.5's apply_lifting keyword (0.9: alpha)",
    r"QuadratureType\.Default": "0.5's make_quadrature signature",
    r"entities_to_geometry": "signature differs",
}


def _sources():
    for folder in ("fenics_plast", "tests", "demos", "benchmarks", "scripts"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            if path.name not in ("dolfinx_compat.py", "test_dolfinx_compat.py"):
                yield path


def test_no_version_switch_outside_the_compat_module():
    found = []
    for path in _sources():
        for n, line in enumerate(path.read_text().splitlines(), 1):
            code = line.split("#", 1)[0]
            for pattern, why in ONE_VERSION_ONLY.items():
                if re.search(pattern, code):
                    found.append(f"{path.relative_to(ROOT)}:{n}: {why}: {line.strip()}")
    # the platform benchmark reports the version it ran on; that is not a switch
    found = [f for f in found if not f.startswith("benchmarks/bench_platform.py")]
    assert not found, "\n".join(found)


@pytest.fixture(scope="module")
def square():
    """A 3 x 2 quadrilateral mesh of [0, 3] x [0, 2], its vertices moved off the grid (no affine map)."""
    m = dm.create_rectangle(MPI.COMM_WORLD, [np.array([0.0, 0.0]), np.array([3.0, 2.0])], [3, 2],
                            dm.CellType.quadrilateral)
    x = m.geometry.x
    x[:, 0] += 0.1 * np.sin(2.0 * x[:, 1]) * x[:, 0] * (3.0 - x[:, 0])
    return m


def test_supported_version():
    assert dc.VERSION in dc.SUPPORTED


def test_spaces_and_dofmaps(square):
    n_local = square.topology.index_map(2).size_local + square.topology.index_map(2).num_ghosts
    V = dc.vector_space(square)
    D0 = dc.function_space(square, "DG", 0)
    W = dc.mixed_space(square, [("Lagrange", 1, (2,)), ("DG", 0, None)])
    Q = dc.quadrature_space(square, 2, (3, 3))
    assert V.dofmap.index_map_bs == 2 and dc.cell_dofs(V).shape == (n_local, 4)
    assert dc.cell_dofs(D0).shape == (n_local, 1)
    assert dc.cell_dofs(Q).shape == (n_local, 4) and Q.dofmap.index_map_bs == 9
    assert dc.geometry_dofs(square).shape == (n_local, 4)
    assert W.num_sub_spaces == 2
    kinds = [dc.space_kind(s) for s in (W, V, D0, Q, W.sub(0).collapse()[0], W.sub(1).collapse()[0])]
    assert kinds == ["mixed", "continuous degree 1", "degree 0", "other", "continuous degree 1", "degree 0"]
    # a CG1 space's nodes are the mesh's geometry nodes, cell by cell
    X = V.tabulate_dof_coordinates()
    np.testing.assert_allclose(X[dc.cell_dofs(V)], square.geometry.x[dc.geometry_dofs(square)], atol=1e-14)


def test_quadrature_rule_is_the_quadrature_space_rule(square):
    """A quadrature Function filled with f(x) at the rule's points integrates as the weighted sum, the
    points placed by eval_expression (the same rule the forms use)."""
    pts, wts = dc.quadrature_rule("quadrilateral", 2)
    assert pts.shape == (4, 2) and wts.sum() == pytest.approx(1.0)
    hpts, hwts = dc.quadrature_rule("hexahedron", 2)
    assert hpts.shape == (8, 3) and hwts.sum() == pytest.approx(1.0)
    n = square.topology.index_map(2).size_local
    cells = np.arange(n, dtype=np.int32)
    xq = dc.eval_expression(fem.Expression(ufl.SpatialCoordinate(square), pts), square, cells).reshape(n, 4, 2)
    Q = dc.quadrature_space(square, 2, (3, 3))
    fq = fem.Function(Q)
    values = np.zeros((n, 4, 9))
    values[..., 0] = xq[..., 0] ** 2 * xq[..., 1]
    fq.x.array.reshape(-1, 9)[dc.cell_dofs(Q)[:n].reshape(-1)] = values.reshape(-1, 9)
    dx = ufl.Measure("dx", domain=square, metadata={"quadrature_degree": 2, "quadrature_scheme": "default"})
    integral = square.comm.allreduce(fem.assemble_scalar(fem.form(fq[0, 0] * dx)), op=MPI.SUM)
    detJ = dc.eval_expression(fem.Expression(abs(ufl.JacobianDeterminant(square)), pts), square, cells)
    expected = square.comm.allreduce(float(np.sum(values[..., 0] * wts * detJ)), op=MPI.SUM)
    assert integral == pytest.approx(expected, rel=1e-13)


def test_vec_scatter_and_lifting(square):
    V = dc.function_space(square, "Lagrange", 1)
    u = fem.Function(V)
    dc.petsc_vec(u).set(2.5)                                      # the Vec shares u's values
    assert np.all(u.x.array == 2.5)
    # ghost contributions added to their owners: every rank marks the nodes of its local cells
    u.x.array[:] = 0.0
    u.x.array[dc.locate_cell_dofs(V, np.arange(dc.cell_dofs(V).shape[0]))] = 1.0
    dc.scatter_reverse_add(u)
    n_owned = V.dofmap.index_map.size_local
    assert u.x.array[:n_owned].min() >= 1.0
    assert square.comm.allreduce(float(u.x.array[:n_owned].max()), op=MPI.MAX) == (square.comm.size > 1) + 1.0
    # apply_lifting: b -= alpha A (g - x0), rows of the constrained dofs included
    a = fem.form(ufl.inner(ufl.grad(ufl.TrialFunction(V)), ufl.grad(ufl.TestFunction(V))) * ufl.dx)
    square.topology.create_connectivity(1, 2)
    left = dm.locate_entities_boundary(square, 1, lambda x: np.isclose(x[0], 0.0))
    bc = fem.dirichletbc(PETSc.ScalarType(1.0), fem.locate_dofs_topological(V, 1, left), V)
    A = fem_petsc.assemble_matrix(a)
    A.assemble()
    g = fem.Function(V)
    g.x.array[bc.dof_indices()[0]] = 1.0
    x0 = fem.Function(V)
    x0.x.array[:] = 0.25
    Ag = A.createVecLeft()
    A.mult(dc.petsc_vec(g), Ag)
    Ax0 = A.createVecLeft()
    x0_bc = fem.Function(V)
    x0_bc.x.array[bc.dof_indices()[0]] = 0.25
    A.mult(dc.petsc_vec(x0_bc), Ax0)
    b = fem_petsc.create_vector(fem.form(ufl.TestFunction(V) * ufl.dx))
    with b.localForm() as bl:
        bl.set(0.0)
    dc.apply_lifting(b, [a], [[bc]], x0=[dc.petsc_vec(x0)], alpha=-2.0)
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    np.testing.assert_allclose(b.array, 2.0 * (Ag.array - Ax0.array), atol=1e-12)
