"""Frictional penalty contact of the deformable body against analytic rigid tools (seed eqs. 16-25).

Tools are rigid bodies that only translate, with a position given as a function of the solver's
load factor (the ``fem.Constant`` ``solver.load``).  For every tool the gap ``g`` and the outward
normal ``N`` (pointing from the tool into the body) are exact UFL expressions of the current
position ``x = X + u`` of the body's candidate facets:

* :class:`SphericalPunch`: sphere (circle in the r-z plane) of radius R centred on the axis,
  tangent to z = ``z_pole`` at load 0, moving up by ``travel * lam``;
* :class:`CircularTool` (the die shoulder): a fixed circle (a torus in axisymmetry);
* :class:`FlatWall`: a plane through ``point`` with normal ``normal`` (into the body), moving along a
  piecewise-linear path of the load factor (tests).

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

History (t_n, N_n, p_n) therefore lives at the nodes: a CG1 Function with 5 components per tool.
``commit()`` (call it after every converged increment, e.g. from the solver's run callback) stores
the values by assembling ``int value q ds / int q ds`` with the same nodal rule and a CG1 test
function q, which gives exactly the nodal values (both facets of a node see the same value).
A cut-back needs nothing: the history only changes in ``commit()``.

Normal and friction terms share the rule, so at every contact node, and therefore in total, the
tangential force equals mu times the normal force when slipping.  mu = 0 assembles no friction
term at all.
"""
from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
import dolfinx.fem.petsc as fpetsc
from mpi4py import MPI
from petsc4py import PETSc

LAWS = ("coulomb", "quasi-coulomb")

#: nodal (trapezoidal) rule on facets: points at the facet's end points
NODAL_RULE = {"quadrature_degree": 1, "quadrature_rule": "custom",
              "quadrature_points": ((0.0,), (1.0,)), "quadrature_weights": (0.5, 0.5)}

#: default normal penalty = PENALTY_FACTOR * E / thickness (chosen by measurement, see
#: tests/test_contact.py: penetration < 1 % of the thickness, force change < 1 % for x10)
PENALTY_FACTOR = 0.3


def default_penalty(E, thickness, factor=PENALTY_FACTOR):
    """Normal penalty eps = factor * E / t [N/mm^3]."""
    return factor * E / thickness


# ----------------------------------------------------------------------------------------------
# piecewise-linear functions of the load factor, in UFL (lam a Constant) or numpy (lam a float)


def _piecewise(lam, knots, values, use_ufl):
    """Piecewise-linear interpolation through (knots, values), constant outside."""
    knots = [float(k) for k in knots]
    values = [float(v) for v in values]
    if len(knots) == 1:
        return values[0] if not use_ufl else ufl.as_ufl(values[0])
    if not use_ufl:
        return float(np.interp(float(lam), knots, values))
    out = ufl.as_ufl(values[0])
    for k in range(len(knots) - 1):
        a, b = knots[k], knots[k + 1]
        slope = (values[k + 1] - values[k]) / (b - a)
        if slope != 0.0:
            out = out + slope * ufl.min_value(ufl.max_value(lam - a, 0.0), b - a)
    return out


# ----------------------------------------------------------------------------------------------
# tools


class Tool:
    """A rigid tool that translates. Subclasses give the gap and the normal.

    ``translation(lam, use_ufl)`` is the tool's displacement at load factor lam (2-vector).
    ``gap(x, lam)`` -> (g, N) in UFL; ``gap_np(x, lam)`` -> (g (n,), N (n,2)) in numpy.
    """

    name = "tool"

    def translation(self, lam, use_ufl=True):
        z = ufl.as_ufl(0.0) if use_ufl else 0.0
        return (z, z) if use_ufl else np.zeros(2)

    def gap(self, x, lam):
        raise NotImplementedError

    def gap_np(self, x, lam):
        raise NotImplementedError


