"""Frictional penalty contact between two facet groups of the body in the static solver, node to surface.

The static counterpart of the explicit solver's master surfaces of the body
(:mod:`fenics_plast.solvers.body_surface`): each owned node s of the slave group finds the master facet
nearest to it at the current Newton state (the same search,
:func:`~fenics_plast.solvers.surface_gaps.nearest_points`), and that node-to-facet element contributes the
forces

    f_s = A_s (p N + t),  f_a = -w_a f_s  (a: the facet's vertices, w_a the nearest point's weights),
    p = eps <-g>,   g = (x_s - q) . n_f inside the facet (n_f its unit normal, out of the master body),
                    g = sign |x_s - q|, N = (x_s - q) / g at its edges and corners,

N = n_f inside a segment (2-D); on triangles (3-D) N is the surface's vertex normals (angle-weighted
pseudo-normals) interpolated at q with the weights w_a and normalised, continuous across facet edges: with
each facet's own normal a node pressed near the diagonal of a slightly warped quadrilateral (two triangles)
or an edge between two nearly coplanar facets saw the normal jump by the warp as it crossed, and Newton
stalled at that jump's force (about 1e-7 N; the frictionless 3-D block on a block stopped at 0.2 % of its
travel, tests/scenes/sliding_blocks_3d.toml). A node whose projection lies outside its facet by less than
:data:`ON_EDGE` of the facet's size counts as inside in 3-D (round-off on a shared edge otherwise tilts N by
the lateral offset over the gap). 2-D is as it was (segments' own normals, no tolerance).

t the tangential traction of the law both solvers share (:func:`~fenics_plast.solvers.contact_law.node_law`:
coulomb or quasi-coulomb, slip as a vector of the tangent plane) with the slip s = d_s - sum_a w_a d_a, the
displacement of the slave since the last commit relative to the master point's (d the nodes' displacements
since then), and A_s the slave node's tributary area int N_s w dA0 [mm^2] (w = 2 pi R in axisymmetry). They
enter the residual (R -= f) and their derivative the Jacobian (K = -df/dx, over the slave's and the facet's
vertices' positions). Without friction, inside a segment (2-D), K is the node-to-segment element's
consistent linearisation (Wriggers, Computational Contact Mechanics, 2006, sec. 9.1:
:func:`_segment_tangent`); otherwise (friction, a segment's end, triangles in 3-D) it is the central
difference of the element's closed-form force, the step 1e-7 of the facet's size and below a thousandth of
the gap (so that it does not cross g = 0; not below 1e-10 of the facet's size), the history and the
committed positions held.
``tests/test_static_body_contact.py`` holds the analytic tangent to central differences, measures Newton's
rates and checks friction between two bodies against friction on a rigid tool.

Self-contact (the master surface is the slave group itself): a node searches only the facets whose normals
face its own (:data:`~fenics_plast.solvers.surface_gaps.SELF_CONTACT_FACING`), never its own, as in the
explicit solver. History (per slave node, stored by :meth:`SurfaceContactTerm.commit` at each converged
increment): the traction, normal and pressure, and the displacement of every node. Rows and columns of constrained dofs
(Dirichlet conditions) take no entries; the entries couple nodes of the two groups that the forms' sparsity
does not hold, so the solver's matrix accepts new nonzeros (MUMPS analyses the pattern again when it grows).
Units mm, N, MPa.
"""
from __future__ import annotations

import math

import numba
import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from fenics_plast.solvers.body_surface import BodySurface, TwoPassPair, tributary_areas
from fenics_plast.solvers.contact_law import COULOMB, QUASI_COULOMB, ContactNodes, NodeHistory, node_law
from fenics_plast.solvers.surface_gaps import nearest_points, segment_nearest, triangle_nearest
from fenics_plast.solvers.tool_gaps import FLAGS

_njit = numba.njit(cache=True, **FLAGS)

#: central-difference step of the element tangent, relative to the facet's longest edge
FD_STEP = 1e-7
#: a node within this gap of its facet, relative to the facet's longest edge, is touching: pressed, for the
#: tangent (round-off puts a node that touches on either side of g = 0: 2.2e-16 mm on one machine, 0 on
#: another, and a touching node without the pressed side's stiffness stalled Newton on the sliding blocks)
TOUCHING = 1e-12
#: a node whose projection onto its facet's plane lies outside the facet by less than this times the facet's
#: longest edge is taken as inside it (the facet's normal, not the direction from the nearest edge point)
ON_EDGE = 1e-6


