"""Frictional penalty contact of the deformable body against rigid tools in the static solver (seed eqs. 16-25).

Two routes, the same numbers: :class:`PenaltyContact` assembles each pair compiled, node by node
(:class:`fenics_plast.solvers.static_tool_contact.ToolContactTerm`, the default: ``compiled=True``), or as the
UFL forms of :class:`ContactPair` below (``compiled=False``), which are the **definition** the compiled route
is held to (``tests/test_static_tool_contact.py``: residual, Jacobian, forces and Newton iterations).

Tools (:mod:`fenics_plast.tools`: :class:`~fenics_plast.tools.Plane`, ``Circle``, ``Profile``) are
rigid bodies that only translate, along a path of the solver's load factor (the ``fem.Constant``
``solver.load``; :func:`fenics_plast.tools.piecewise_path` makes a piecewise-linear one).  For every
tool the gap ``g`` and the outward normal ``N`` (pointing from the tool into the body) are exact UFL
expressions of the current position ``x = X + u`` of the body's candidate facets; a meshed tool
(:mod:`fenics_plast.meshed_tools`, no UFL gap) gives them at the nodes, linearised about each Newton
state (:meth:`ContactPair._nodal_gap`).

Each :class:`ContactPair` (one tool against one facet group, :meth:`PenaltyContact.add_pair`) has
its own normal penalty ``eps``, tangential penalty ``eps_T``, friction coefficient ``mu`` and law;
:meth:`PenaltyContact.add_tool` uses the contact-wide values given to :class:`PenaltyContact`.
Friction coefficient and law default to the schema's ``contact.<name>.friction`` and
``contact.<name>.law`` (:func:`fenics_plast.schema.default`), the laws are its choices (:data:`LAWS`).

Normal contact (seed eqs. 17-18) is a penalty derived from the potential
``Pi = int 1/2 eps <-g>^2 w dA0`` (reference facets, weight w = 2 pi R in axisymmetry): the
contact pressure is ``p = eps <-g>`` and the residual ``-int p N . v w dA0``; the Jacobian is
``ufl.derivative`` of it (consistent and symmetric: eps N N^T + p dN/du).

Friction (seed eqs. 19-22) is Coulomb's law regularised as elastoplastic slip: tangential penalty
``eps_T``, trial tangential traction (on the body) ``t_tr = T . t_n - eps_T T . ds`` with ``ds``
the displacement increment relative to the tool since the last converged increment, and the
return map ``|t| <= mu p`` written with ``ufl.conditional`` so that ``ufl.derivative`` gives the
consistent tangent (quadratic Newton in stick and in slip).

* ``law = "coulomb"``: p, N and T are the current ones (non-symmetric Jacobian in slip);
* ``law = "quasi-coulomb"`` (seed eq. 24): p and the normal N (hence T) are frozen at the last
  converged values during an increment, so the frictional Jacobian is eps_T T_n T_n^T in stick and
  zero in slip (symmetric; the friction force is mu p_n in slip).

Every contact integral uses the nodal (trapezoidal, "node-to-surface") rule on the candidate
facets: a custom 2-point rule at the facet's end points (``quadrature_rule = "custom"`` in the
``ds`` metadata; the "vertex" scheme is silently ignored by ffcx 0.5 on facets).  So gaps are
nodal gaps (a straight facet wrapped around a convex tool does not see its chord's sagitta as a
penetration), and the weight is a CG1 Function holding each node's exact tributary area
``int N_i w dA0 / int_trap N_i dA0`` (2 pi r_i inside the face, 2 pi h/3 at the axis node, where
2 pi r would be 0).

History (t_n, N_n, p_n) therefore lives at the nodes: a CG1 Function with 5 components per pair.
``commit()`` (call it after every converged increment, e.g. from the solver's run callback) stores
the values by assembling ``int value q ds / int q ds`` with the same nodal rule and a CG1 test
function q, which gives exactly the nodal values (both facets of a node see the same value).
A cut-back needs nothing: the history only changes in ``commit()``.

Predictor: :meth:`PenaltyContact.attach` also registers :meth:`ContactPair.keep_gaps` with the solver
(``solver.predictors``): an extrapolated increment starts with the nodes that were in contact at their
committed gaps, so Newton starts with the contact set of the last increment instead of none.

Normal and friction terms share the rule, so at every contact node, and therefore in total, the
tangential force of a pair equals its mu times its normal force when slipping.  A pair with
mu = 0 assembles no friction term at all.

3-D (``Kinematics(mesh, "3d")``, 3-D tools of :mod:`fenics_plast.tools`): the same equations with
the tangential traction a vector in the tangent plane of the normal N_f (N current for Coulomb, the
committed N_n for Quasi-Coulomb), P_T = I - N_f N_f^T,

    t_tr = P_T (t_n - eps_T ds),     t = t_tr  if |t_tr| <= mu p,   t = mu p t_tr / |t_tr|  otherwise

(the return map on its norm); 2-D is the special case P_T = T T^T, T = (N_y, -N_x), where
t_tr T = P_T (t_n - eps_T ds) and the clamp of the scalar is the same map.  The nodal rule puts its
points at the facet's vertices (4 on a hexahedron's quadrilateral facets, weights 1/4 of the
reference square; 3 on a tetrahedron's), the weight w is 1 and each node's tributary area is its
facet-area share int N_i dA0.  The history per node is (t_n (3), N_n (3), p_n), 7 components.
The 2-D forms are built by the unchanged 2-D code (same numbers to the bit).
"""
from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
import dolfinx.fem.petsc as fpetsc
from mpi4py import MPI
from petsc4py import PETSc