class CircularTool(Tool):
    """Circle of radius ``radius`` centred at ``center`` + translation (the body lies outside)."""

    name = "circle"

    def __init__(self, radius, center, name=None):
        self.radius = float(radius)
        self.center0 = np.asarray(center, dtype=float)
        if name:
            self.name = name

    def center(self, lam, use_ufl=True):
        d = self.translation(lam, use_ufl)
        if use_ufl:
            return ufl.as_vector([self.center0[0] + d[0], self.center0[1] + d[1]])
        return self.center0 + d

    def gap(self, x, lam):
        c = self.center(lam)
        dx = x - c
        dist = ufl.sqrt(ufl.dot(dx, dx))
        return dist - self.radius, dx / dist

    def gap_np(self, x, lam):
        dx = np.asarray(x)[:, :2] - self.center(lam, use_ufl=False)
        dist = np.linalg.norm(dx, axis=1)
        return dist - self.radius, dx / dist[:, None]


class SphericalPunch(CircularTool):
    """Hemispherical punch of radius R on the axis, its pole at z = ``z_pole`` + travel * lam."""

    name = "punch"

    def __init__(self, radius, travel, z_pole=0.0):
        super().__init__(radius, (0.0, z_pole - radius))
        self.travel = float(travel)

    def translation(self, lam, use_ufl=True):
        if use_ufl:
            return (ufl.as_ufl(0.0), self.travel * lam)
        return np.array([0.0, self.travel * float(lam)])


class DieShoulder(CircularTool):
    """Fixed die shoulder: circle of radius ``radius`` centred at (r_c, z_c)."""

    name = "die"

    def __init__(self, radius, r_center, z_center):
        super().__init__(radius, (r_center, z_center))


class FlatWall(Tool):
    """Plane through ``point`` (+ translation) with unit ``normal`` pointing into the body.

    ``path``: knots [(lam, dx, dy), ...] of a piecewise-linear translation (default: fixed).
    """

    name = "wall"

    def __init__(self, point=(0.0, 0.0), normal=(0.0, 1.0), path=None, name=None):
        self.point = np.asarray(point, dtype=float)
        n = np.asarray(normal, dtype=float)
        self.normal = n / np.linalg.norm(n)
        self.path = [(0.0, 0.0, 0.0)] if not path else [tuple(map(float, k)) for k in path]
        if name:
            self.name = name

    def translation(self, lam, use_ufl=True):
        knots = [k[0] for k in self.path]
        d = [_piecewise(lam, knots, [k[i] for k in self.path], use_ufl) for i in (1, 2)]
        return tuple(d) if use_ufl else np.array(d)

    def gap(self, x, lam):
        d = self.translation(lam)
        p = ufl.as_vector([self.point[0] + d[0], self.point[1] + d[1]])
        N = ufl.as_vector([float(self.normal[0]), float(self.normal[1])])
        return ufl.dot(x - p, N), N

    def gap_np(self, x, lam):
        p = self.point + self.translation(lam, use_ufl=False)
        g = (np.asarray(x)[:, :2] - p) @ self.normal
        return g, np.tile(self.normal, (len(g), 1))


# ----------------------------------------------------------------------------------------------
# contact pairs


