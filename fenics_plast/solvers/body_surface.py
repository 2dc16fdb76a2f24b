"""A boundary facet group of the body as the master surface of node-to-surface contact (both solvers).

Two bodies are two regions of one mesh; a contact pair whose master surface is a facet group of the body
presses the nodes of its slave group against the facets of the master group at their current positions,
and every slave force has its reaction on the nodes of the master facet that holds the slave's nearest
point, weighted by that point's coordinates in the facet (the force a node-to-surface element
exerts on both sides: Wriggers, Computational Contact Mechanics, 2006, ch. 8).

:class:`BodySurface` holds the group's facets as one :class:`~fenics_plast.solvers.surface_gaps.FacetSurface`
on every rank (segments in 2-D; in 3-D a hexahedron's quadrilateral facet as four triangles about its centre,
a vertex that moves with the mean of the four corners and passes its reactions to them a quarter each),
oriented to point out of their cells. Under MPI each rank owns some of its vertices: :meth:`BodySurface.move`
sums the owned rows of every rank into the whole surface's positions and displacement increments (one
Allreduce of (nv, 2 dim) numbers a step; the surface is gathered whole on every rank, which suits forming
and impact interfaces of up to some 10^5 facets) and refreshes its normals and search boxes;
:meth:`BodySurface.add_reactions` sums the ranks' reactions the same way and adds the owned rows to the
contact force vector. Units mm, N.
"""
from __future__ import annotations

import numba
import numpy as np
from mpi4py import MPI

from fenics_plast import dolfinx_compat as dc
from fenics_plast.solvers.surface_gaps import nearest_points, oriented_surface, refresh
from fenics_plast.solvers.tool_gaps import FLAGS

_njit = numba.njit(cache=True, **FLAGS)


def _boundary_facets(V, facet_tags, tag):
    """(facets (nf, dim) as global node (dof block) indices, cell centroids (nf, dim) [mm]) of this rank's
    owned facets tagged ``tag``, each as its cell sees it: 2 nodes (2-D) or the 4 of a quadrilateral in
    cyclic order (3-D)."""
    mesh = V.mesh
    tdim, fdim = mesh.topology.dim, mesh.topology.dim - 1
    gdim = V.dofmap.index_map_bs
    mesh.topology.create_connectivity(fdim, tdim)
    f2c = mesh.topology.connectivity(fdim, tdim)
    facets = np.asarray(facet_tags.find(tag), dtype=np.int32)
    facets = facets[facets < mesh.topology.index_map(fdim).size_local]
    geometry = dc.geometry_dofs(mesh)                       # cell -> geometry nodes, the order of V's cell dofs
    cell_dofs = dc.cell_dofs(V)
    nodes = dc.entity_nodes(mesh, fdim, facets) if len(facets) else np.zeros((0, 2 ** fdim), dtype=np.int32)
    out = np.zeros((len(facets), nodes.shape[1]), dtype=np.int64)
    centroids = np.zeros((len(facets), gdim))
    for i, f in enumerate(facets):
        c = f2c.links(f)[0]
        column = {int(g): k for k, g in enumerate(geometry[c])}
        out[i] = cell_dofs[c][[column[int(g)] for g in nodes[i]]]
        centroids[i] = mesh.geometry.x[geometry[c], :gdim].mean(axis=0)
    if fdim == 2:
        out = out[:, [0, 1, 3, 2]]                              # tensor-product order -> cyclic
    imap = V.dofmap.index_map
    return imap.local_to_global(out.ravel().astype(np.int32)).reshape(out.shape).astype(np.int64), centroids


