"""Prescribed displacements of the static solver: Dirichlet conditions on components of the displacement
on facet sets, scaled by the load factor lam or given as functions of the reference position and lam.

:class:`DirichletConditions` is :class:`~fenics_plast.solvers.static.StaticSolver`'s ``dirichlet``: it holds
the dolfinx ``DirichletBC`` objects and the boundary-value functions g behind them, sets g at each load
factor (:meth:`~DirichletConditions.set_load`), finds the constrained dofs of a facet set (reactions) and
tells whether an iterate already holds the values (the residual's lifting is then zero). Units mm.
"""
from __future__ import annotations

import numpy as np
from dolfinx import fem
from dolfinx.fem import petsc as fpetsc
from petsc4py import PETSc


class DirichletConditions:
    """The Dirichlet conditions on the displacement space ``V`` (a subspace of the unknowns' space ``W``:
    with q1p0 the mixed space of displacement and dilatation, else V itself)."""

    def __init__(self, V, W):
        self.V, self.W = V, W
        self._scaled = []       # (DirichletBC, g Function, g0 array): g = lam * g0
        self._prescribed = []   # (DirichletBC, g Function, X (3, n), value(X, lam)): g = value(X, lam)
        self._gap = None        # work vector of values_reached

    @staticmethod
    def _facets(facet_tags, tag):
        """The facets tagged ``tag`` (a number), or ``tag`` itself (an array of facet indices)."""
        return facet_tags.find(tag) if np.isscalar(tag) else np.asarray(tag, dtype=np.int32)

    def _located(self, component, facet_tags, tag):
        """(the component's subspace, its collapsed space, the (W, collapsed) dof pair of the facets)."""
        fdim = self.V.mesh.topology.dim - 1
        Vsub = self.V.sub(component)
        Vc, _ = Vsub.collapse()
        return Vsub, Vc, fem.locate_dofs_topological((Vsub, Vc), fdim, self._facets(facet_tags, tag))

    def add(self, component, facet_tags, tag, value=0.0, where=None, lam=0.0):
        """u[component] = lam * value [mm] on the facets tagged ``tag`` (value: a number or a callable x (3, n) ->
        (n,)), set now at the load factor ``lam``. ``where(X) -> bool mask`` optionally keeps only the dofs at
        the coordinates X (n, 3): to avoid constraining a dof twice (a corner shared with a symmetry line).
        Returns the DirichletBC."""
        Vsub, Vc, dofs = self._located(component, facet_tags, tag)
        if where is not None:
            keep = np.asarray(where(Vc.tabulate_dof_coordinates()[dofs[1]]), dtype=bool)
            dofs = [dofs[0][keep], dofs[1][keep]]
        g = fem.Function(Vc)
        if callable(value):
            g.interpolate(lambda x: np.asarray(value(x), dtype=float) * np.ones(x.shape[1]))
        else:
            g.x.array[:] = float(value)
        g0 = g.x.array.copy()
        g.x.array[:] = lam * g0
        bc = fem.dirichletbc(g, dofs, Vsub)
        self._scaled.append((bc, g, g0))
        return bc

    def add_prescribed(self, component, facet_tags, tag, value, lam=0.0):
        """u[component] = value(X, lam) [mm] on the facets tagged ``tag``: ``value(X (3, n) reference
        coordinates, lam) -> (n,)`` is evaluated at every load factor (tables and expressions of x, y, z, t of a
        scene file), now at ``lam``. Returns the DirichletBC."""
        Vsub, Vc, dofs = self._located(component, facet_tags, tag)
        g = fem.Function(Vc)
        X = Vc.tabulate_dof_coordinates().T.copy()
        g.x.array[:] = np.asarray(value(X, lam), dtype=float) * np.ones(X.shape[1])
        bc = fem.dirichletbc(g, dofs, Vsub)
        self._prescribed.append((bc, g, X, value))
        return bc

    def dofs(self, component, facet_tags, tag, where=None):
        """Owned W-dof indices of u[component] on the facets tagged ``tag`` (for reactions); ``where(X) -> bool
        mask`` optionally filters by the dof coordinates X (n, 3)."""
        _, Vc, (dofs, cdofs) = self._located(component, facet_tags, tag)
        imap = self.W.dofmap.index_map
        keep = dofs < imap.size_local * self.W.dofmap.index_map_bs
        if where is not None:
            keep &= np.asarray(where(Vc.tabulate_dof_coordinates()[cdofs]), dtype=bool)
        return np.asarray(dofs[keep], dtype=np.int32)

    @property
    def bcs(self):
        """The DirichletBC objects, in the order they were added (scaled ones first)."""
        return [b[0] for b in self._scaled] + [b[0] for b in self._prescribed]

    def set_load(self, lam):
        """The boundary values at the load factor ``lam``."""
        for _, g, g0 in self._scaled:
            g.x.array[:] = lam * g0
        for _, g, X, value in self._prescribed:
            g.x.array[:] = np.asarray(value(X, lam), dtype=float) * np.ones(X.shape[1])

    def values_reached(self, x) -> bool:
        """Whether the PETSc vector ``x`` holds the boundary values g on every constrained dof (collective).
        Then the residual's lifting, -A (g - x) on the free rows, is zero, and assembling it (every boundary
        cell's tangent, every cell's coefficients packed) is skipped. It is not zero only at the first
        iteration after the tangent predictor, which leaves the constrained dofs at their converged values."""
        bcs = self.bcs
        if not bcs:
            return True
        if self._gap is None:
            self._gap = x.duplicate()
        with self._gap.localForm() as gl:
            gl.set(0.0)
        fpetsc.set_bc(self._gap, bcs, x, -1.0)      # x - g on the owned constrained dofs
        return self._gap.norm(PETSc.NormType.INFINITY) == 0.0
