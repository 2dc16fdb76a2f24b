"""Iterative linear solves for the static Newton iterations: GMRES + PETSc GAMG with rigid-body modes.

``linear_solver="gamg"`` (:class:`fenics_plast.solvers.static.StaticSolver`) replaces MUMPS LU for
meshes whose factorisation costs too much memory or time (3-D hexahedral meshes of 1e5 dofs and more).

* Plain Q1 (``element="q1"``): the Jacobian is the displacement block itself; GMRES is
  preconditioned by GAMG with the rigid-body modes of the mesh (3-D: 3 translations + 3 rotations;
  plane strain: 2 + 1; axisymmetric: the 2 translations) as its near-nullspace.
* Q1/P0 (``element="q1p0"``): the unknowns are (u, theta) with theta the DG0 dilatation. Its block
  A_tt = int dtheta q w dV is the DG0 mass matrix, which is *diagonal* (one dof per cell), so theta
  is condensed out exactly per Newton iteration (:class:`CondensedDilatation`, a PETSc python PC of a
  ``preonly`` KSP): S = A_uu - A_ut D^-1 A_tu (S has the sparsity of A_uu: theta couples the nodes
  of one cell), S du = r_u - A_ut D^-1 r_t is solved by GMRES + GAMG on S, and
  dtheta = D^-1 (r_t - A_tu du). Why condense rather than precondition the mixed matrix: the
  elimination is exact and cheap (a diagonal D), GAMG then sees a plain displacement operator
  whose near-nullspace is the rigid-body modes (rows of S grouped node by node, block size gdim),
  and there is no Schur-complement approximation to tune (a fieldsplit Schur ``selfp`` would form
  the same S, with the near-nullspace harder to attach to PETSc's internal matrix).
* GMRES, not CG: the consistent tangent of finite-strain F-bar plasticity is not symmetric (the
  geometric term tau : (gv l), the F-bar projection). Measured on the clamped quarter bar of
  benchmarks/bench_static_3d.py (972 hexahedra, 2 plastic increments, linear rtol 1e-8): q1p0,
  GMRES 30-61 iterations (mean 50) per Newton step, CG 31-64 (mean 52), same 18 Newton
  iterations; q1, GMRES 20 Newton iterations (38-51 linear), CG 25 (29-47 linear: its steps
  are poorer). GAMG's solution equals MUMPS's to 4e-14 of the largest displacement there.

The linear tolerance ``rtol`` (the solver's ``linear_rtol``) is relative to the Newton residual; with
1e-8 Newton keeps its quadratic convergence to the usual tolerances. A linear solve that does not
converge makes the Newton iteration fail (cut-back), like a failed factorisation.
"""
from __future__ import annotations

import numpy as np
from petsc4py import PETSc


def rigid_body_modes(V, W_vector, geometry: str):
    """Near-nullspace vectors (PETSc Vecs like ``W_vector``, orthonormalised) of the displacement
    sub-space ``V`` of W: translations and, in 3-D and plane strain, rotations about the axes.
    ``V``: W.sub(0) (mixed) or W itself (a vector P1 space); coordinates in mm."""
    gdim = 3 if geometry == "3d" else 2
    comps = []
    for c in range(gdim):
        Vc, dofs = V.sub(c).collapse()
        X = Vc.tabulate_dof_coordinates()
        n_own = W_vector.getLocalSize()
        dofs = np.asarray(dofs)
        own = dofs < n_own
        comps.append((dofs[own], X[own]))
    modes = []

    def mode(fill):
        v = W_vector.duplicate()
        v.set(0.0)
        a = v.getArray()
        for c, (dofs, X) in enumerate(comps):
            a[dofs] = fill(c, X)
        v.setArray(a)
        modes.append(v)
    for k in range(gdim):
        mode(lambda c, X, k=k: np.full(len(X), 1.0 if c == k else 0.0))
    if geometry == "3d":
        # rotations about z, x, y: (-y, x, 0), (0, -z, y), (z, 0, -x)
        rot = [{0: (-1, 1), 1: (1, 0)}, {1: (-1, 2), 2: (1, 1)}, {0: (1, 2), 2: (-1, 0)}]
        for r in rot:
            mode(lambda c, X, r=r: r[c][0] * X[:, r[c][1]] if c in r else np.zeros(len(X)))
    elif geometry == "plane_strain":
        mode(lambda c, X: -X[:, 1] if c == 0 else X[:, 0])
    return orthonormalise(modes)


def orthonormalise(vecs):
    """Modified Gram-Schmidt on PETSc Vecs (in place); returns them."""
    for i, v in enumerate(vecs):
        for u in vecs[:i]:
            v.axpy(-v.dot(u), u)
        v.normalize()
    return vecs


def gamg_options(prefix: str, rtol: float, max_it: int) -> dict:
    """PETSc options of a GMRES + GAMG solve under ``prefix``."""
    return {f"{prefix}ksp_type": "gmres", f"{prefix}ksp_gmres_restart": 100, f"{prefix}ksp_rtol": rtol,
            f"{prefix}ksp_atol": 0.0, f"{prefix}ksp_max_it": max_it, f"{prefix}pc_type": "gamg",
            f"{prefix}pc_gamg_type": "agg", f"{prefix}pc_gamg_agg_nsmooths": 1,
            f"{prefix}pc_gamg_threshold": 0.01, f"{prefix}mg_levels_ksp_type": "chebyshev",
            f"{prefix}mg_levels_pc_type": "jacobi", f"{prefix}mg_levels_ksp_max_it": 2,
            f"{prefix}ksp_error_if_not_converged": False}