def _nodes_on(V, facet_tags, tags):
    """(n,) the global nodes (dof blocks) of V on the facets tagged any of ``tags``, every rank's (collective)."""
    from dolfinx import fem
    fdim = V.mesh.topology.dim - 1
    imap = V.dofmap.index_map
    blocks = [np.asarray(fem.locate_dofs_topological(V, fdim, facet_tags.find(t)), dtype=np.int32) for t in tags]
    local = np.unique(np.concatenate(blocks)) if blocks else np.zeros(0, dtype=np.int32)
    local = local[local < imap.size_local]
    mine = imap.local_to_global(local).astype(np.int64)
    return np.concatenate(V.mesh.comm.allgather(mine))


def tributary_areas(V, weight, facet_tags, tag):
    """int N_i w dA0 [mm^2] of every owned node i of the CG1 vector space V, per unrolled dof ((n_own,)),
    over the facets tagged ``tag``; w the UFL weight (2 pi R in axisymmetry, 1 otherwise). Degree 4: exact
    for N_i times the linear weight (collective)."""
    import ufl
    from dolfinx import fem
    from dolfinx.fem import petsc as fem_petsc
    from petsc4py import PETSc
    bs = V.dofmap.index_map_bs
    ds = ufl.Measure("ds", domain=V.mesh, subdomain_data=facet_tags, metadata={"quadrature_degree": 4})(tag)
    ones = fem.Constant(V.mesh, PETSc.ScalarType((1.0,) * bs))
    b = fem_petsc.assemble_vector(fem.form(ufl.inner(ones, ufl.TestFunction(V)) * weight * ds))
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    areas = b.array[: V.dofmap.index_map.size_local * bs].copy()
    b.destroy()
    return areas


