r"""Penalty contact with Coulomb friction for the explicit solver: body nodes against rigid tools and
against master surfaces of the body (another body's, or their own group's: self-contact).

Each :class:`ExplicitContactPair` is the set of nodes of one boundary facet group of the body
against one rigid tool (any object with ``gap_np(x, t) -> (g (n,), N (n, dim))``, ``dim`` and
``translation(t, use_ufl=False) -> (dim,)``, e.g. the tools of :mod:`fenics_plast.tools`, whose
load factor is the time t [s] here). Units mm, N, MPa, s.

* Nodes: the owned nodes of the facet group (each rank handles its owned nodes; totals are
  reduced over the ranks), with the tributary area A_i = int N_i w dA0 [mm^2] on the reference
  facets, w = 2 pi R in axisymmetry (the exact nodal rule of :mod:`fenics_plast.contact`).
* Normal force (on the body) A_i p N, p = eps <-g> [MPa], g the gap of the node's current position
  and N the tool's normal pointing into the body.
* Friction: Coulomb's law as elastoplastic slip with a nodal history. Trial traction
  t_tr = T . t_n - eps_T T . (du - dd) (T = (N_y, -N_x), t_n the tangential traction vector of the
  last step, du the node's displacement increment over the step and dd the tool's translation over
  it), returned to |t| <= mu p. ``law="coulomb"``: p and N current; ``"quasi-coulomb"`` (seed eq.
  24, as :mod:`fenics_plast.contact`): the bound mu p and the normal that defines T are those at
  the start of the step (history), and t = 0 at nodes out of contact. Force on the body
  A_i (p N + t T).
* Stable step: a node of lumped mass m_i on a penalty spring of stiffness eps A_i alone has the
  limit dt_c,i = 2 sqrt(m_i / (eps A_i)) (eps the larger of the normal and the tangential
  penalty; a node in several pairs, e.g. a corner shared by two groups, has their springs summed).
  The spring adds to the stiffness of the elements at the same node (omega^2 = (k_e + k_c) / m),
  so the solver combines the element estimate dt_e = h_min / c and dt_c = min_i dt_c,i
  as dt = 1 / sqrt(1 / dt_e^2 + 1 / dt_c^2) (<= both) and multiplies it by ``dt_safety``.
  Measured (tests' bar, dt_safety 0.8): the plain minimum min(dt_e, dt_c) goes unstable when
  dt_c ~ dt_e; the combined rule does not. eps ~ E / h gives dt_c ~ 1.4 h / c at a boundary node.
* Energies (trapezoidal over each step): contact work E_c = -int f_c . (du - dd) (penalty energy
  stored + frictional dissipation, >= 0 for a fixed tool) and the tool's work
  W_tool = int F_c . dd (goes into the external work); impulse int F_c dt [N s].

The forces are computed by :func:`fenics_plast.solvers.contact_kernels.contact_forces`, for every
:class:`~fenics_plast.tools.Tool` (any registered shape, :mod:`fenics_plast.tool_shapes`) with the
shape's gap formula compiled (:mod:`fenics_plast.solvers.tool_gaps`), so that serial fused runs keep
taking several steps per compiled call; another object with a ``gap_np`` (or a Tool subclass that
overrides it) has its ``gap_np`` called every step, which makes the serial run go step by step.

3-D bodies (3 dofs per node, 3-D tools): the same, with the tangential traction a vector of the
tangent plane returned to |t| <= mu p on its norm
(:func:`~fenics_plast.solvers.contact_kernels.contact_forces_3d`). Arrays per node have ``dim``
(2 or 3) columns: positions, dofs, t_hist, N_hist, fc; the impulse and the tool translations
``dim`` components; :meth:`ExplicitContactPair.tangential_force` is the vector sum A_i t_i in 3-D
and t_scal the norm |t| of each node's tangential traction.

A master surface of the body (:class:`~fenics_plast.solvers.body_surface.BodySurface`, kind BODY): every
step :meth:`ContactSet.update` moves it to the current positions, finds each slave node's nearest point,
gives the kernel the gap, normal and that point's increment (the slip and the contact work are relative to
it), and adds the reactions -w_a f_c to the master nodes; the springs count on both sides in the stable
step; :class:`~fenics_plast.solvers.body_surface.TwoPassPair` reports a pair taken both ways as one.
Self-contact (the pair's own group as its master): each node searches only the facets that face it.
"""
from __future__ import annotations