class ContactPair:
    """One tool against the body facets tagged ``tag`` (UFL forms + midpoint history)."""

    def __init__(self, contact, tool, facet_tags, tag):
        self.contact = contact
        self.tool = tool
        self.tag = tag
        self.facet_tags = facet_tags
        s = contact.solver
        mesh = s.mesh
        c = contact
        self.ds = ufl.Measure("ds", domain=mesh, subdomain_data=facet_tags, metadata=NODAL_RULE)(tag)
        # history: [t_n (2), N_n (2), p_n] per node
        cell = mesh.ufl_cell()
        self.H = fem.FunctionSpace(mesh, ufl.VectorElement("Lagrange", cell, 1, dim=5))
        self.hist = fem.Function(self.H, name=f"contact_history_{tool.name}")
        self.omega = self._nodal_weight(facet_tags, tag, c.weight)
        lam, lam_c = s.load, c.lam_c
        x = c.X + s.u
        g, N = tool.gap(x, lam)
        self.g, self.N = g, N
        self.p = ufl.conditional(ufl.lt(g, 0.0), -c.penalty_c * g, 0.0)
        w = self.omega
        v = s.v
        traction = self.p * N
        self.t_vec = None
        self.t_scalar = None
        if c.friction > 0.0:
            h = self.hist
            t_n = ufl.as_vector([h[0], h[1]])
            d1, d0 = tool.translation(lam), tool.translation(lam_c)
            ds_rel = (s.u - c.u_c) - ufl.as_vector([d1[0] - d0[0], d1[1] - d0[1]])
            if c.law == "coulomb":
                Nf, bound, active = N, c.friction * self.p, 1.0
            else:
                Nf = ufl.as_vector([h[2], h[3]])
                bound = c.friction * h[4]
                active = ufl.conditional(ufl.lt(g, 0.0), 1.0, 0.0)
            T = ufl.as_vector([Nf[1], -Nf[0]])
            t_tr = ufl.dot(T, t_n) - c.tangential_penalty_c * ufl.dot(T, ds_rel)
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
        tv = self.t_vec if self.t_vec is not None else ufl.as_vector([zero, zero])
        new = ufl.as_vector([tv[0], tv[1], N[0], N[1], self.p])
        self._num = fem.form(ufl.inner(new, q) * self.ds)
        self._bnum = fpetsc.create_vector(self._num)
        den = fpetsc.assemble_vector(fem.form(ufl.inner(ufl.as_vector([1.0] * 5), q) * self.ds))
        den.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        arr = den.array
        arr[arr == 0.0] = 1.0
        self._den = den
        # nodal status [in contact, slipping] (diagnostics)
        incontact = ufl.conditional(ufl.lt(g, 0.0), 1.0, 0.0)
        if self.t_scalar is not None:
            slipping = incontact * ufl.conditional(ufl.gt(abs(self.t_trial), self.bound), 1.0, 0.0)
        else:
            slipping = incontact
        self.S = fem.FunctionSpace(mesh, ufl.VectorElement("Lagrange", cell, 1, dim=2))
        qs = ufl.TestFunction(self.S)
        self._status = fem.form(ufl.inner(ufl.as_vector([incontact, slipping]), qs) * self.ds)
        self._status_den = fpetsc.assemble_vector(fem.form(ufl.inner(ufl.as_vector([1.0, 1.0]), qs) * self.ds))
        self._status_den.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        # post-processing forms
        self._force = [fem.form(traction[i] * w * self.ds) for i in range(2)]
        self._normal_force = fem.form(self.p * w * self.ds)
        if self.t_scalar is not None:
            self._tangential_force = fem.form(self.t_scalar * w * self.ds)

    def _nodal_weight(self, facet_tags, tag, weight):
        """CG1 Function: int N_i w dA0 (exact) / int N_i dA0 (nodal rule) at the pair's nodes."""
        mesh = self.contact.solver.mesh
        S = fem.FunctionSpace(mesh, ("Lagrange", 1))
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
        num.copy(om.vector)
        om.x.scatter_forward()
        return om

    def commit(self):
        b = self._bnum
        with b.localForm() as bl:
            bl.set(0.0)
        fpetsc.assemble_vector(b, self._num)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        b.pointwiseDivide(b, self._den)
        b.copy(self.hist.vector)
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
        """Total contact force (r, z) exerted BY the tool ON the body [N] (2 pi r included)."""
        return np.array([self._sum(f) for f in self._force])

    def normal_force(self):
        """int p w dA0 [N]."""
        return self._sum(self._normal_force)

    def tangential_force(self):
        """int t_T w dA0 (signed, along T = (N_z, -N_r)) [N]; 0 without friction."""
        if self.t_scalar is None:
            return 0.0
        return self._sum(self._tangential_force)