class SurfaceContactTerm:
    """The nodes of the facets tagged ``tag`` pressed against ``surface`` (a
    :class:`~fenics_plast.solvers.body_surface.BodySurface` of the same body, on the solver's displacement
    space) with the normal penalty ``penalty`` [N/mm^3], friction coefficient ``friction``, law and tangential
    penalty [N/mm^3] (None: the normal one): a term of :class:`~fenics_plast.solvers.static.StaticSolver`
    (``solver.terms``: :meth:`residual` and :meth:`jacobian`) with the history and reports of the contact set
    ``contact`` (:class:`fenics_plast.contact.PenaltyContact`: its committed state ``w_c``). Collective
    construction and calls."""

    def __init__(self, contact, facet_tags, tag, surface, *, penalty, friction, law, tangential_penalty=None,
                 name=None):
        if not penalty > 0:
            raise ValueError(f"contact penalty must be > 0, got {penalty!r}")
        from dolfinx import fem

        from fenics_plast.checkpoint import dof_keys
        self.contact = contact
        s = self.solver = contact.solver
        self.surface, self.penalty, self.name, self.tag = surface, float(penalty), name or "contact", tag
        self.tangential_penalty = float(tangential_penalty if tangential_penalty else penalty)
        self.friction, self.law = float(friction), law
        code = COULOMB if law == "coulomb" else QUASI_COULOMB
        self._law = (self.penalty, self.tangential_penalty, self.friction, code)
        self.comm = s.comm
        Vc, vmap = s.displacement_space()
        d = self.dim = Vc.dofmap.index_map_bs
        self.vmap = vmap                                        # Vc unrolled dof -> w's local dof
        n_own = Vc.dofmap.index_map.size_local
        blocks = fem.locate_dofs_topological(Vc, s.mesh.topology.dim - 1, facet_tags.find(tag))
        blocks = np.asarray(blocks[blocks < n_own], dtype=np.int64)
        self.dofs = np.ascontiguousarray(blocks[:, None] * d + np.arange(d), dtype=np.int64)    # (n, dim) Vc
        self.X = np.ascontiguousarray(Vc.tabulate_dof_coordinates()[blocks, :d])               # (n, dim) [mm]
        self.area = tributary_areas(Vc, s.kin.weight, facet_tags, tag)[self.dofs[:, 0]]      # (n,) [mm^2]
        if self.comm.allreduce(float(self.area.sum()), op=MPI.SUM) <= 0.0:
            raise ValueError(f"contact pair {self.name!r}: facet group {tag} has no facets (zero area)")
        imap = Vc.dofmap.index_map
        self.skip = surface.skip_of(imap.local_to_global(blocks.astype(np.int32)))
        self.self_contact = surface.tag == tag          # the group against its own facets
        C = surface.to_facet_vertices                   # the slave's dofs, then C from the master nodes' (3-D)
        self._to_element = None
        if C is not None:
            self._to_element = np.zeros((d + C.shape[0], d + C.shape[1]))
            self._to_element[:d, :d], self._to_element[d:, d:] = np.eye(d), C
        self._equations_built = False                           # at the first residual (bcs complete)
        n = len(blocks)
        self.g, self.N = np.zeros(n), np.zeros((n, d))
        self.facet, self.weights = np.full(n, -1, np.int64), np.zeros((n, d))
        self.r = np.zeros((n, (1 + d) * d))
        self.K = np.zeros((n, (1 + d) * d, (1 + d) * d))
        self.t, self.p, self.slip = np.zeros((n, d)), np.zeros(n), np.zeros(n)
        self.pressed = np.zeros(n, dtype=np.bool_)     # pressed or touching: the node's tangent is added
        # history at the last commit: the slaves' traction, normal, pressure; the displacement (Vc numbering)
        self.hist = NodeHistory(n, d, dof_keys(Vc)[self.dofs[:, 0]])
        self.u_c = np.asarray(contact.w_c.x.array[vmap]).copy()

    # -- equation numbers ----------------------------------------------------------------------
    def _build_equations(self):
        """The global equations of the slave nodes' and the master surface's dofs (-1: a Dirichlet dof)."""
        s = self.solver
        self._slave_eq = s.equation_numbers(self.vmap[self.dofs])                     # (n, dim)
        surf = self.surface
        self._master_eq = surf.global_rows(s.equation_numbers(self.vmap[surf.dofs]))  # (nv, dim)

    # -- the solver's calls --------------------------------------------------------------------
    def evaluate(self):
        """The slave nodes' nearest facets, gaps, forces and element tangents at the solver's current state
        (collective: the surface moves)."""
        u = self.solver.w.x.array[self.vmap]            # displacement on the Vc numbering (ghosts current)
        du = u - self.u_c                               # since the last commit: the slip's measure
        self.surface.move(u, du)
        x = self.X + u[self.dofs]
        surf = self.surface.surface
        # self-contact: a node searches only the facets that face its own normal, never its own
        facing = surf.vertex_normals[self.skip] if self.self_contact else None
        nearest_points(surf, x, self.skip, self.g, self.N, self.facet, self.weights, facing=facing)
        h = self.hist
        _node_terms(x, du[self.dofs], self.area, self.facet, surf.vertices, self.surface.increment, surf.facets,
                    surf.vertex_normals, self._law, h.t_n, h.N_n, h.p_n, self.r, self.K, self.g, self.N, self.t,
                    self.p, self.slip, self.pressed)

    def residual(self, b):
        """b -= the contact forces at the solver's current state (global entries; off-process ones are
        stashed: the caller assembles b)."""
        if not self._equations_built:
            self._build_equations()
            self._equations_built = True
        self.evaluate()
        on = np.flatnonzero(self.pressed)        # pressed or touching: a tangent (a body held by contact alone)
        self._active = on
        if len(on):
            eq = self._equations_of(on)
            r = self.r[on]
            C = self.surface.to_facet_vertices
            if C is not None:               # the element's forces on the master nodes' dofs: C^T f
                r = np.concatenate([r[:, :self.dim], r[:, self.dim:] @ C], axis=1)
            eq, r = eq.ravel(), r.ravel()
            free = eq >= 0
            b.setValues(eq[free].astype(PETSc.IntType), r[free], addv=PETSc.InsertMode.ADD)

    def commit(self):
        """Store the history (the slaves' traction, normal, pressure; the displacement) at the current
        (converged) state; collective."""
        self.evaluate()
        self.hist.store(self.t, self.N, self.p)
        self.u_c[:] = self.solver.w.x.array[self.vmap]
        self._committed_points = (self.facet.copy(), self.weights.copy())

    def keep_gaps(self, lam) -> None:
        """The contact predictor's hook (collective): with friction, each slave node in contact at the last
        commit is moved with the master point it touched then (its predicted displacement = the committed one +
        the master point's predicted increment): Newton starts from every such node stuck where it was and
        finds which slip. With the extrapolation alone the nodes slid along with the body's spreading, all of
        them started slipping and Newton stalled: the 3-D sliding blocks stopped at the onset of sliding
        (t = 0.53); holding only the nodes that were stuck, and extrapolating those that slipped, stopped
        there as well (measured, tests/scenes/sliding_blocks_3d.toml). Frictionless: nothing (the master surface
        moves with the body)."""
        if self.friction <= 0.0 or not hasattr(self, "_committed_points"):
            return
        facet, weights = self._committed_points
        u = self.solver.w.x.array[self.vmap]
        self.surface.move(u, u - self.u_c)
        on = np.flatnonzero((self.hist.p_n > 0.0) & (facet >= 0))
        if len(on):
            dd = self.surface.increment_at(facet[on], weights[on])
            self.solver.w.x.array[self.vmap[self.dofs[on]]] = self.u_c[self.dofs[on]] + dd

    # -- checkpoints ----------------------------------------------------------------------------
    def history(self):
        """(values, keys) of the committed history (t_n, N_n, p_n) of the owned slave nodes
        (:class:`~fenics_plast.solvers.contact_law.NodeHistory`)."""
        return self.hist.keyed()

    def load_history(self, values):
        """Restore :meth:`history`'s values (the caller has restored the set's ``w_c``)."""
        self.hist.load(values)
        self.u_c[:] = self.contact.w_c.x.array[self.vmap]

    def _equations_of(self, rows):
        """The global equations (m, dim (1 + k)) of the slave nodes ``rows`` and of the k master nodes their
        facets act on (:meth:`~fenics_plast.solvers.body_surface.BodySurface.element_nodes`)."""
        nodes = self.surface.element_nodes(self.facet[rows])
        return np.concatenate([self._slave_eq[rows], self._master_eq[nodes].reshape(len(rows), -1)], axis=1)

    def jacobian(self, A):
        """A += the contact tangent at the state of the last :meth:`residual` (SNES evaluates the residual,
        then the Jacobian, at the same iterate)."""
        on = self._active
        if not len(on):
            return
        K = self.K[on]
        if self._to_element is not None:    # the element's tangent on the master nodes' dofs: Ce^T K Ce
            K = self._to_element.T @ K @ self._to_element
        eq = np.ascontiguousarray(self._equations_of(on), dtype=PETSc.IntType)
        A.setValuesRCV(eq, eq, np.ascontiguousarray(K), addv=PETSc.InsertMode.ADD)    # one block a node

    # -- reports (collective) --------------------------------------------------------------------
    def contact_nodes(self):
        """The pair's owned group nodes now, a :class:`~fenics_plast.solvers.contact_law.ContactNodes`."""
        self.evaluate()
        return ContactNodes(self.X + self.solver.w.x.array[self.vmap[self.dofs]], self.g.copy(), self.p.copy(),
                            self.area, self.dofs[:, 0] // self.dim, (self.g < 0.0) & (self.slip > 0.0))

    def conduction_links(self):
        """Where the pair's owned slave nodes touch the master surface now, for a heat conductance between the
        two bodies (collective: :meth:`evaluate`): (slave blocks (m,) of the displacement's CG1 space, their
        tributary areas (m,) [mm^2], the master nodes (m, k) as rows of the surface's vertex list
        (:meth:`~fenics_plast.solvers.body_surface.BodySurface.element_nodes`), their weights (m, k) in the
        master point: the facet's, 3-D the centre's quarter to each corner of its quadrilateral), m the nodes
        in contact (g < 0)."""
        self.evaluate()
        on = np.flatnonzero(self.g < 0.0)
        w = self.weights[on]
        if self.surface.to_facet_vertices is not None:          # 3-D: two corners, then the centre's four
            w = np.concatenate([w[:, :2], np.repeat(0.25 * w[:, 2:3], 4, axis=1)], axis=1)
        return self.dofs[on, 0] // self.dim, self.area[on], self.surface.element_nodes(self.facet[on]), w

    def pressures(self):
        """(positions (n, dim) [mm], p (n,) [MPa]) of this rank's slave nodes at the last residual."""
        u = self.solver.w.x.array[self.vmap]
        return self.X + u[self.dofs], self.p.copy()

    def force(self):
        """Total contact force on the slave nodes [N] (dim,) at the last residual (2 pi r included in
        axisymmetry)."""
        return self.comm.allreduce(-self.r[:, :self.dim].sum(axis=0), op=MPI.SUM)

    def normal_force(self):
        """sum A p over the slave nodes [N] at the last residual."""
        return self.comm.allreduce(float(np.dot(self.area, self.p)), op=MPI.SUM)

    def tangential_force(self):
        """sum A t [N] at the last residual: 2-D signed along T = (N_f,y, -N_f,x) (0 without friction), 3-D
        the vector (3,)."""
        if self.dim == 3:
            return self.comm.allreduce((self.area[:, None] * self.t).sum(axis=0), op=MPI.SUM)
        Nf = self.N if self._law[3] == COULOMB else self.hist.N_n
        return self.comm.allreduce(float(np.dot(self.area, self.t[:, 0] * Nf[:, 1] - self.t[:, 1] * Nf[:, 0])),
                                   op=MPI.SUM)

    def status(self):
        """(slave nodes in contact, slipping) at the last residual, all ranks (frictionless: all slip)."""
        on = self.g < 0.0
        tot = self.comm.allreduce(np.array([np.count_nonzero(on), np.count_nonzero(on & (self.slip > 0))]),
                                  op=MPI.SUM)
        return int(tot[0]), int(tot[1])

    def max_penetration(self):
        """Largest -g over the slave nodes at the last residual [mm] (0 if none penetrates)."""
        local = float(max(0.0, -self.g.min())) if self.g.size else 0.0
        return self.comm.allreduce(local, op=MPI.MAX)


def surface_terms(contact, facet_tags, tag, master_tag, *, penalty, friction, law, tangential_penalty=None,
                  two_pass=True, mirror_tags=(), name=None):
    """The terms of the pair of the nodes tagged ``tag`` against the body's facets tagged ``master_tag`` (and,
    with ``two_pass``, back; the surfaces continue across the facets tagged ``mirror_tags``, see
    :class:`~fenics_plast.solvers.body_surface.BodySurface`), for the static contact set ``contact``
    (:meth:`fenics_plast.contact.PenaltyContact.add_surface_pair`): (the terms, the pair that reports:
    the :class:`SurfaceContactTerm` or a :class:`~fenics_plast.solvers.body_surface.TwoPassPair`). Collective."""
    solver = contact.solver
    Vc, _ = solver.displacement_space()
    X = Vc.tabulate_dof_coordinates()[:, :Vc.dofmap.index_map_bs]
    surfaces = {t: BodySurface(Vc, X, facet_tags, t, mirror_tags=mirror_tags)
                for t in ({master_tag, tag} if two_pass else {master_tag})}
    law_args = dict(penalty=penalty, friction=friction, law=law, tangential_penalty=tangential_penalty, name=name)
    forward = SurfaceContactTerm(contact, facet_tags, tag, surfaces[master_tag], **law_args)
    if not two_pass:
        return [forward], forward
    backward = SurfaceContactTerm(contact, facet_tags, master_tag, surfaces[tag], **law_args)
    return [forward, backward], TwoPassPair(forward, backward)


# ----------------------------------------------------------------------------------------------
# compiled: one node-to-facet element's force and its central-difference tangent


@_njit
def _element_force(P, D, nfv, area, n_f, NV, size, law, t_n, N_n, p_n, f, t):
    """f (1 + nfv, dim) = the forces [N] on the slave (row 0, position P[0]) and on the facet's vertices
    (P[1:]) of the element of slave area ``area`` [mm^2] and facet normal n_f (its own, from the vertices'
    order; only its side is used at edges and corners; inside a triangle N is the vertex normals NV (nfv, 3)
    interpolated, NV (0, dim) in 2-D: n_f; ``size`` [mm] the facet's longest edge, for :data:`ON_EDGE`), by
    :func:`~fenics_plast.solvers.contact_law.node_law`
    (law = (eps, eps_t, mu, law code); t_n (dim,), N_n (dim,), p_n: the slave's history) with the slip
    s = D[0] - sum_a w_a D[1 + a] (D (1 + nfv, dim) the nodes' displacements since the history's state
    [mm], w the nearest point's weights); t (dim,) gets the slave's tangential traction [MPa]. Returns
    (g [mm], N, p [MPa], slip)."""
    dim = P.shape[1]
    V = P[1:]
    if dim == 2:
        d2, q0, q1, feature, xi = segment_nearest(P[0], V, 0, 1)
        q2 = 0.0
        w = (1.0 - xi, xi, 0.0)
    else:
        d2, q0, q1, q2, feature, v, ww = triangle_nearest(P[0], V, 0, 1, 2)
        w = (1.0 - v - ww, v, ww)
    r0, r1 = P[0, 0] - q0, P[0, 1] - q1
    r2 = P[0, 2] - q2 if dim == 3 else 0.0
    along = r0 * n_f[0] + r1 * n_f[1] + (r2 * n_f[2] if dim == 3 else 0.0)
    dist = math.sqrt(d2)
    N = np.empty(dim)
    if feature == 0 or dist <= 1e-14 or (dim == 3 and d2 - along * along <= (ON_EDGE * size) ** 2):
        g = along
        for j in range(dim):
            N[j] = n_f[j]
        if NV.shape[0] == nfv:          # 3-D: the vertex normals interpolated, continuous across facets
            size_n = 0.0
            for j in range(dim):
                N[j] = w[0] * NV[0, j] + w[1] * NV[1, j] + w[2] * NV[2, j]
                size_n += N[j] * N[j]
            for j in range(dim):
                N[j] /= math.sqrt(size_n)
    else:
        sign = 1.0 if along >= 0.0 else -1.0
        g = sign * dist
        N[0], N[1] = sign * r0 / dist, sign * r1 / dist
        if dim == 3:
            N[2] = sign * r2 / dist
    s = np.empty(dim)
    for j in range(dim):
        s[j] = D[0, j]
        for a in range(nfv):
            s[j] -= w[a] * D[1 + a, j]
    fs = np.empty(dim)
    p, slip = node_law(g, N, np.empty((dim, dim)), s, t_n, N_n, p_n, area, law[0], law[1], law[2], law[3], fs, t,
                       np.empty((0, 0)))
    for j in range(dim):
        f[0, j] = fs[j]
        for a in range(nfv):
            f[1 + a, j] = -w[a] * fs[j]
    return g, N, p, slip


@_njit
def _facet_normal(P):
    """The unit normal of the facet P[1:] (left of a segment's direction, right-handed about a triangle's
    vertex order)."""
    dim = P.shape[1]
    n = np.zeros(dim)
    if dim == 2:
        t0, t1 = P[2, 0] - P[1, 0], P[2, 1] - P[1, 1]
        n[0], n[1] = -t1, t0
    else:
        a0, a1, a2 = P[2, 0] - P[1, 0], P[2, 1] - P[1, 1], P[2, 2] - P[1, 2]
        b0, b1, b2 = P[3, 0] - P[1, 0], P[3, 1] - P[1, 1], P[3, 2] - P[1, 2]
        n[0], n[1], n[2] = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
    size = math.sqrt(np.sum(n * n))
    return n / size if size > 0.0 else n


@_njit
def _segment_tangent(P, xi, g, k, K):
    """K (6, 6) = k [N_e N_e^T + g dN_e/dx] of a slave node P[0] pressed (g <= 0) into the inside of the
    segment P[1], P[2] (nearest point at xi in (0, 1)), k = eps A [N/mm]: the node-to-segment tangent
    (Wriggers 2006, sec. 9.1; K = -df/dx of f = -k g N_e, N_e = (n, -(1 - xi) n, -xi n)), with
    dg = N_e . dx, dxi = (T_e + g / l D_e) . dx / l, dn = -tau (D_e . dx) / l (tau the unit tangent, l the
    length, T_e = (tau, -(1 - xi) tau, -xi tau), D_e = (0, -n, n))."""
    t0, t1 = P[2, 0] - P[1, 0], P[2, 1] - P[1, 1]
    length = math.sqrt(t0 * t0 + t1 * t1)
    tau = np.array([t0 / length, t1 / length])
    n = np.array([-tau[1], tau[0]])
    Ne = np.empty(6)
    Te = np.empty(6)
    De = np.zeros(6)
    c = (1.0, -(1.0 - xi), -xi)
    for a in range(3):
        for j in range(2):
            Ne[2 * a + j] = c[a] * n[j]
            Te[2 * a + j] = c[a] * tau[j]
    for j in range(2):
        De[2 + j] = -n[j]
        De[4 + j] = n[j]
    for r in range(6):
        a, j = r // 2, r % 2
        for q in range(6):
            dxi = (Te[q] + g / length * De[q]) / length
            dn = -tau[j] * De[q] / length                      # d n_j / d x_q
            if a == 0:
                dNe = dn
            elif a == 1:
                dNe = -(1.0 - xi) * dn + n[j] * dxi
            else:
                dNe = -xi * dn - n[j] * dxi
            K[r, q] = k * (Ne[r] * Ne[q] + g * dNe)


@_njit
def _node_terms(x, dx, area, facet, V, DV, F, VN, law, t_n, N_n, p_n, r, K, g, N, t, p, slip, pressed):
    """Per slave node i (positions x (n, dim) [mm], displacements since the last commit dx (n, dim) [mm]) with a
    facet (facet[i] >= 0) of the surface V (nv, dim) [mm] (its vertices' displacements since the commit DV
    (nv, dim), unit vertex normals VN (nv, dim), read in 3-D), F (nf, nfv): r[i] = -f (the residual's
    entries: the slave's dim components, then each facet vertex's) and K[i] = -df/dx, the node-to-segment
    element's analytic tangent inside a segment without friction, else central differences; g[i], N[i] the gap and normal (overwriting the search's with the
    element's own, the same numbers inside a facet), t[i], p[i], slip[i] the law's (law, t_n, N_n, p_n: see
    :func:`_element_force`); pressed[i] whether the node is pressed or touching (g <= TOUCHING x the facet's
    longest edge) and so has a tangent. Nodes without a facet get g = inf and zeros."""
    n, dim = x.shape
    nfv = F.shape[1]
    m = (1 + nfv) * dim
    P = np.empty((1 + nfv, dim))
    D = np.empty((1 + nfv, dim))
    f = np.empty((1 + nfv, dim))
    fp = np.empty((1 + nfv, dim))
    fm = np.empty((1 + nfv, dim))
    tw = np.empty(dim)
    frictionless = law[2] <= 0.0
    smooth = dim == 3
    NVf = np.zeros((nfv if smooth else 0, dim))
    for i in range(n):
        r[i, :] = 0.0
        K[i, :, :] = 0.0
        t[i, :] = 0.0
        p[i] = 0.0
        slip[i] = 0.0
        pressed[i] = False
        fc = facet[i]
        if fc < 0:
            g[i] = math.inf
            continue
        for j in range(dim):
            P[0, j] = x[i, j]
            D[0, j] = dx[i, j]
        size = 0.0
        for a in range(nfv):
            for j in range(dim):
                P[1 + a, j] = V[F[fc, a], j]
                D[1 + a, j] = DV[F[fc, a], j]
                if smooth:
                    NVf[a, j] = VN[F[fc, a], j]
            for b in range(a):
                e = 0.0
                for j in range(dim):
                    e += (V[F[fc, a], j] - V[F[fc, b], j]) ** 2
                size = max(size, math.sqrt(e))
        gi, Ni, p[i], slip[i] = _element_force(P, D, nfv, area[i], _facet_normal(P), NVf, size, law, t_n[i],
                                               N_n[i], p_n[i], f, t[i])
        g[i] = gi
        for j in range(dim):
            N[i, j] = Ni[j]
        for a in range(1 + nfv):
            for j in range(dim):
                r[i, a * dim + j] = -f[a, j]
        if gi > TOUCHING * size:        # apart: no force, no stiffness
            continue
        pressed[i] = True
        if dim == 2 and frictionless:
            _, _, _, feature, xi = segment_nearest(P[0], P[1:], 0, 1)
            if feature == 0:
                _segment_tangent(P, xi, gi, law[0] * area[i], K[i])
                continue
        # friction, corners and edges (and 3-D): central differences, the step below the gap so as not to
        # cross g = 0 (but not below a thousandth of the step: a node touching, |g| ~ 1e-16, would take a step
        # at round-off); a node's displacement since the commit moves with it
        h = FD_STEP * size
        h = max(min(h, 1e-3 * -gi), 1e-3 * h)
        # a node touching (|g| below the steps) takes the tangent of the pressed side, as the law's own
        # tangent does for g < 0: the differences are taken with the slave moved in along N to g = -2 h
        shift = -gi - 2.0 * h if gi > -2.0 * h else 0.0
        for j in range(dim):
            P[0, j] += shift * Ni[j]
            D[0, j] += shift * Ni[j]
        for c in range(m):
            a, j = c // dim, c % dim
            keep, keep_d = P[a, j], D[a, j]
            P[a, j], D[a, j] = keep + h, keep_d + h
            _element_force(P, D, nfv, area[i], _facet_normal(P), NVf, size, law, t_n[i], N_n[i], p_n[i], fp, tw)
            P[a, j], D[a, j] = keep - h, keep_d - h
            _element_force(P, D, nfv, area[i], _facet_normal(P), NVf, size, law, t_n[i], N_n[i], p_n[i], fm, tw)
            P[a, j], D[a, j] = keep, keep_d
            for b in range(1 + nfv):
                for k in range(dim):
                    K[i, b * dim + k, c] = -(fp[b, k] - fm[b, k]) / (2.0 * h)
