r"""Penalty contact of the body's nodes against rigid tools in the static solver, compiled, node by node.

The fast route of :class:`fenics_plast.contact.PenaltyContact` (its default): the pair's law and numbers are
those of :class:`fenics_plast.contact.ContactPair`, the UFL forms that stay the **definition** (seed eqs.
16-25 in its docstring), and ``tests/test_static_tool_contact.py`` holds this route's residual and
Jacobian to the forms' (2-D, axisymmetric, 3-D; both friction laws, stick and slip; analytic and meshed
tools) and its Newton iterations and answers to theirs.

Why a second route: the forms integrate over every facet of the contact groups at every residual and
Jacobian, building whole facet matrices for nodes that are mostly apart (3-D quarter punch: 30 ms of a
Newton iteration's 96 ms of assembly). The nodal rule makes contact a property of each node, so here each
owned node of the pair's facets is one compiled evaluation of the law both solvers share
(:func:`~fenics_plast.solvers.contact_law.node_law`, its equations and tangent there):

    x = X + u,  (g, N, dN/dx) of the tool at x (the shape's own compiled formula,
                :mod:`~fenics_plast.solvers.tool_gaps`, dN/dx by central differences of N; a meshed tool's
                ``nodal_gap``),
    f = A (p N + t) on the body [N] and df/dx,

with A the node's tributary area int N_i w dA0 [mm^2], s = u - u_c - (d(lam) - d(lam_c)) the slip since the
last commit relative to the tool and (t_n, N_n, p_n) the committed traction, normal and pressure. Its
residual entries are -f, its Jacobian block -df/dx (dim x dim, the node's own dofs: inside the
finite-element pattern). Apart the friction term is zero and has no tangent in both laws (the forms'
coulomb tangent of a node apart whose trial traction is exactly zero, -eps_T P, is not copied). Units mm,
N, MPa.
"""
from __future__ import annotations

import numba
import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from fenics_plast.solvers.contact_kernels import GENERIC
from fenics_plast.solvers.contact_law import COULOMB, QUASI_COULOMB, ContactNodes, NodeHistory, node_law
from fenics_plast.solvers.tool_gaps import FLAGS, gap_2d, gap_3d
from fenics_plast.tools import compiled_shape

_njit = numba.njit(cache=True, **FLAGS)

#: central-difference step of a tool normal's derivative dN/dx, relative to 1 + |x| [mm]
NORMAL_FD_STEP = 1e-6


@_njit
def _gap(kind, prm, x, d):
    """(g, N (dim,)) of the tool shape ``kind`` at x (dim,) translated by d (dim,)."""
    if x.shape[0] == 2:
        g, n = gap_2d(kind, prm, (x[0], x[1]), (d[0], d[1]))
        return g, np.array([n[0], n[1]])
    g, n = gap_3d(kind, prm, (x[0], x[1], x[2]), (d[0], d[1], d[2]))
    return g, np.array([n[0], n[1], n[2]])


@_njit
def analytic_geometry(kind, prm, x, d, g, N, dN):
    """Gap g (n,) [mm], normal N (n, dim) and its derivative dN (n, dim, dim) [1/mm] (dN[k, i, j] = dN_i/dx_j,
    central differences; zeros where g >= 0, where it is not used) of the tool shape ``kind`` (parameters
    prm) translated by d (dim,) [mm], at the positions x (n, dim) [mm]."""
    n, dim = x.shape
    xp = np.empty(dim)
    for k in range(n):
        gk, Nk = _gap(kind, prm, x[k], d)
        g[k] = gk
        N[k, :] = Nk
        dN[k, :, :] = 0.0
        if gk >= 0.0:
            continue
        for j in range(dim):
            xp[:] = x[k]
            h = NORMAL_FD_STEP * (1.0 + abs(x[k, j]))
            xp[j] = x[k, j] + h
            _, Np = _gap(kind, prm, xp, d)
            xp[j] = x[k, j] - h
            _, Nm = _gap(kind, prm, xp, d)
            for i in range(dim):
                dN[k, i, j] = (Np[i] - Nm[i]) / (2.0 * h)