from fenics_plast import dolfinx_compat as dc
from fenics_plast.schema import PENALTY_FACTOR, choices, default
from fenics_plast.solvers.static_tool_contact import keep_committed_gaps, pair_nodes
from fenics_plast.tools import TINY, default_penalty

#: the friction laws: "coulomb" (p, N current), "quasi-coulomb" (p, N of the last commit)
LAWS = choices("contact.*.law")

#: nodal (trapezoidal) rule on facets: points at the facet's end points
NODAL_RULE = {"quadrature_degree": 1, "quadrature_rule": "custom",
              "quadrature_points": ((0.0,), (1.0,)), "quadrature_weights": (0.5, 0.5)}
#: nodal rules on the facets of 3-D cells: the facet's vertices (reference square [0, 1]^2 of a
#: hexahedron's facets, reference triangle of a tetrahedron's)
NODAL_RULE_QUADRILATERAL = {"quadrature_degree": 1, "quadrature_rule": "custom",
                            "quadrature_points": ((0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)),
                            "quadrature_weights": (0.25, 0.25, 0.25, 0.25)}
NODAL_RULE_TRIANGLE = {"quadrature_degree": 1, "quadrature_rule": "custom",
                       "quadrature_points": ((0.0, 0.0), (1.0, 0.0), (0.0, 1.0)),
                       "quadrature_weights": (1.0 / 6.0, 1.0 / 6.0, 1.0 / 6.0)}


def nodal_rule(mesh):
    """The ``ds`` metadata of the nodal rule on the facets of ``mesh``'s cells (points at the facet's
    vertices, weights summing to the reference facet's size)."""
    name = mesh.topology.cell_type.name
    if name in ("quadrilateral", "triangle", "interval"):
        return NODAL_RULE
    if name == "hexahedron":
        return NODAL_RULE_QUADRILATERAL
    if name == "tetrahedron":
        return NODAL_RULE_TRIANGLE
    raise ValueError(f"no nodal contact rule for {name} cells")


def _check_pair(tool, gdim, penalty, friction, law, tangential_penalty):
    """ValueError for a pair's argument out of range or a tool of another dimension than the body's."""
    if law not in LAWS:
        raise ValueError(f"contact law must be one of {LAWS}, got {law!r}")
    if not penalty > 0:
        raise ValueError(f"penalty must be > 0, got {penalty}")
    if not friction >= 0:
        raise ValueError(f"friction coefficient must be >= 0, got {friction}")
    if tangential_penalty is not None and not tangential_penalty > 0:
        raise ValueError(f"tangential penalty must be > 0, got {tangential_penalty}")
    if tool is not None and getattr(tool, "dim", 2) != gdim:
        raise ValueError(f"contact pair {tool.name!r}: a {getattr(tool, 'dim', 2)}-D tool on a {gdim}-D body")