class BodySurface:
    """The facets tagged ``tag`` of a body as a master surface (see the module docstring); V the body's CG1
    vector space (its dof blocks are the nodes), X (local nodes, gdim) their reference positions [mm];
    collective construction. ``mirror_tags``: the facet tags of the model's planes (and axis) of symmetry;
    where the surface ends on one, it continues as its mirror image (its vertices there are ``mirrored``
    in :func:`~fenics_plast.solvers.surface_gaps.oriented_surface`). ``vertex_nodes`` (nv,) the global
    node of each surface vertex, ``surface`` the :class:`~fenics_plast.solvers.surface_gaps.FacetSurface`
    at the last :meth:`move`."""

    path = None     # as a "tool" of ExplicitContactPair: no path, so no translation (its ``fixed``)

    def __init__(self, V, X, facet_tags, tag, name=None, mirror_tags=()):
        comm = V.mesh.comm
        self.comm, self.tag, self.name = comm, tag, name or f"facets {tag}"
        bs = self.dim = V.dofmap.index_map_bs
        local, centroids = _boundary_facets(V, facet_tags, tag)
        imap = V.dofmap.index_map
        nodes_local = np.arange(imap.size_local + imap.num_ghosts, dtype=np.int32)
        owned_global = imap.local_to_global(nodes_local[: imap.size_local]).astype(np.int64)
        # every rank gets every facet (global nodes) and the reference position of every vertex
        pieces = comm.allgather((local, centroids))
        quads = np.concatenate([p[0] for p in pieces])
        cells = np.concatenate([p[1] for p in pieces])
        if len(quads) == 0:
            raise ValueError(f"contact master group {self.name!r} has no facets")
        self.vertex_nodes = np.unique(quads)
        facets = np.searchsorted(self.vertex_nodes, quads)
        # the rows this rank owns, their local dofs
        mine = np.isin(owned_global, self.vertex_nodes)
        self.rows = np.searchsorted(self.vertex_nodes, owned_global[mine])
        local_nodes = nodes_local[: imap.size_local][mine]
        self.dofs = np.ascontiguousarray(np.stack([local_nodes * bs + j for j in range(bs)], axis=1), dtype=np.int64)
        X0 = np.zeros((len(self.vertex_nodes), bs))
        X0[self.rows] = X[local_nodes, :bs]
        X0 = self._sum(X0)
        self.X = X0
        facets = self._outward(facets, X0, cells)
        nv = len(X0)
        # 3-D: the quadrilaterals' centres (vertices nv, nv + 1, ...), four triangles (corner, next corner, centre)
        self.quads = facets if bs == 3 else np.zeros((0, 4), dtype=np.int64)
        if bs == 3:
            centre = nv + np.arange(len(facets))
            facets = np.concatenate([np.stack([facets[:, k], facets[:, (k + 1) % 4], centre], axis=1)
                                     for k in range(4)])
        mirrored = np.concatenate([np.isin(self.vertex_nodes, _nodes_on(V, facet_tags, mirror_tags)),
                                   np.zeros(len(self.quads), dtype=bool)])
        self.surface = oriented_surface(self._with_centres(X0), facets, mirrored=mirrored)
        # the (dim nfv, dim k) map from the k real vertices a facet acts on to its vertices (3-D: the triangle's
        # two corners, then the centre as the mean of its quadrilateral's four); None in 2-D (the identity)
        self.to_facet_vertices = None
        if bs == 3:
            C = np.zeros((3 * bs, 6 * bs))
            C[:2 * bs, :2 * bs] = np.eye(2 * bs)
            C[2 * bs:, 2 * bs:] = np.tile(0.25 * np.eye(bs), 4)
            self.to_facet_vertices = C
        self.increment = np.zeros((nv + len(self.quads), bs))  # displacement of each vertex over the last step [mm]
        self._moved = np.zeros((nv, 2 * bs))

    def _sum(self, a):
        if self.comm.size > 1:
            self.comm.Allreduce(MPI.IN_PLACE, a, op=MPI.SUM)
        return a

    def _with_centres(self, a):
        """(nv + nq, k): the rows a (nv, k) of the real vertices, then the mean of each quadrilateral's four."""
        if not len(self.quads):
            return a
        out = np.empty((len(a) + len(self.quads), a.shape[1]))
        _centres(self.quads, np.ascontiguousarray(a, dtype=float), out)
        return out

    def element_nodes(self, facet):
        """(m, k) the real vertices whose dofs the facets (m,) act on: 2-D the segment's two; 3-D the triangle's
        two corners and its quadrilateral's four (the centre is their mean; ``to_facet_vertices`` maps their
        dofs' values to the facet vertices')."""
        F = self.surface.facets[facet]
        if not len(self.quads):
            return F
        return np.concatenate([F[:, :2], self.quads[F[:, 2] - len(self.vertex_nodes)]], axis=1)

    @staticmethod
    def _outward(facets, X, centroids):
        """Segments (2-D) turned so that their left normal points out of their cell; quadrilaterals (3-D)
        turned so that their right-handed normal does (corners in cyclic order)."""
        P = X[facets]
        if facets.shape[1] == 2:
            t = P[:, 1] - P[:, 0]
            n = np.stack([-t[:, 1], t[:, 0]], axis=1)
        else:
            n = np.cross(P[:, 1] - P[:, 0], P[:, 3] - P[:, 0])
        inward = np.einsum("ij,ij->i", n, P.mean(axis=1) - centroids) < 0.0
        facets = facets.copy()
        facets[inward] = facets[inward, ::-1]
        return np.ascontiguousarray(facets)

    def global_rows(self, values):
        """(nv, dim) of this rank's rows of ``values`` (rows of the surface it owns, e.g. global equation
        numbers), the other ranks' summed in (collective)."""
        out = np.zeros((len(self.vertex_nodes), self.dim), dtype=values.dtype)
        out[self.rows] = values
        if self.comm.size > 1:
            self.comm.Allreduce(MPI.IN_PLACE, out, op=MPI.SUM)
        return out

    def skip_of(self, global_nodes):
        """(n,) the surface vertex of each of the global nodes (-1: not on this surface): a node does not
        touch its own facets."""
        global_nodes = np.asarray(global_nodes, dtype=np.int64)
        at = np.minimum(np.searchsorted(self.vertex_nodes, global_nodes), len(self.vertex_nodes) - 1)
        return np.where(self.vertex_nodes[at] == global_nodes, at, -1).astype(np.int64)

    def move(self, u, du=None):
        """The surface at the positions X + u and its vertices' increments du over the step (u the local
        displacement array, du the owned increments [mm]; None: not wanted); collective."""
        m, bs = self._moved, self.dim
        _owned_rows(self.X, self.rows, self.dofs, u, du if du is not None else u, m)
        self._sum(m)
        m = self._with_centres(m)
        refresh(self.surface, m[:, :bs])
        self.increment[:] = m[:, bs:]

    def nearest(self, x, skip, g, N, facet, weights, self_contact=False):
        """Gaps g (n,) [mm], normals N (n, dim) pointing out of the master body, the facet (n,) and the
        weights (n, dim) of the nearest points of the slave positions x (n, dim) [mm]
        (:func:`~fenics_plast.solvers.surface_gaps.nearest_points`); the master point's increment over the
        step (n, dim) [mm] is returned. ``self_contact``: the points are this surface's own vertices skip
        (n,), and only facets facing their vertex normals count."""
        facing = self.surface.vertex_normals[skip] if self_contact else None
        nearest_points(self.surface, x, skip, g, N, facet, weights, facing=facing)
        return self.increment_at(facet, weights)

    def increment_at(self, facet, weights):
        """The surface's increment over the step (as :meth:`move` left it) at the points of the facets (n,)
        with the weights (n, dim) of their vertices: (n, dim) [mm]."""
        dd = np.empty((len(facet), self.dim))
        _at_points(self.surface.facets, facet, weights, self.increment, dd)
        return dd

    def add_reactions(self, facet, weights, fc, fcon):
        """fcon (owned dofs) += the reactions -w_a f_c of the slave forces fc (n, dim) [N] at the vertices of
        their facets (n,) with weights (n, dim); collective."""
        R = np.zeros_like(self.increment)
        _spread(self.surface.facets, facet, weights, fc, R)
        R = self._centres_to_corners(R)
        self._sum(R)
        _add_rows(R, self.rows, self.dofs, fcon)

    def _centres_to_corners(self, R):
        """(nv, dim): the rows R (nv + nq, dim) of the real vertices, each centre's passed to its
        quadrilateral's four corners, a quarter each."""
        if not len(self.quads):
            return R
        out = R[: len(self.vertex_nodes)].copy()
        _to_corners(self.quads, R[len(self.vertex_nodes):], out)
        return out