@_njit
def node_forces(g, N, dN, s, t_n, N_n, p_n, area, eps, eps_t, mu, law, f, K, t, p, slip):
    """The law (:func:`~fenics_plast.solvers.contact_law.node_law`) at every node k of a pair, with its tangent:

    g (n,) [mm], N (n, dim), dN (n, dim, dim) [1/mm]: the tool's gap, normal and dN_i/dx_j at the node;
    s (n, dim) [mm] the slip since the last commit; t_n (n, dim) [MPa], N_n (n, dim), p_n (n,) [MPa] the
    committed traction, normal and pressure; area (n,) [mm^2]; eps, eps_t [N/mm^3], mu, law the pair's.

    Writes f (n, dim) [N] the force on the body, K (n, dim, dim) [N/mm] = df/dx, t (n, dim) [MPa] the
    tangential traction, p (n,) [MPa] the pressure and slip (n,) (1: in contact and slipping; frictionless:
    in contact)."""
    for k in range(N.shape[0]):
        p[k], slip[k] = node_law(g[k], N[k], dN[k], s[k], t_n[k], N_n[k], p_n[k], area[k], eps, eps_t, mu, law,
                                 f[k], t[k], K[k])


def pair_nodes(solver, facet_tags, tag, gdim):
    """(reference positions X (n, gdim) [mm], their displacement entries in the solver's w (n, gdim), their
    blocks (n,) in the solver's displacement space) of the owned nodes of the facets tagged ``tag``."""
    from dolfinx import fem
    Vc, vmap = solver.displacement_space()
    blocks = fem.locate_dofs_topological(Vc, solver.mesh.topology.dim - 1, facet_tags.find(tag))
    blocks = np.asarray(blocks[blocks < Vc.dofmap.index_map.size_local], dtype=np.int64)
    X = np.ascontiguousarray(Vc.tabulate_dof_coordinates()[blocks, :gdim])
    idx = np.ascontiguousarray(np.asarray(vmap).reshape(-1, gdim)[blocks])
    return X, idx, blocks


def keep_committed_gaps(tool, contact, X, idx, lam) -> None:
    """Predictor of an increment to load factor ``lam``: move each node (reference positions X (n, dim) [mm],
    entries idx (n, dim) of the solver's ``w``, owned) that was in contact with ``tool`` at the last commit
    of ``contact`` (gap g_n < 0) along the tool's normal N at the predicted position, by g_n - g [mm], so that
    its predicted gap g is its committed gap again (the caller updates the ghosts).

    Why: the extrapolated predictor moves the contact nodes along a chord of their path over the
    tool; on a curved tool (the punch) the chord's error (up to 0.05 mm per increment on the 3-D
    punch) exceeds the penalty penetration (~1 um), so most contact nodes start the increment just
    outside the tool. There they have no contact stiffness, Newton's first step pushes them
    millimetres into the tool, and the line search crawls in tiny steps until they are in contact
    again (measured: the 3-D quarter punch's late increments took 9 to 15 iterations, 5 to 7 with
    this predictor)."""
    if not len(X):
        return
    w = contact.solver.w.x.array
    g_n, _ = tool.gap_np(X + contact.w_c.x.array[idx], float(contact.lam_c.value))
    on = g_n < 0.0
    if on.any():
        g, N = tool.gap_np(X[on] + w[idx[on]], lam)
        w[idx[on]] += (g_n[on] - g)[:, None] * N