class CondensedDilatation:
    """PETSc python PC: exact static condensation of the DG0 dilatation, then GMRES + GAMG on the
    condensed displacement matrix (see the module docstring).

    ``is_u``: owned W-dofs of u (global indices), node by node (x, y[, z] of one node together, so
    the condensed matrix has block size gdim); ``is_t``: owned W-dofs of theta; ``modes``: the
    rigid-body modes as W vectors; ``prefix``: PETSc options prefix of the inner KSP."""

    def __init__(self, comm, is_u, is_t, modes, prefix, bs):
        self.is_u, self.is_t, self.bs = is_u, is_t, bs
        self.ksp = PETSc.KSP().create(comm)
        self.ksp.setOptionsPrefix(prefix)
        self.ksp.setFromOptions()
        self.modes_u = []
        for m in modes:
            sub = m.getSubVector(is_u)
            self.modes_u.append(sub.copy())
            m.restoreSubVector(is_u, sub)
        orthonormalise(self.modes_u)
        self.nullspace = PETSc.NullSpace().create(vectors=self.modes_u, comm=comm)
        self.S = self.A_ut = self.A_tu = None
        self.failed_reason = 0       # the inner KSP's reason when it diverged (0: none)
        self.iterations = []         # inner iterations of every solve

    def setUp(self, pc):
        _, P = pc.getOperators()
        iu, it = self.is_u, self.is_t
        reuse = self.S is not None
        self.S = P.createSubMatrix(iu, iu, submat=self.S if reuse else None)
        self.A_ut = P.createSubMatrix(iu, it, submat=self.A_ut if reuse else None)
        self.A_tu = P.createSubMatrix(it, iu, submat=self.A_tu if reuse else None)
        d = P.getDiagonal()
        dt = d.getSubVector(it)
        self.dinv = dt.copy()
        d.restoreSubVector(it, dt)
        self.dinv.reciprocal()
        scaled = self.A_tu.copy()
        scaled.diagonalScale(L=self.dinv)
        coupling = self.A_ut.matMult(scaled)
        # S = A_uu - A_ut D^-1 A_tu: the product couples the nodes of one cell, a subset of A_uu's pattern
        self.S.axpy(-1.0, coupling, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        coupling.destroy()
        scaled.destroy()
        if self.S.getBlockSize() != self.bs:
            try:
                self.S.setBlockSize(self.bs)
            except PETSc.Error:
                pass
        self.S.setNearNullSpace(self.nullspace)
        self.ksp.setOperators(self.S)
        self.rhs_u, self.sol_u = self.S.createVecs()
        self.work_t = self.dinv.duplicate()

    def apply(self, pc, x, y):
        iu, it = self.is_u, self.is_t
        xu, xt = x.getSubVector(iu), x.getSubVector(it)
        # rhs_u = x_u - A_ut D^-1 x_t
        self.work_t.pointwiseMult(xt, self.dinv)
        self.A_ut.mult(self.work_t, self.rhs_u)
        self.rhs_u.aypx(-1.0, xu)
        self.sol_u.set(0.0)
        self.ksp.solve(self.rhs_u, self.sol_u)
        reason = self.ksp.getConvergedReason()
        self.iterations.append(self.ksp.getIterationNumber())
        # y_t = D^-1 (x_t - A_tu y_u)
        self.A_tu.mult(self.sol_u, self.work_t)
        self.work_t.aypx(-1.0, xt)
        self.work_t.pointwiseMult(self.work_t, self.dinv)
        x.restoreSubVector(iu, xu)
        x.restoreSubVector(it, xt)
        yu, yt = y.getSubVector(iu), y.getSubVector(it)
        self.sol_u.copy(yu)
        self.work_t.copy(yt)
        y.restoreSubVector(iu, yu)
        y.restoreSubVector(it, yt)
        if reason < 0:
            self.failed_reason = reason
            y.set(np.nan)          # fails the Newton iteration (SNES sees a non-finite step)

    def destroy(self, pc=None):
        for m in (self.S, self.A_ut, self.A_tu):
            if m is not None:
                m.destroy()
        self.S = self.A_ut = self.A_tu = None
        if self.ksp is not None:
            self.ksp.destroy()
            self.ksp = None


def displacement_index_sets(W, V, theta_dofs, gdim):
    """(is_u, is_t): owned W dofs of the displacement (node by node: the gdim components of a node
    together) and of the dilatation, as global indices. ``V``: W.sub(0); ``theta_dofs``: W-local
    dofs of theta (owned and ghost)."""
    comm = W.mesh.comm
    imap = W.dofmap.index_map
    n_own = imap.size_local * W.dofmap.index_map_bs
    start = imap.local_range[0] * W.dofmap.index_map_bs
    Vc, vmap = V.collapse()
    vmap = np.asarray(vmap)
    n_nodes = Vc.dofmap.index_map.size_local
    u_local = vmap[: n_nodes * gdim]
    if (u_local >= n_own).any():
        raise RuntimeError("displacement_index_sets: an owned node has a displacement dof owned elsewhere")
    # PETSc's parallel MatCreateSubMatrix needs sorted index sets (unsorted ones fail on 2 ranks with "Object is
    # in wrong state: subgarray[0] cannot < garray[0]"): the nodes in the order of their first dof, each node's
    # components together (consecutive in W's numbering)
    blocks = u_local.reshape(-1, gdim)
    u_local = blocks[np.argsort(blocks[:, 0], kind="stable")].reshape(-1)
    if (np.diff(u_local) <= 0).any():
        raise RuntimeError("displacement_index_sets: a node's displacement dofs are not consecutive in W")
    t_local = np.sort(theta_dofs[theta_dofs < n_own])
    is_u = PETSc.IS().createGeneral((u_local + start).astype(PETSc.IntType), comm=comm)
    is_t = PETSc.IS().createGeneral((t_local + start).astype(PETSc.IntType), comm=comm)
    return is_u, is_t
