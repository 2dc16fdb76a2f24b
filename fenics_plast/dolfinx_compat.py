"""The one module that knows dolfinx 0.5.2 (Debian 12) from dolfinx 0.9 (Debian 13).

Everything else in the package, the tests, demos and notebook calls these helpers where the two
APIs differ, and reads as ordinary dolfinx elsewhere. The day 0.5.2 is dropped, each helper
becomes its ``else`` branch (or a plain dolfinx call) and ``LEGACY`` goes.

What differs, and the helper that hides it:

=====================================  =====================================  =====================
dolfinx 0.5.2 (UFL 2022.2)             dolfinx 0.9 (UFL 2024.2, basix.ufl)    helper
=====================================  =====================================  =====================
``fem.FunctionSpace(mesh, element)``,  ``fem.functionspace(mesh, element)``   ``function_space``,
``fem.VectorFunctionSpace``            (value shape in the element)           ``mixed_space``
``ufl.FiniteElement / VectorElement    ``basix.ufl.element / blocked_element  ``quadrature_space``,
/ TensorElement / MixedElement``       / mixed_element / quadrature_element`` ``coordinate_element``
``dofmap.list.array`` (flat),          2-D arrays                              ``cell_dofs``,
``geometry.dofmap.links(c)``                                                  ``geometry_dofs``
``Function.vector``                    ``Function.x.petsc_vec``                ``petsc_vec``
``apply_lifting(..., scale=)``         ``apply_lifting(..., alpha=)``          ``apply_lifting``
``dolfinx.cpp.la.ScatterMode.add``     ``dolfinx.la.InsertMode.add``           ``scatter_reverse_add``
``Expression.eval(cells)``             ``Expression.eval(mesh, cells)``        ``eval_expression``
``basix.make_quadrature(rule, c, d)``  ``basix.make_quadrature(c, d)``         ``quadrature_rule``
``ufl.atan_2``                         ``ufl.atan2``                           ``atan2``
cell dofs located without (tdim,       needs the (tdim, tdim) connectivity    ``locate_cell_dofs``
tdim) connectivity
``entities_to_geometry(mesh._mesh..)`` ``entities_to_geometry(mesh._cpp..)``  ``entity_nodes``
=====================================  =====================================  =====================

Both give the same numbers for what fenics-plast computes: the default quadrature rules are
basix's on both (same points, same order), the quadrature elements of both place their points on
that rule, and the dof numbering of a space does not enter the results (they are keyed by node,
cell and point, see ``checkpoint``).
"""
from __future__ import annotations

import basix
import dolfinx
import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc

VERSION: tuple[int, int] = tuple(int(p) for p in dolfinx.__version__.split(".")[:2])
"""(major, minor) of the dolfinx found, e.g. (0, 5) or (0, 9)."""

SUPPORTED = {(0, 5): "Debian 12 bookworm (dolfinx 0.5.2)", (0, 9): "Debian 13 trixie (dolfinx 0.9.0)"}
"""The dolfinx versions fenics-plast runs on, and the Debian release that ships each."""

LEGACY = VERSION < (0, 8)
"""True on dolfinx 0.5 (UFL elements, flat dofmaps); the only version switch in the package."""

if VERSION not in SUPPORTED:     # pragma: no cover - refused by scripts/install.sh already
    raise ImportError(f"fenics-plast supports dolfinx {' and '.join(f'{a}.{b}' for a, b in SUPPORTED)} "
                      f"({'; '.join(SUPPORTED.values())}), found dolfinx {dolfinx.__version__}")

if LEGACY:
    from dolfinx.cpp.la import ScatterMode as _ScatterMode
    _ADD = _ScatterMode.add
    atan2 = ufl.atan_2
else:
    import basix.ufl as _bufl
    _ADD = dolfinx.la.InsertMode.add
    atan2 = ufl.atan2
"""UFL's two-argument arc tangent atan2(y, x)."""