import math

import numpy as np
from dolfinx import fem
from mpi4py import MPI

from fenics_plast.contact import LAWS
from fenics_plast.tools import compiled_shape
from fenics_plast.solvers import contact_kernels as ck
from fenics_plast.solvers.body_surface import BodySurface, tributary_areas

_LAW_CODE = {"coulomb": ck.COULOMB, "quasi-coulomb": ck.QUASI_COULOMB}


def _hist_cols(dim):
    """Per-node history columns in checkpoints: t_hist (dim), N_hist (dim), p_hist, t_scal, slip,
    fc (dim): 9 in 2-D, 12 in 3-D."""
    return 3 * dim + 3


def tool_kind(tool):
    """(kind, params) of the compiled gap: a :class:`~fenics_plast.tools.Tool`'s shape code and parameter
    vector (:func:`~fenics_plast.tools.compiled_shape`), (BODY, empty) for a master surface of the body, or
    (GENERIC, empty) for any other tool, or a Tool subclass with a gap_np of its own."""
    if isinstance(tool, BodySurface):
        return ck.BODY, np.zeros(0)
    shape = compiled_shape(tool)
    return shape if shape is not None else (ck.GENERIC, np.zeros(0))


class ExplicitContactPair:
    """Nodes of the facets tagged ``tag`` against ``tool`` (create with
    :meth:`ExplicitDynamics.add_contact`). Collective construction.

    penalty, tangential_penalty (default: penalty) [N/mm^3]; friction mu; law "coulomb" |
    "quasi-coulomb" (friction and law have no default here: :meth:`ExplicitDynamics.add_contact` takes
    the schema's). Reporting methods are collective and return global values on all ranks.
    """

    def __init__(self, contact_set, index, tool, facet_tags, tag, penalty, friction, law,
                 tangential_penalty=None, name=None):
        if law not in LAWS:
            raise ValueError(f"contact law must be one of {LAWS}, got {law!r}")
        if not penalty > 0:
            raise ValueError(f"contact penalty must be > 0, got {penalty!r}")
        if friction < 0:
            raise ValueError(f"friction coefficient must be >= 0, got {friction!r}")
        s = contact_set.solver
        self.set, self.index, self.tool, self.tag = contact_set, index, tool, tag
        self.name = name or getattr(tool, "name", "tool")
        self.penalty = float(penalty)
        self.tangential_penalty = float(tangential_penalty if tangential_penalty else penalty)
        self.friction = float(friction)
        self.law = law
        self.kind, self.params = tool_kind(tool)
        self.fixed = getattr(tool, "path", True) is None       # a tools.Tool without a path does not move
        self.comm = s.comm
        mesh, V, bs, n = s.mesh, s.V, s.bs, s.n_own
        self.dim = bs
        tool_dim = getattr(tool, "dim", 2)
        if tool_dim != bs:
            raise ValueError(f"contact pair {self.name!r}: a {tool_dim}-D tool on a {bs}-D body")
        fdim = mesh.topology.dim - 1
        facets = np.asarray(facet_tags.find(tag), dtype=np.int32)
        xdofs = np.asarray(fem.locate_dofs_topological(V.sub(0), fdim, facets), dtype=np.int64)
        xdofs = np.unique(xdofs[xdofs < n])
        nodes = xdofs // bs
        self.dofs = np.ascontiguousarray(np.stack([nodes * bs + j for j in range(bs)], axis=1))   # (nc, dim)
        self.X = np.ascontiguousarray(s.reference_positions[nodes, :bs])                           # (nc, dim) [mm]
        areas = tributary_areas(s.V, s.kin.weight, facet_tags, tag)
        self.area = areas[self.dofs[:, 0]].copy()                                             # (nc,) [mm^2]
        total = self.comm.allreduce(float(self.area.sum()), op=MPI.SUM)
        if total <= 0.0:
            raise ValueError(f"contact pair {self.name!r}: facet group {tag} has no facets (zero area)")
        if self.kind == ck.BODY:
            # a node does not touch the facets it belongs to (the slave and master groups may share nodes);
            # the master nodes' springs (their tributary areas on the master group) enter the stable step
            imap = V.dofmap.index_map
            self.skip = tool.skip_of(imap.local_to_global(nodes.astype(np.int32)))
            self.master_area = tributary_areas(s.V, s.kin.weight, facet_tags, tool.tag)[tool.dofs[:, 0]]
        else:
            self.skip = np.full(len(nodes), -1, dtype=np.int64)
        # stable step of the node on its penalty spring
        k = max(self.penalty, self.tangential_penalty if self.friction > 0 else 0.0) * self.area
        m = s.mass[self.dofs[:, 0]]
        on = k > 0
        loc = float(np.min(2.0 * np.sqrt(m[on] / k[on]))) if on.any() else math.inf
        self.dt_stable = self.comm.allreduce(loc, op=MPI.MIN)
        self.sl = slice(0, 0)

    @property
    def compiled(self):
        """True if the gap is computed in compiled code (every :class:`~fenics_plast.tools.Tool`)."""
        return self.kind >= 0

    def translation(self, t):
        """The tool's translation at time t [s] (dim,) [mm]."""
        if self.fixed:
            return np.zeros(self.dim)
        return np.asarray(self.tool.translation(float(t), use_ufl=False), dtype=float).reshape(self.dim)

    # -- reporting (collective) --------------------------------------------------------------
    def _sum(self, x):
        return self.comm.allreduce(x, op=MPI.SUM)

    def force(self):
        """Total contact force exerted BY the tool ON the body (Fx, Fy) [N] at the current step
        (2 pi r included in axisymmetry); (Fx, Fy, Fz) in 3-D."""
        return self._sum(self.set.fc[self.sl].sum(axis=0))

    def normal_force(self):
        """sum_i A_i p_i [N]."""
        c = self.set
        return self._sum(float(np.dot(c.area[self.sl], c.p_hist[self.sl])))

    def tangential_force(self):
        """sum_i A_i t_i [N], t signed along T = (N_y, -N_x) (0 without friction); 3-D: the vector
        sum_i A_i t_i (3,) [N] of the tangential tractions."""
        c = self.set
        if self.dim == 3:
            return self._sum((c.area[self.sl, None] * c.t_hist[self.sl]).sum(axis=0))
        return self._sum(float(np.dot(c.area[self.sl], c.t_scal[self.sl])))

    def contact_nodes(self):
        """The pair's owned group nodes now, a :class:`~fenics_plast.solvers.contact_law.ContactNodes`."""
        from fenics_plast.solvers.contact_law import ContactNodes
        c, s = self.set, self.set.solver
        x = self.X + s.u.x.array[self.dofs]
        if self.kind == ck.BODY or not self.compiled:
            g = c.gN[self.sl, 0].copy()
        else:
            g = self.tool.gap_np(x, float(s.t))[0]
        p = c.p_hist[self.sl].copy()
        return ContactNodes(x, g, p, c.area[self.sl], self.dofs[:, 0] // self.dim, (p > 0.0) & (c.slip[self.sl] > 0.0))

    def max_penetration(self):
        """Largest penetration -g over the pair's nodes now [mm] (0 if none penetrates)."""
        p = self.set.p_hist[self.sl]
        return self.comm.allreduce(float(p.max()) / self.penalty if p.size else 0.0, op=MPI.MAX)

    def max_penetration_run(self):
        """Largest penetration over the run so far [mm]."""
        return self.comm.allreduce(float(self.set.pen[self.index]), op=MPI.MAX)

    def contact_work(self):
        """Energy taken up by the contact [N mm]: penalty energy + frictional dissipation (minus
        the work of a moving tool, which is :meth:`tool_work`)."""
        return self._sum(float(self.set.acc[self.index, 0]))

    def tool_work(self):
        """Work of the tool's motion on the body [N mm] (0 for a fixed tool and a master surface of the
        body, whose work on the body is part of :meth:`contact_work`)."""
        return self._sum(float(self.set.acc[self.index, 1]))

    def impulse(self):
        """Time integral of :meth:`force` since t = 0 (trapezoidal) (dim,) [N s]."""
        return self._sum(self.set.acc[self.index, 2:2 + self.dim].copy())

    def stored_energy(self):
        """Elastic energy in the penalty springs now [N mm]: sum A (p^2 / 2 eps + |t|^2 / 2 eps_T)."""
        c = self.set
        a, p, t = c.area[self.sl], c.p_hist[self.sl], c.t_scal[self.sl]
        e = 0.5 * np.dot(a, p * p) / self.penalty
        if self.friction > 0:
            e += 0.5 * np.dot(a, t * t) / self.tangential_penalty
        return self._sum(float(e))

    def status(self):
        """(nodes in contact, nodes slipping) at the last step (frictionless: every node in contact
        slips)."""
        c = self.set
        on = c.p_hist[self.sl] > 0.0
        slip = c.slip[self.sl] > 0.0
        tot = self._sum(np.array([on.sum(), slip.sum()], dtype=np.int64))
        return int(tot[0]), int(tot[1])


class ContactSet:
    """All contact pairs of one solver, their nodes concatenated in the arrays of
    :func:`~fenics_plast.solvers.contact_kernels.contact_forces` (rank-local rows)."""

    def __init__(self, solver):
        self.solver = solver
        self.dim = solver.bs                 # components per node: 2 (2-D) or 3 (3-D)
        self.pairs: list[ExplicitContactPair] = []
        self._surfaces: dict[int, BodySurface] = {}
        self._build()

    def surface(self, facet_tags, tag, mirror_tags=()):
        """The :class:`~fenics_plast.solvers.body_surface.BodySurface` of the facets tagged ``tag``, continued
        across the facets tagged ``mirror_tags`` (one per group, shared by the pairs that press on it;
        collective on first use)."""
        if tag not in self._surfaces:
            self._surfaces[tag] = BodySurface(self.solver.V, self.solver.reference_positions, facet_tags, tag,
                                              mirror_tags=mirror_tags)
        return self._surfaces[tag]

    def add(self, tool, facet_tags, tag, **kw):
        pair = ExplicitContactPair(self, len(self.pairs), tool, facet_tags, tag, **kw)
        self.pairs.append(pair)
        self._build()
        return pair

    @property
    def chunkable(self):
        """All gaps compiled: the serial step loop may run several steps per call."""
        return all(p.compiled for p in self.pairs)

    @property
    def dt_stable(self):
        """min over the contact nodes of 2 sqrt(m_i / k_i), k_i the summed penalty springs of every pair
        the node belongs to (a node shared by two groups, e.g. the corner of a face and a side, has
        both springs in parallel; each pair's own ``dt_stable`` sees only its own) [s]."""
        return self._dt_stable

    def _build(self):
        P = self.pairs
        nc = [p.X.shape[0] for p in P]
        start = np.concatenate([[0], np.cumsum(nc)]).astype(int)
        for p, a, b in zip(P, start[:-1], start[1:]):
            p.sl = slice(int(a), int(b))
        cat = (lambda xs, shape, dt=float: np.ascontiguousarray(np.concatenate(xs)) if xs
               else np.zeros(shape, dtype=dt))
        d = self.dim
        self.X = cat([p.X for p in P], (0, d))
        self.dofs = cat([p.dofs for p in P], (0, d), np.int64).astype(np.int64)
        self.pair = cat([np.full(p.X.shape[0], i, dtype=np.int64) for i, p in enumerate(P)], (0,), np.int64)
        self.area = cat([p.area for p in P], (0,))
        self.kind = np.array([p.kind for p in P], dtype=np.int64)
        self.params = np.zeros((len(P), max([p.params.size for p in P], default=0)))     # padded rows
        for i, p in enumerate(P):
            self.params[i, :p.params.size] = p.params
        self.eps = np.array([p.penalty for p in P], dtype=float)
        self.eps_t = np.array([p.tangential_penalty for p in P], dtype=float)
        self.mu = np.array([p.friction for p in P], dtype=float)
        self.law = np.array([_LAW_CODE[p.law] for p in P], dtype=np.int64)
        n = self.X.shape[0]
        self.gN = np.zeros((n, 1 + d))
        self.dd_node = np.zeros((n, d))
        self.skip = cat([p.skip for p in P], (0,), np.int64).astype(np.int64)
        self.facet = np.full(n, -1, dtype=np.int64)
        self.weights = np.zeros((n, d))
        self.t_hist = np.zeros((n, d))
        self.N_hist = np.zeros((n, d))
        self.p_hist = np.zeros(n)
        self.t_scal = np.zeros(n)
        self.slip = np.zeros(n)
        self.fc = np.zeros((n, d))
        self.acc = np.zeros((len(P), 2 + d))
        self.pen = np.zeros(len(P))
        # the kernel's record of these very arrays (it updates the history in place; restore writes into them)
        self._arrays = ck.ContactArrays(self.X, self.dofs, self.pair, self.area, self.kind, self.params, self.eps,
                                        self.eps_t, self.mu, self.law, self.gN, self.dd_node, self.t_hist,
                                        self.N_hist, self.p_hist, self.t_scal, self.slip, self.fc, self.acc, self.pen)
        self._dt_stable = self._combined_dt() if P else math.inf

    def mass_changed(self):
        """Recompute the springs' stable-step limit after the solver's nodal mass changed (selective
        mass scaling, a restored checkpoint); collective."""
        self._dt_stable = self._combined_dt() if self.pairs else math.inf

    def _combined_dt(self):
        """The penalty springs' stable-step limit with the springs of all pairs summed per node
        (collective: called when a pair is added). A pair against a master surface of the body has its
        springs between two moving nodes: each counts twice (two equal masses on a spring k vibrate as one
        on 2 k), on the slave nodes and, with their tributary areas on the master group, on the master
        nodes."""
        s = self.solver
        k = np.zeros(s.n_own // s.bs)
        for p in self.pairs:
            eps = max(p.penalty, p.tangential_penalty if p.friction > 0 else 0.0)
            both = 2.0 if p.kind == ck.BODY else 1.0
            np.add.at(k, p.dofs[:, 0] // s.bs, both * eps * p.area)
            if p.kind == ck.BODY:
                np.add.at(k, p.tool.dofs[:, 0] // s.bs, both * eps * p.master_area)
        m = s.mass[0::s.bs][: k.size]
        on = k > 0
        loc = float(np.min(2.0 * np.sqrt(m[on] / k[on]))) if on.any() else math.inf
        return self.pairs[0].comm.allreduce(loc, op=MPI.MIN)

    def args(self):
        """The :class:`~fenics_plast.solvers.contact_kernels.ContactArrays` of contact_forces (built with the
        arrays, once per pair added)."""
        return self._arrays

    def translations(self, t):
        """(npairs, dim) tool translations at time t [mm]."""
        return self.translations_at(np.array([float(t)]))[0]

    def translations_at(self, times):
        """(ntimes, npairs, dim) tool translations at the times (ntimes,) [mm]."""
        if not self.pairs:
            return np.zeros((len(times), 0, self.dim))
        return np.array([[p.translation(t) for p in self.pairs] for t in times], dtype=float)

    def update(self, u, du, dt, trans_old, trans_new, fcon, t):
        """Contact forces at the current positions X + u and time t into fcon (see contact_forces);
        the gaps of generic tools come from their gap_np; master surfaces of the body are moved to
        X + u (du their increment over the step), searched, and take the reactions (collective when the
        set has such pairs)."""
        body = [p for p in self.pairs if p.kind == ck.BODY]
        for surface in {id(p.tool): p.tool for p in body}.values():
            surface.move(u, du)
            fcon[surface.dofs] = 0.0
        for p in self.pairs:
            if p.kind == ck.BODY:
                n = p.X.shape[0]
                g, N, facet, w = np.empty(n), np.empty((n, self.dim)), np.empty(n, np.int64), np.empty((n, self.dim))
                self.dd_node[p.sl] = p.tool.nearest(p.X + u[p.dofs], self.skip[p.sl], g, N, facet, w,
                                                    self_contact=p.tool.tag == p.tag)
                self.gN[p.sl, 0], self.gN[p.sl, 1:], self.facet[p.sl], self.weights[p.sl] = g, N, facet, w
            elif not p.compiled and p.X.shape[0]:
                x = p.X + u[p.dofs]
                g, N = p.tool.gap_np(x, t)
                self.gN[p.sl, 0] = g
                self.gN[p.sl, 1:] = np.asarray(N)[:, :self.dim]
        ck.contact_forces(u, du, dt, self.args(), trans_old, trans_new, fcon)
        for p in body:
            p.tool.add_reactions(self.facet[p.sl], self.weights[p.sl], self.fc[p.sl], fcon)

    # -- checkpoints -------------------------------------------------------------------------
    def state_dict(self, dof_keys, comm):
        """Per pair i: ``contact<i>`` the nodal history rows keyed by node, ``contact<i>_acc`` the
        summed accumulators, ``contact<i>_pen`` the run's max penetration."""
        from fenics_plast.checkpoint import Keyed
        d = {}
        hist = np.column_stack([self.t_hist, self.N_hist, self.p_hist, self.t_scal, self.slip, self.fc])
        for i, p in enumerate(self.pairs):
            d[f"contact{i}"] = Keyed(hist[p.sl], dof_keys[self.dofs[p.sl, 0]])
            d[f"contact{i}_acc"] = comm.allreduce(self.acc[i].copy(), op=MPI.SUM).tolist()
            d[f"contact{i}_pen"] = comm.allreduce(float(self.pen[i]), op=MPI.MAX)
        return d

    def required_keys(self):
        return [f"contact{i}{s}" for i in range(len(self.pairs)) for s in ("", "_acc", "_pen")]

    def take(self, d, dof_keys):
        """The rows of this rank (raises CheckpointError, rank-local, for another mesh)."""
        return [d[f"contact{i}"].take(dof_keys[self.dofs[p.sl, 0]]) for i, p in enumerate(self.pairs)]

    def restore(self, d, rows, root):
        dim = self.dim
        for i, (p, r) in enumerate(zip(self.pairs, rows)):
            r = np.asarray(r, dtype=float).reshape(-1, _hist_cols(dim))
            self.t_hist[p.sl], self.N_hist[p.sl] = r[:, 0:dim], r[:, dim:2 * dim]
            c = 2 * dim
            self.p_hist[p.sl], self.t_scal[p.sl], self.slip[p.sl] = r[:, c], r[:, c + 1], r[:, c + 2]
            self.fc[p.sl] = r[:, c + 3:c + 3 + dim]
            self.acc[i] = np.asarray(d[f"contact{i}_acc"], dtype=float) if root else 0.0
            self.pen[i] = float(d[f"contact{i}_pen"])