# ----------------------------------------------------------------------------------------------
# contact pairs


class ContactPair:
    """One tool against the body facets tagged ``tag``, with its own normal penalty [N/mm^3],
    tangential penalty [N/mm^3], friction coefficient and law (UFL forms + nodal history): the definition
    of the compiled :class:`~fenics_plast.solvers.static_tool_contact.ToolContactTerm`.
    Made by :meth:`PenaltyContact.add_pair` / :meth:`PenaltyContact.add_tool` (which hold the defaults)."""

    def __init__(self, contact, tool, facet_tags, tag, *, penalty, friction, law, tangential_penalty=None):
        _check_pair(tool, contact.solver.kin.gdim, penalty, friction, law, tangential_penalty)
        self.contact = contact
        self.tool = tool
        self.tag = tag
        self.facet_tags = facet_tags
        s = contact.solver
        mesh = s.mesh
        c = contact
        self.penalty = float(penalty)
        self.tangential_penalty = float(tangential_penalty if tangential_penalty else penalty)
        self.friction = float(friction)
        self.law = law
        # as Constants in the forms: a new penalty value needs no new JIT compilation
        self.penalty_c = fem.Constant(mesh, PETSc.ScalarType(self.penalty))
        self.tangential_penalty_c = fem.Constant(mesh, PETSc.ScalarType(self.tangential_penalty))
        gdim = s.kin.gdim
        self.gdim = gdim
        self.ds = ufl.Measure("ds", domain=mesh, subdomain_data=facet_tags, metadata=nodal_rule(mesh))(tag)
        # history: [t_n (gdim), N_n (gdim), p_n] per node
        self.hist_size = 2 * gdim + 1
        self.H = dc.function_space(mesh, "Lagrange", 1, (self.hist_size,))
        self.hist = fem.Function(self.H, name=f"contact_history_{tool.name}")
        self.omega = self._nodal_weight(facet_tags, tag, c.weight)
        lam, lam_c = s.load, c.lam_c
        x = c.X + s.u
        g, N = tool.gap(x, lam) if getattr(tool, "has_ufl_gap", True) else self._nodal_gap(x)
        self.g, self.N = g, N
        self.p = ufl.conditional(ufl.lt(g, 0.0), -self.penalty_c * g, 0.0)
        w = self.omega
        v = s.v
        traction = self.p * N
        self.t_vec = None
        self.t_scalar = None
        if self.friction > 0.0 and gdim == 3:
            traction = traction + self._friction_3d(tool, N, g, lam, lam_c)
        elif self.friction > 0.0:
            h = self.hist
            t_n = ufl.as_vector([h[0], h[1]])
            d1, d0 = tool.translation(lam), tool.translation(lam_c)
            ds_rel = (s.u - c.u_c) - ufl.as_vector([d1[0] - d0[0], d1[1] - d0[1]])
            if self.law == "coulomb":
                Nf, bound, active = N, self.friction * self.p, 1.0
            else:
                Nf = ufl.as_vector([h[2], h[3]])
                bound = self.friction * h[4]
                active = ufl.conditional(ufl.lt(g, 0.0), 1.0, 0.0)
            T = ufl.as_vector([Nf[1], -Nf[0]])
            t_tr = ufl.dot(T, t_n) - self.tangential_penalty_c * ufl.dot(T, ds_rel)
            t = ufl.conditional(ufl.gt(t_tr, bound), bound,
                                ufl.conditional(ufl.lt(t_tr, -bound), -bound, t_tr))
            self.t_scalar = active * t
            self.t_vec = self.t_scalar * T
            self.t_trial = t_tr
            self.bound = bound
            traction = traction + self.t_vec
        self.traction = traction            # on the body, per reference area
        self.R = -ufl.dot(traction, v) * w * self.ds
        # commit: midpoint values -> DG0 history
        q = ufl.TestFunction(self.H)
        zero = ufl.as_ufl(0.0)
        tv = self.t_vec if self.t_vec is not None else ufl.as_vector([zero] * gdim)
        new = ufl.as_vector([tv[i] for i in range(gdim)] + [N[i] for i in range(gdim)] + [self.p])
        self._num = fem.form(ufl.inner(new, q) * self.ds)
        self._bnum = fpetsc.create_vector(self._num)
        den = fpetsc.assemble_vector(fem.form(ufl.inner(ufl.as_vector([1.0] * self.hist_size), q) * self.ds))
        den.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        arr = den.array
        arr[arr == 0.0] = 1.0
        self._den = den
        # nodal status [in contact, slipping] (diagnostics)
        incontact = ufl.conditional(ufl.lt(g, 0.0), 1.0, 0.0)
        if self.t_vec is not None and gdim == 3:
            slipping = incontact * ufl.conditional(ufl.gt(ufl.dot(self.t_trial, self.t_trial),
                                                          self.bound * self.bound), 1.0, 0.0)
        elif self.t_scalar is not None:
            slipping = incontact * ufl.conditional(ufl.gt(abs(self.t_trial), self.bound), 1.0, 0.0)
        else:
            slipping = incontact
        self.S = dc.function_space(mesh, "Lagrange", 1, (2,))
        qs = ufl.TestFunction(self.S)
        self._status = fem.form(ufl.inner(ufl.as_vector([incontact, slipping]), qs) * self.ds)
        self._status_den = fpetsc.assemble_vector(fem.form(ufl.inner(ufl.as_vector([1.0, 1.0]), qs) * self.ds))
        self._status_den.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        # post-processing forms
        self._force = [fem.form(traction[i] * w * self.ds) for i in range(gdim)]
        self._normal_force = fem.form(self.p * w * self.ds)
        if self.t_vec is not None and gdim == 3:
            self._tangential_force = [fem.form(self.t_vec[i] * w * self.ds) for i in range(3)]
        elif self.t_scalar is not None:
            self._tangential_force = fem.form(self.t_scalar * w * self.ds)

    def _friction_3d(self, tool, N, g, lam, lam_c):
        """The tangential traction vector t (UFL, on the body, per reference area [MPa]) of a 3-D
        pair: t_tr = P_T (t_n - eps_T ds), P_T = I - N_f N_f^T, returned to |t| <= mu p on its norm
        (see the module docstring).  Sets t_vec, t_trial (the trial vector) and bound."""
        s, c, h = self.contact.solver, self.contact, self.hist
        t_n = ufl.as_vector([h[0], h[1], h[2]])
        d1, d0 = tool.translation(lam), tool.translation(lam_c)
        ds_rel = (s.u - c.u_c) - ufl.as_vector([d1[i] - d0[i] for i in range(3)])
        if self.law == "coulomb":
            Nf, bound, active = N, self.friction * self.p, 1.0
        else:
            Nf = ufl.as_vector([h[3], h[4], h[5]])
            bound = self.friction * h[6]
            active = ufl.conditional(ufl.lt(g, 0.0), 1.0, 0.0)
        trial = t_n - self.tangential_penalty_c * ds_rel
        t_tr = trial - ufl.dot(Nf, trial) * Nf
        # slip where |t_tr| > bound (then |t_tr| > 0: the guard only keeps the unused branch finite)
        norm = ufl.sqrt(ufl.dot(t_tr, t_tr) + TINY)
        t = ufl.conditional(ufl.gt(ufl.dot(t_tr, t_tr), bound * bound), (bound / norm) * t_tr, t_tr)
        self.t_vec = active * t
        self.t_trial = t_tr
        self.bound = bound
        return self.t_vec

    def _nodal_weight(self, facet_tags, tag, weight):
        """CG1 Function: int N_i w dA0 (exact) / int N_i dA0 (nodal rule) at the pair's nodes."""
        mesh = self.contact.solver.mesh
        S = dc.function_space(mesh, "Lagrange", 1)
        q = ufl.TestFunction(S)
        exact = ufl.Measure("ds", domain=mesh, subdomain_data=facet_tags,
                            metadata={"quadrature_degree": 4})(tag)
        num = fpetsc.assemble_vector(fem.form(ufl.as_ufl(weight) * q * exact))
        den = fpetsc.assemble_vector(fem.form(q * self.ds))
        for b in (num, den):
            b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        d = den.array
        d[d == 0.0] = 1.0
        num.pointwiseDivide(num, den)
        om = fem.Function(S, name=f"contact_weight_{self.tool.name}")
        num.copy(dc.petsc_vec(om))
        om.x.scatter_forward()
        return om

    def commit(self):
        b = self._bnum
        with b.localForm() as bl:
            bl.set(0.0)
        fpetsc.assemble_vector(b, self._num)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        b.pointwiseDivide(b, self._den)
        b.copy(dc.petsc_vec(self.hist))
        self.hist.x.scatter_forward()

    def history(self):
        """(values, keys) of the committed history (t_n, N_n, p_n) at the owned nodes (checkpoints)."""
        from fenics_plast.checkpoint import dof_keys
        n = self.H.dofmap.index_map.size_local * self.hist_size
        return self.hist.x.array[:n].copy(), dof_keys(self.H)[:n]

    def load_history(self, values):
        """Restore :meth:`history`'s values."""
        self.hist.x.array[: len(values)] = values
        self.hist.x.scatter_forward()

    def status(self):
        """(nodes in contact, nodes slipping) at the current state, all ranks (frictionless: all slip)."""
        b = fpetsc.assemble_vector(self._status)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        den = self._status_den.array
        a = b.array.reshape(-1, 2)
        d = den.reshape(-1, 2)
        on = d[:, 0] > 0
        vals = np.rint(a[on] / d[on])
        local = vals.sum(axis=0) if len(vals) else np.zeros(2)
        tot = self.contact.comm.allreduce(local, op=MPI.SUM)
        return int(tot[0]), int(tot[1])

    def _sum(self, form):
        return self.contact.comm.allreduce(fem.assemble_scalar(form), op=MPI.SUM)

    def force(self):
        """Total contact force (r, z) exerted BY the tool ON the body [N] (2 pi r included); (x, y, z)
        in 3-D."""
        return np.array([self._sum(f) for f in self._force])

    def normal_force(self):
        """int p w dA0 [N]."""
        return self._sum(self._normal_force)

    def tangential_force(self):
        """int t_T w dA0 (signed, along T = (N_z, -N_r)) [N]; 0 without friction.  3-D: the vector
        int t w dA0 (3,) [N] of the tangential tractions (zeros without friction)."""
        if self.gdim == 3:
            if self.t_vec is None:
                return np.zeros(3)
            return np.array([self._sum(f) for f in self._tangential_force])
        if self.t_scalar is None:
            return 0.0
        return self._sum(self._tangential_force)

    def contact_nodes(self):
        """The pair's owned group nodes now, a :class:`~fenics_plast.solvers.contact_law.ContactNodes`
        (slipping or not is not told node by node on this route: every node in contact counts as stuck)."""
        from fenics_plast.solvers.body_surface import tributary_areas
        from fenics_plast.solvers.contact_law import ContactNodes
        s = self.contact.solver
        X, idx = self._owned_nodes()
        if not hasattr(self, "_areas"):
            Vc, _ = s.displacement_space()
            self._areas = tributary_areas(Vc, s.kin.weight, self.facet_tags, self.tag)[
                self._node_blocks * Vc.dofmap.index_map_bs]
        g = self.nodal_gaps()
        return ContactNodes(X + s.w.x.array[idx], g, self.penalty * np.maximum(-g, 0.0), self._areas,
                            self._node_blocks, np.zeros(len(g), dtype=bool))

    def nodal_gaps(self):
        """Gaps [mm] at the owned nodes of the pair's facets (current state), numpy (n,)."""
        s = self.contact.solver
        X, idx = self._owned_nodes()
        g, _ = self.tool.gap_np(X + s.w.x.array[idx], s.lam)
        return g

    def _nodal_gap(self, x):
        """(g, N) in UFL for a tool whose gap UFL cannot write (a meshed tool): its gap, normal and the
        normal's derivative at the pair's nodes (``tool.nodal_gap``), computed again whenever the solver's
        state changes (``solver.state_hooks``) and linearised about that state: g = g_k + N_k . (x - x_k),
        N = N_k + dN_k (x - x_k) (CG1 functions: the nodal rule evaluates them at the nodes, where they are
        g_k and N_k at the state itself; ``ufl.derivative`` then gives the exact Jacobian eps N N^T + p dN/dx,
        dN/dx being the normal's turn about a facet edge or vertex that the node's nearest point lies on)."""
        s = self.contact.solver
        Vc, _ = s.displacement_space()
        self._gap_k, self._normal_k, self._position_k = (fem.Function(Vc) for _ in range(3))
        T = dc.function_space(s.mesh, "Lagrange", 1, (self.gdim, self.gdim))
        self._turn_k = fem.Function(T)
        # the pair's owned nodes in T's numbering (the displacement space is a collapsed subspace: its own)
        X, _ = self._owned_nodes()
        blocks = fem.locate_dofs_topological(T, s.mesh.topology.dim - 1, self.facet_tags.find(self.tag))
        blocks = blocks[blocks < T.dofmap.index_map.size_local]
        XT = T.tabulate_dof_coordinates()[blocks, :self.gdim]
        mine, theirs = np.lexsort(X.T[::-1]), np.lexsort(XT.T[::-1])
        if len(X) != len(XT) or not np.array_equal(X[mine], XT[theirs]):
            raise RuntimeError(f"contact pair {self.tool.name!r}: the tensor space's nodes are not the pair's")
        self._turn_blocks = np.empty_like(blocks)
        self._turn_blocks[mine] = blocks[theirs]
        s.state_hooks.append(self._update_nodal_gap)
        self._update_nodal_gap()
        dx = x - self._position_k
        return self._gap_k[0] + ufl.dot(self._normal_k, dx), self._normal_k + ufl.dot(self._turn_k, dx)

    def _update_nodal_gap(self):
        """The nodal gaps, normals, their derivatives and the positions of :meth:`_nodal_gap` at the solver's
        current state."""
        s = self.contact.solver
        X, idx = self._owned_nodes()
        x = X + s.w.x.array[idx]
        g, N, dN = self.tool.nodal_gap(x, s.lam)
        blocks, d = self._node_blocks, self.gdim
        self._gap_k.x.array.reshape(-1, d)[blocks, 0] = g
        self._normal_k.x.array.reshape(-1, d)[blocks] = N
        self._position_k.x.array.reshape(-1, d)[blocks] = x
        self._turn_k.x.array.reshape(-1, d * d)[self._turn_blocks] = dN.reshape(-1, d * d)
        for f in (self._gap_k, self._normal_k, self._position_k, self._turn_k):
            f.x.scatter_forward()

    def _owned_nodes(self):
        """(reference positions (n, gdim) [mm], their displacement entries in the solver's w (n, gdim)) of
        the owned nodes of the pair's facets (:func:`pair_nodes`); built on first use."""
        if not hasattr(self, "_nodes"):
            X, idx, self._node_blocks = pair_nodes(self.contact.solver, self.facet_tags, self.tag, self.gdim)
            self._nodes = (X, idx)
        return self._nodes

    def keep_gaps(self, lam) -> None:
        """The contact predictor (:func:`keep_committed_gaps`)."""
        keep_committed_gaps(self.tool, self.contact, *self._owned_nodes(), lam)

    def max_penetration(self):
        """Largest -g over the pair's owned nodes, all ranks [mm] (0 if none penetrates)."""
        g = self.nodal_gaps()
        local = max(0.0, float(-g.min())) if g.size else 0.0
        return self.contact.comm.allreduce(local, op=MPI.MAX)