_BASIX_CELL = {"interval": basix.CellType.interval, "triangle": basix.CellType.triangle,
               "quadrilateral": basix.CellType.quadrilateral, "tetrahedron": basix.CellType.tetrahedron,
               "hexahedron": basix.CellType.hexahedron}


# -- elements and spaces ----------------------------------------------------------------------------
def _element(family: str, cellname: str, degree: int, shape: tuple[int, ...] | None = None):
    """A Lagrange ("Lagrange", "CG") or discontinuous ("DG") element, scalar (shape None) or with
    value shape ``shape`` (e.g. (2,) for a 2-D displacement, (5,) for 5 nodal values)."""
    if LEGACY:
        if shape is None:
            return ufl.FiniteElement(family, cellname, degree)
        if len(shape) == 1:
            return ufl.VectorElement(family, cellname, degree, dim=shape[0])
        return ufl.TensorElement(family, cellname, degree, shape=shape)
    return _bufl.element(family, cellname, degree, shape=shape)


def function_space(mesh, family: str, degree: int, shape: tuple[int, ...] | None = None):
    """The space of ``family`` ("Lagrange" or "DG") of ``degree`` on ``mesh``; scalar when
    ``shape`` is None, else of that value shape ((gdim,) for displacements)."""
    cellname = mesh.ufl_cell().cellname()
    if LEGACY:
        return fem.FunctionSpace(mesh, _element(family, cellname, degree, shape))
    return fem.functionspace(mesh, _element(family, cellname, degree, shape))


def vector_space(mesh, degree: int = 1):
    """Continuous Lagrange displacements with gdim components (CG1 by default)."""
    return function_space(mesh, "Lagrange", degree, (mesh.geometry.dim,))


def mixed_space(mesh, parts):
    """A mixed space of ``parts``, each a (family, degree, shape or None) triple, e.g.
    [("Lagrange", 1, (2,)), ("DG", 0, None)] for q1p0's displacement and dilatation."""
    cellname = mesh.ufl_cell().cellname()
    elements = [_element(f, cellname, d, s) for f, d, s in parts]
    if LEGACY:
        return fem.FunctionSpace(mesh, ufl.MixedElement(elements))
    return fem.functionspace(mesh, _bufl.mixed_element(elements))


def quadrature_space(mesh, degree: int, shape: tuple[int, ...]):
    """Quadrature space of tensors of ``shape`` (() for scalars) at the points of
    ``quadrature_rule(cell, degree)``."""
    cellname = mesh.ufl_cell().cellname()
    if LEGACY:
        kw = dict(degree=degree, quad_scheme="default")
        if len(shape) == 0:
            el = ufl.FiniteElement("Quadrature", cellname, **kw)
        elif len(shape) == 1:
            el = ufl.VectorElement("Quadrature", cellname, dim=shape[0], **kw)
        else:
            el = ufl.TensorElement("Quadrature", cellname, shape=shape, **kw)
        return fem.FunctionSpace(mesh, el)
    return fem.functionspace(mesh, _bufl.quadrature_element(cellname, value_shape=shape, scheme="default",
                                                            degree=degree))


def coordinate_element(cellname: str, gdim: int):
    """The first-order coordinate element of a ``ufl.Mesh`` of ``cellname`` in ``gdim`` dimensions."""
    if LEGACY:
        return ufl.VectorElement("Lagrange", cellname, 1, dim=gdim)
    return _bufl.element("Lagrange", cellname, 1, shape=(gdim,))


def space_kind(space) -> str:
    """What ``space`` is, as far as checkpoints need: "mixed" (of subspaces), "degree 0" (one value
    per cell), "continuous degree 1" (one per node), or "other"; blocked (vector) spaces are of the
    kind of their scalar element."""
    el = space.ufl_element()
    if LEGACY:
        if isinstance(el, ufl.MixedElement) and not isinstance(el, (ufl.VectorElement, ufl.TensorElement)):
            return "mixed"
        if isinstance(el, (ufl.VectorElement, ufl.TensorElement)):
            el = el.sub_elements()[0]
        family, degree = el.family(), el.degree()
        discontinuous = "Discontinuous" in family or family in ("DG", "DQ")
    else:
        if el.is_mixed:
            return "mixed"
        degree, discontinuous = el.embedded_superdegree, el.discontinuous
    if degree == 0:
        return "degree 0"
    return "continuous degree 1" if degree == 1 and not discontinuous else "other"