class TwoPassPair:
    """A contact pair between two facet groups of the body taken both ways: ``forward`` (the group's nodes
    against the master's facets) and ``backward`` (the master's nodes against the group's facets), passes
    of the same law and penalty (the explicit solver's
    :class:`~fenics_plast.solvers.explicit_contact.ExplicitContactPair`, the static solver's
    :class:`~fenics_plast.solvers.static_surface_contact.SurfaceContactTerm`). Reports as one pair: forces on
    the group's side (each pass's forces on its slaves, and the reactions of the other's), energies and
    penetrations of both (the methods a solver's passes have). Collective methods, as the passes'."""

    def __init__(self, forward, backward):
        self.forward, self.backward = forward, backward
        self.name, self.penalty = forward.name, forward.penalty

    def force(self):
        """Force [N] (dim,) on the group's nodes' body from the master's: forward's forces on its slaves less
        backward's (whose reactions act on the group's nodes)."""
        return np.asarray(self.forward.force()) - np.asarray(self.backward.force())

    def normal_force(self):
        """sum A p over both passes [N] (each carries a share of the interface's force)."""
        return self.forward.normal_force() + self.backward.normal_force()

    def tangential_force(self):
        """Tangential force [N] on the group's side: 2-D signed along forward's T (backward's T is opposite:
        its share adds), 3-D the vector."""
        if self.forward.dim == 3:
            return np.asarray(self.forward.tangential_force()) - np.asarray(self.backward.tangential_force())
        return self.forward.tangential_force() + self.backward.tangential_force()

    def max_penetration(self):
        return max(self.forward.max_penetration(), self.backward.max_penetration())

    def contact_sides(self):
        """Both passes' :meth:`contact_nodes` (the group's side, then the master's), each pass's pressures scaled
        by the interface's normal force over its own: each pass carries a share of the force, the scaled
        pressures the whole (collective)."""
        own = (self.forward.normal_force(), self.backward.normal_force())
        total = sum(own)
        return [c._replace(p=c.p * (total / f if f > 0.0 else 1.0))
                for c, f in zip((self.forward.contact_nodes(), self.backward.contact_nodes()), own)]

    def contact_nodes(self):
        """The group's side of :meth:`contact_sides` (collective)."""
        return self.contact_sides()[0]

    def max_penetration_run(self):
        return max(self.forward.max_penetration_run(), self.backward.max_penetration_run())

    def contact_work(self):
        return self.forward.contact_work() + self.backward.contact_work()

    def tool_work(self):
        return 0.0

    def impulse(self):
        return np.asarray(self.forward.impulse()) - np.asarray(self.backward.impulse())

    def stored_energy(self):
        return self.forward.stored_energy() + self.backward.stored_energy()

    def status(self):
        a, b = self.forward.status(), self.backward.status()
        return a[0] + b[0], a[1] + b[1]