class PenaltyContact:
    """Penalty contact (+ friction) of a StaticSolver's body against rigid tools, one
    :class:`ContactPair` per (tool, facet group), each with its own penalty, friction and law.

    Usage::

        c = PenaltyContact(solver)
        c.add_pair(Profile(...), facet_tags, lower_tag, penalty=eps, friction=0.15)
        c.add_pair(Circle(...), facet_tags, upper_tag, penalty=eps2, law="coulomb")
        c.attach()          # adds residual + Jacobian terms to the solver (before solver.setup())
        solver.run(..., callback=lambda s: c.commit() or False)

    ``penalty``, ``friction``, ``law`` and ``tangential_penalty`` given here are the contact-wide
    values used by :meth:`add_tool` (``PenaltyContact(solver, eps, friction=0.15)`` then
    ``add_tool(Circle((0.0, -50.8), 50.8, path=...), facet_tags, lower_tag)``). Friction and law
    default to the schema's (:func:`fenics_plast.schema.default`). ``compiled``: the pairs are
    :class:`~fenics_plast.solvers.static_tool_contact.ToolContactTerm` (the solver's terms), else
    :class:`ContactPair` (forms): see the module docstring.
    """

    def __init__(self, solver, penalty=None, friction=default("contact.*.friction"), law=default("contact.*.law"),
                 tangential_penalty=None, compiled=True):
        if law not in LAWS:
            raise ValueError(f"contact law must be one of {LAWS}, got {law!r}")
        if penalty is not None and not penalty > 0:
            raise ValueError("penalty must be > 0")
        self.solver = solver
        self.comm = solver.comm
        mesh = solver.mesh
        self.penalty = None if penalty is None else float(penalty)
        self.tangential_penalty = None if penalty is None else \
            float(tangential_penalty if tangential_penalty else penalty)
        self.friction = float(friction)
        self.law = law
        kin = solver.kin
        self.weight = kin.weight
        self.X = ufl.SpatialCoordinate(mesh)
        # state at the last contact commit (own copy: the solver's w_n is already updated when
        # the run callback is called)
        self.w_c = fem.Function(solver.W, name="contact_state_n")
        self.w_c.x.array[:] = solver.w.x.array
        self.u_c = ufl.split(self.w_c)[0] if solver.mixed else self.w_c
        self.lam_c = fem.Constant(mesh, PETSc.ScalarType(solver.lam))
        self.compiled = bool(compiled)
        self.pairs: list = []
        self._attached = False

    def add_pair(self, tool, facet_tags, tag, *, penalty, friction=default("contact.*.friction"),
                 law=default("contact.*.law"), tangential_penalty=None):
        """Contact of ``tool`` with the facets tagged ``tag``: normal penalty [N/mm^3], Coulomb
        coefficient (0: no friction term), law ("coulomb" / "quasi-coulomb") and tangential
        penalty [N/mm^3] (None: the normal penalty).  Call before :meth:`attach`."""
        if self._attached:
            raise RuntimeError("add contact pairs before attach()")
        if self.compiled:
            from fenics_plast.solvers.static_tool_contact import ToolContactTerm
            _check_pair(tool, self.solver.kin.gdim, penalty, friction, law, tangential_penalty)
            pair = ToolContactTerm(self, tool, facet_tags, tag, penalty=penalty, friction=friction, law=law,
                                   tangential_penalty=tangential_penalty)
        else:
            pair = ContactPair(self, tool, facet_tags, tag, penalty=penalty, friction=friction, law=law,
                               tangential_penalty=tangential_penalty)
        self.pairs.append(pair)
        return pair

    def add_surface_pair(self, facet_tags, tag, master_tag, *, penalty, friction=default("contact.*.friction"),
                         law=default("contact.*.law"), tangential_penalty=None, two_pass, mirror_tags=(),
                         name=None):
        """Contact of the facets tagged ``tag`` with the body's own facets tagged ``master_tag`` (and back, with
        ``two_pass``): :func:`fenics_plast.solvers.static_surface_contact.surface_terms`, compiled whatever
        ``compiled``; ``mirror_tags`` the facet tags of the symmetry planes (and axis) the surfaces continue
        across. Returns the pair that reports (forces, status). Call before :meth:`attach`."""
        from fenics_plast.solvers.static_surface_contact import surface_terms
        if self._attached:
            raise RuntimeError("add contact pairs before attach()")
        _check_pair(None, None, penalty, friction, law, tangential_penalty)
        terms, pair = surface_terms(self, facet_tags, tag, master_tag, penalty=penalty, friction=friction, law=law,
                                    tangential_penalty=tangential_penalty, two_pass=two_pass,
                                    mirror_tags=mirror_tags, name=name)
        self.pairs.extend(terms)
        return pair

    def add_tool(self, tool, facet_tags, tag):
        """:meth:`add_pair` with the contact-wide penalty, friction, law and tangential penalty."""
        if self.penalty is None:
            raise ValueError("add_tool() needs the contact-wide penalty: PenaltyContact(solver, penalty, ...)")
        return self.add_pair(tool, facet_tags, tag, penalty=self.penalty, friction=self.friction,
                             law=self.law, tangential_penalty=self.tangential_penalty)

    def residual(self):
        """The UFL residual of the pairs assembled as forms (``compiled=False``), or None."""
        R = None
        for p in self.pairs:
            if isinstance(p, ContactPair):
                R = p.R if R is None else R + p.R
        return R

    def trial_function(self):
        """The solver's own trial Argument (a fresh ufl.TrialFunction(W) may differ in its repr on
        meshes from dolfinx.mesh.create_*, which UFL then refuses to combine)."""
        from ufl.algorithms.analysis import extract_arguments
        for a in extract_arguments(self.solver.J_int):
            if a.number() == 1:
                return a
        return ufl.TrialFunction(self.solver.W)

    def jacobian(self):
        R = self.residual()
        return ufl.derivative(R, self.solver.w, self.trial_function())

    def attach(self):
        """Add the contact residual and its consistent Jacobian to the solver: the compiled pairs as its
        terms, the forms' pairs as forms."""
        if self._attached:
            return
        self.solver.terms.extend(p for p in self.pairs if not isinstance(p, ContactPair))
        if any(isinstance(p, ContactPair) for p in self.pairs):
            self.solver.add_residual(self.residual(), self.jacobian())
        self.solver.predictors.append(self.keep_gaps)
        self._attached = True

    def keep_gaps(self, lam):
        """The solver's predictor hook: :meth:`ContactPair.keep_gaps` of every pair."""
        for p in self.pairs:
            p.keep_gaps(lam)

    def commit(self):
        """Store the history at the current (converged) state; call once per converged increment."""
        for p in self.pairs:
            p.commit()
        self.w_c.x.array[:] = self.solver.w.x.array
        self.lam_c.value = self.solver.lam

    # -- checkpoints (fenics_plast.checkpoint) -----------------------------------------------
    def state_dict(self):
        """The contact history at the last commit (collective; see fenics_plast.checkpoint): the owned
        entries of the state w_c and of each pair's nodal history (t_n, N_n, p_n) as ``hist<i>``,
        keyed by node/cell, and the load factor lam_c."""
        from fenics_plast.checkpoint import Keyed, owned_keyed
        d = dict(w_c=owned_keyed(self.w_c, self.solver.restart.keys()[0]), lam_c=float(self.lam_c.value))
        for i, p in enumerate(self.pairs):
            d[f"hist{i}"] = Keyed(*p.history())
        return d

    def load_state(self, d):
        """Restore :meth:`state_dict` (collective; same mesh and tools)."""
        from fenics_plast import checkpoint as ck
        ck.require(d, ["w_c", "lam_c"] + [f"hist{i}" for i in range(len(self.pairs))], "contact")
        dm = self.w_c.function_space.dofmap
        why, w_c, hists = None, None, []
        try:
            w_c = d["w_c"].take(self.solver.restart.keys()[0][: dm.index_map.size_local * dm.index_map_bs])
            hists = [d[f"hist{i}"].take(p.history()[1]) for i, p in enumerate(self.pairs)]
        except ck.CheckpointError as e:
            why = str(e)
        ck.raise_on_any(self.comm, why)
        self.w_c.x.array[: w_c.size] = w_c
        self.w_c.x.scatter_forward()
        self.lam_c.value = float(d["lam_c"])
        for p, h in zip(self.pairs, hists):
            p.load_history(h)

    # -- diagnostics -------------------------------------------------------------------------
    def nodal_gaps(self, pair):
        """Gaps [mm] at the owned nodes of ``pair``'s facets (current state), numpy (n,)."""
        return pair.nodal_gaps()

    def max_penetration(self):
        """Largest -g over the nodes of all pairs, all ranks [mm] (0 if none penetrates); collective."""
        return max([p.max_penetration() for p in self.pairs] or [0.0])


__all__ = ["ContactPair", "PenaltyContact", "default_penalty", "PENALTY_FACTOR", "LAWS", "NODAL_RULE",
           "nodal_rule"]