class PenaltyContact:
    """Penalty contact (+ friction) of a StaticSolver's body against rigid tools.

    Usage::

        c = PenaltyContact(solver, penalty=eps, friction=0.15, law="quasi-coulomb")
        c.add_tool(SphericalPunch(50.8, 40.0), facet_tags, lower_tag)
        c.attach()          # adds residual + Jacobian terms to the solver (before solver.setup())
        solver.run(..., callback=lambda s: c.commit() or False)
    """

    def __init__(self, solver, penalty, friction=0.0, law="quasi-coulomb", tangential_penalty=None):
        if law not in LAWS:
            raise ValueError(f"contact law must be one of {LAWS}, got {law!r}")
        if penalty <= 0:
            raise ValueError("penalty must be > 0")
        self.solver = solver
        self.comm = solver.comm
        mesh = solver.mesh
        self.penalty = float(penalty)
        self.tangential_penalty = float(tangential_penalty if tangential_penalty else penalty)
        # as Constants in the forms: a new penalty value needs no new JIT compilation
        self.penalty_c = fem.Constant(mesh, PETSc.ScalarType(self.penalty))
        self.tangential_penalty_c = fem.Constant(mesh, PETSc.ScalarType(self.tangential_penalty))
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
        self.pairs: list[ContactPair] = []
        self._attached = False

    def add_tool(self, tool, facet_tags, tag):
        pair = ContactPair(self, tool, facet_tags, tag)
        self.pairs.append(pair)
        return pair

    def residual(self):
        R = None
        for p in self.pairs:
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
        """Add the contact residual and its consistent Jacobian to the solver."""
        if self._attached:
            return
        self.solver.add_residual(self.residual(), self.jacobian())
        self._attached = True

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
        from fenics_plast.checkpoint import owned_keyed
        d = dict(w_c=owned_keyed(self.w_c, self.solver._checkpoint_keys()[0]), lam_c=float(self.lam_c.value))
        for i, p in enumerate(self.pairs):
            d[f"hist{i}"] = owned_keyed(p.hist)
        return d

    def load_state(self, d):
        """Restore :meth:`state_dict` (collective; same mesh and tools)."""
        from fenics_plast import checkpoint as ck
        ck.require(d, ["w_c", "lam_c"] + [f"hist{i}" for i in range(len(self.pairs))], "contact")
        funs = [(self.w_c, d["w_c"], self.solver._checkpoint_keys()[0])]
        funs += [(p.hist, d[f"hist{i}"], ck.dof_keys(p.hist.function_space)) for i, p in enumerate(self.pairs)]
        why, vals = None, []
        try:
            for fun, table, keys in funs:
                dm = fun.function_space.dofmap
                vals.append(table.take(keys[: dm.index_map.size_local * dm.index_map_bs]))
        except ck.CheckpointError as e:
            why = str(e)
        ck.raise_on_any(self.comm, why)
        for (fun, _, _), v in zip(funs, vals):
            fun.x.array[: v.size] = v
            fun.x.scatter_forward()
        self.lam_c.value = float(d["lam_c"])

    # -- diagnostics -------------------------------------------------------------------------
    def nodal_gaps(self, pair):
        """Gaps at the owned nodes of the pair's facets (current state), numpy (n,)."""
        s = self.solver
        if not hasattr(pair, "_nodes"):
            V = s.V
            Vc, vmap = V.collapse()
            fdim = s.mesh.topology.dim - 1
            facets = pair.facet_tags.find(pair.tag)
            blocks = fem.locate_dofs_topological(Vc, fdim, facets)
            n_owned = Vc.dofmap.index_map.size_local
            blocks = blocks[blocks < n_owned]
            X = Vc.tabulate_dof_coordinates()[blocks, :2]
            vmap = np.asarray(vmap).reshape(-1, 2)
            pair._nodes = (X, vmap[blocks])
        X, idx = pair._nodes
        x = X + s.w.x.array[idx]
        g, _ = pair.tool.gap_np(x, s.lam)
        return g

    def max_penetration(self):
        """Largest -g over the owned nodes of all pairs, all ranks [mm] (0 if none penetrates)."""
        local = 0.0
        for p in self.pairs:
            g = self.nodal_gaps(p)
            if g.size:
                local = max(local, float(-g.min()))
        return self.comm.allreduce(local, op=MPI.MAX)


__all__ = ["Tool", "CircularTool", "SphericalPunch", "DieShoulder", "FlatWall", "ContactPair",
           "PenaltyContact", "default_penalty", "PENALTY_FACTOR", "LAWS"]