class ToolContactTerm:
    """One rigid tool against the owned nodes of the body facets tagged ``tag``, compiled (module docstring):
    a term of :class:`~fenics_plast.solvers.static.StaticSolver` (``solver.terms``: :meth:`residual`,
    :meth:`jacobian`) with the reports and history of :class:`fenics_plast.contact.ContactPair`. Made by
    :meth:`fenics_plast.contact.PenaltyContact.add_pair` (which holds the defaults and validates the
    arguments); ``contact`` is that set (its committed state ``w_c``, ``lam_c``). Collective construction."""

    def __init__(self, contact, tool, facet_tags, tag, *, penalty, friction, law, tangential_penalty=None):
        from fenics_plast.checkpoint import dof_keys
        from fenics_plast.solvers.body_surface import tributary_areas
        self.contact, self.tool, self.facet_tags, self.tag = contact, tool, facet_tags, tag
        s = self.solver = contact.solver
        self.penalty = float(penalty)
        self.tangential_penalty = float(tangential_penalty if tangential_penalty else penalty)
        self.friction, self.law = float(friction), law
        self._law = COULOMB if law == "coulomb" else QUASI_COULOMB
        d = self.gdim = s.kin.gdim
        shape = compiled_shape(tool)
        self.kind, self.params = shape if shape is not None else (GENERIC, np.zeros(0))
        Vc, _ = s.displacement_space()
        self.X, self.idx, blocks = pair_nodes(s, facet_tags, tag, d)       # (n, dim) [mm], (n, dim) w entries
        self.blocks = blocks
        self.area = tributary_areas(Vc, s.kin.weight, facet_tags, tag)[blocks * Vc.dofmap.index_map_bs]
        n = len(self.X)
        self.hist = NodeHistory(n, d, dof_keys(Vc)[blocks * Vc.dofmap.index_map_bs])
        self.u_c = contact.w_c.x.array[self.idx].copy()     # the nodes' displacement at the last commit [mm]
        self.g, self.N, self.dN = np.zeros(n), np.zeros((n, d)), np.zeros((n, d, d))
        self.f, self.K, self.t = np.zeros((n, d)), np.zeros((n, d, d)), np.zeros((n, d))
        self.p, self.slip = np.zeros(n), np.zeros(n)
        self.s = np.zeros((n, d))               # the slip since the last commit [mm]
        self._rows = None                       # the nodes' global equations, built at the first residual

    # -- the state ------------------------------------------------------------------------------
    def _translation(self, lam):
        return np.asarray(self.tool.translation(float(lam), use_ufl=False), dtype=float).reshape(self.gdim)

    def evaluate(self):
        """Gaps, normals, forces and tangents of the pair's nodes at the solver's current state (w, lam)."""
        s = self.solver
        u = s.w.x.array[self.idx]
        x = self.X + u
        d = self._translation(s.lam)
        if self.kind == GENERIC:                # a meshed tool: its own search
            self.g[:], self.N[:], self.dN[:] = self.tool.nodal_gap(x, s.lam)
        else:
            analytic_geometry(self.kind, self.params, x, d, self.g, self.N, self.dN)
        self.s[:] = u - self.u_c - (d - self._translation(self.contact.lam_c.value))
        h = self.hist
        node_forces(self.g, self.N, self.dN, self.s, h.t_n, h.N_n, h.p_n, self.area, self.penalty,
                    self.tangential_penalty, self.friction, self._law, self.f, self.K, self.t, self.p, self.slip)

    def commit(self):
        """Store the history (t_n, N_n, p_n, u_c) at the current (converged) state."""
        self.evaluate()
        self.hist.store(self.t, self.N, self.p)
        self.u_c[:] = self.solver.w.x.array[self.idx]

    # -- the solver's calls ---------------------------------------------------------------------
    def residual(self, b):
        """b -= the nodal forces at the solver's current state (owned entries)."""
        self.evaluate()
        with b.localForm() as bl:
            bl.array[self.idx.ravel()] -= self.f.ravel()

    def jacobian(self, A):
        """A += -df/dx of the last :meth:`residual` (the nodes in contact; constrained dofs skipped)."""
        if self._rows is None:
            self._rows = self.solver.equation_numbers(self.idx)     # (n, dim), -1: a Dirichlet dof
        on = np.flatnonzero(self.g < 0.0)
        if len(on):
            rows = np.ascontiguousarray(self._rows[on])
            A.setValuesRCV(rows, rows, np.ascontiguousarray(-self.K[on]), addv=PETSc.InsertMode.ADD)

    # -- checkpoints ----------------------------------------------------------------------------
    def history(self):
        """(values, keys) of the committed history (t_n, N_n, p_n) of the owned nodes (:class:`NodeHistory`)."""
        return self.hist.keyed()

    def load_history(self, values):
        """Restore :meth:`history`'s values (the caller has restored the set's ``w_c``)."""
        self.hist.load(values)
        self.u_c[:] = self.contact.w_c.x.array[self.idx]

    # -- reports (collective, at the current state) ---------------------------------------------
    def _sum(self, x):
        return self.contact.comm.allreduce(x, op=MPI.SUM)

    def force(self):
        """Total contact force (Fr, Fz) BY the tool ON the body [N] (2 pi r included); (x, y, z) in 3-D."""
        self.evaluate()
        return self._sum(self.f.sum(axis=0))

    def normal_force(self):
        """sum A p [N]."""
        self.evaluate()
        return self._sum(float(np.dot(self.area, self.p)))

    def tangential_force(self):
        """sum A t [N] along T = (N_f,z, -N_f,r) (signed; 0 without friction); 3-D: the vector (3,)."""
        self.evaluate()
        if self.gdim == 3:
            return self._sum((self.area[:, None] * self.t).sum(axis=0))
        if self.friction <= 0.0:
            return 0.0
        Nf = self.N if self._law == COULOMB else self.hist.N_n
        return self._sum(float(np.dot(self.area, self.t[:, 0] * Nf[:, 1] - self.t[:, 1] * Nf[:, 0])))

    def status(self):
        """(nodes in contact, nodes slipping) at the current state, all ranks (frictionless: all slip)."""
        self.evaluate()
        tot = self._sum(np.array([np.count_nonzero(self.g < 0.0), np.count_nonzero(self.slip)], dtype=np.int64))
        return int(tot[0]), int(tot[1])

    def contact_nodes(self):
        """The pair's owned group nodes now, a :class:`~fenics_plast.solvers.contact_law.ContactNodes`."""
        self.evaluate()
        return ContactNodes(self.X + self.solver.w.x.array[self.idx], self.g.copy(), self.p.copy(), self.area,
                            self.blocks, (self.g < 0.0) & (self.slip > 0.0))

    def friction_dissipation(self):
        """The friction's dissipation at each owned node (in :meth:`contact_nodes`' order) since the last commit
        [N mm] (n,), >= 0: the work of the tangential traction t against the irreversible part of the slip s,
        -A t . (s + (t - t_n) / eps_T) (t is in the tangent plane, so the projections drop out): the elastic
        part of the slip, -(t - t_n) / eps_T, stores and gives back; a stuck node dissipates nothing, a
        slipping one (b |q| - b^2) / eps_T per area (module contact_law's notation). Call it before the commit.
        Zero without friction."""
        self.evaluate()
        if self.friction <= 0.0:
            return np.zeros(len(self.X))
        t = self.t
        return -self.area * ((t * self.s).sum(axis=1) + ((t * t).sum(axis=1) - (t * self.hist.t_n).sum(axis=1))
                             / self.tangential_penalty)

    def nodal_gaps(self):
        """Gaps [mm] at the owned nodes of the pair's facets (current state), numpy (n,)."""
        self.evaluate()
        return self.g.copy()

    def max_penetration(self):
        """Largest -g over the pair's owned nodes, all ranks [mm] (0 if none penetrates)."""
        g = self.nodal_gaps()
        return self.contact.comm.allreduce(max(0.0, float(-g.min())) if g.size else 0.0, op=MPI.MAX)

    def keep_gaps(self, lam) -> None:
        """The contact predictor (:func:`keep_committed_gaps`)."""
        keep_committed_gaps(self.tool, self.contact, self.X, self.idx, lam)