# -- dofmaps ----------------------------------------------------------------------------------------
def cell_dofs(space) -> np.ndarray:
    """(local cells, dofs per cell) block indices of ``space``'s dofmap, owned cells first."""
    dm = space.dofmap
    if LEGACY:
        return dm.list.array.reshape(-1, dm.dof_layout.num_dofs)
    return dm.list


def geometry_dofs(mesh) -> np.ndarray:
    """(local cells, nodes per cell) indices into ``mesh.geometry.x``, owned cells first."""
    dm = mesh.geometry.dofmap
    if LEGACY:
        return dm.array.reshape(len(dm.offsets) - 1, -1)
    return dm


def locate_cell_dofs(space, cells) -> np.ndarray:
    """The dofs of ``space`` (block indices) on the local ``cells``."""
    tdim = space.mesh.topology.dim
    space.mesh.topology.create_connectivity(tdim, tdim)
    return fem.locate_dofs_topological(space, tdim, np.asarray(cells, dtype=np.int32))


def entity_nodes(mesh, dim: int, entities) -> np.ndarray:
    """(entities, nodes) geometry-node indices of the local ``entities`` of dimension ``dim``."""
    from dolfinx.cpp.mesh import entities_to_geometry
    cpp = mesh._mesh if LEGACY else mesh._cpp_object
    return entities_to_geometry(cpp, dim, np.asarray(entities, dtype=np.int32), False)


def bc_dofs(bc) -> np.ndarray:
    """The local dofs (unrolled, owned and ghost) of the space a Dirichlet condition ``bc`` was made on (its
    parent space's for a condition on a subspace) that it holds."""
    cpp = bc if hasattr(bc, "dof_indices") else bc._cpp_object
    return np.asarray(cpp.dof_indices()[0])


# -- vectors and assembly -----------------------------------------------------------------------------
def petsc_vec(function):
    """The PETSc Vec that shares ``function``'s values (owned and ghost)."""
    return function.vector if LEGACY else function.x.petsc_vec


def scatter_reverse_add(function) -> None:
    """Add the ghost entries of ``function``'s array to their owners (collective)."""
    function.x.scatter_reverse(_ADD)


def apply_lifting(b, forms, bcs, x0=None, alpha: float = 1.0) -> None:
    """``b -= alpha A (g - x0)`` for the Dirichlet values g of ``bcs`` (dolfinx's apply_lifting)."""
    if LEGACY:
        fem_petsc.apply_lifting(b, forms, bcs=bcs, x0=x0 or [], scale=alpha)
    else:
        fem_petsc.apply_lifting(b, forms, bcs=bcs, x0=x0 or [], alpha=alpha)


# -- expressions and quadrature ---------------------------------------------------------------------
def eval_expression(expression, mesh, cells, out: np.ndarray | None = None) -> np.ndarray:
    """``expression`` (a compiled ``fem.Expression``) at its points on the local ``cells``:
    (cells, points * value size), into ``out`` when given."""
    cells = np.asarray(cells, dtype=np.int32)
    if LEGACY:
        return expression.eval(cells) if out is None else expression.eval(cells, out)
    return expression.eval(mesh, cells) if out is None else expression.eval(mesh, cells, out)


def quadrature_rule(cellname: str, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """basix's default rule of ``degree`` on the reference ``cellname``: points (n, tdim), weights (n,)."""
    cell = _BASIX_CELL[cellname]
    if LEGACY:
        return basix.make_quadrature(basix.QuadratureType.Default, cell, degree)
    return basix.make_quadrature(cell, degree)