# ----------------------------------------------------------------------------------------------
# compiled: the per-step work on the surface's arrays


@_njit
def _owned_rows(X, rows, dofs, u, du, out):
    """out (nv, 2 dim) = 0 but this rank's rows: positions X + u [mm], then the increments du [mm]."""
    out[:, :] = 0.0
    dim = X.shape[1]
    for i in range(len(rows)):
        r = rows[i]
        for j in range(dim):
            out[r, j] = X[r, j] + u[dofs[i, j]]
            out[r, dim + j] = du[dofs[i, j]]


@_njit
def _centres(quads, a, out):
    """out[:nv] = a (nv, k); out[nv + q] = the mean of a over the four corners quads[q]."""
    nv = a.shape[0]
    out[:nv] = a
    for q in range(quads.shape[0]):
        for j in range(a.shape[1]):
            out[nv + q, j] = 0.25 * (a[quads[q, 0], j] + a[quads[q, 1], j] + a[quads[q, 2], j] + a[quads[q, 3], j])


@_njit
def _to_corners(quads, Rc, out):
    """out[quads[q, k]] += Rc[q] / 4 for each corner k of each quadrilateral q."""
    for q in range(quads.shape[0]):
        for k in range(4):
            for j in range(Rc.shape[1]):
                out[quads[q, k], j] += 0.25 * Rc[q, j]


@_njit
def _at_points(facets, facet, weights, values, out):
    """out (n, dim) = sum_a weights[i, a] values[facets[facet[i], a]] (0 where facet[i] < 0)."""
    for i in range(len(facet)):
        for j in range(out.shape[1]):
            out[i, j] = 0.0
        f = facet[i]
        if f < 0:
            continue
        for a in range(facets.shape[1]):
            for j in range(out.shape[1]):
                out[i, j] += weights[i, a] * values[facets[f, a], j]


@_njit
def _spread(facets, facet, weights, fc, R):
    """R[facets[facet[i], a]] -= weights[i, a] fc[i] (the reactions of the forces fc (n, dim))."""
    for i in range(len(facet)):
        f = facet[i]
        if f < 0:
            continue
        for a in range(facets.shape[1]):
            for j in range(fc.shape[1]):
                R[facets[f, a], j] -= weights[i, a] * fc[i, j]


@_njit
def _add_rows(R, rows, dofs, fcon):
    """fcon[dofs[i, j]] += R[rows[i], j] (this rank's rows)."""
    for i in range(len(rows)):
        for j in range(R.shape[1]):
            fcon[dofs[i, j]] += R[rows[i], j]
