"""The energies of a static run, kept increment by increment (issue 35: the energy balance of a
remeshed run). Units: N mm (the ``energy`` outputs write J).

After every converged increment (:meth:`StaticEnergy.update`), by the trapezoidal rule over the
increment, with forces at its two ends on the same mesh:

* ``internal_work`` W_int = sum R_u . dw over the body's dofs (R_u the assembled internal force, w
  the solver's unknowns: displacement and, q1p0, the dilatation, whose equation is satisfied);
* ``tool_work`` = sum over the pairs with a rigid tool of F . dd (F the force of the tool on the
  body, d its translation); ``boundary_work`` = sum R_u . dw over the Dirichlet dofs (a prescribed
  displacement's reaction; zero where a support holds); ``external_work`` = their sum;
* ``contact_work`` W_c = - sum f . (du - dd) over the pairs' nodes (f the nodal contact force, u the
  node's displacement, d its tool's translation): friction dissipation plus the penalty's stored
  energy, >= 0;
* ``elastic`` = sum over the points of psi(b_e^-1) dv / J_e (psi per stress-free volume, dv the
  point's current volume, J_e = det(b_e^-1)^(-1/2)); ``plastic`` = W_int - elastic;
* ``balance_error`` = |W_int + W_c - W_ext| / |W_ext|.

Within an increment the balance closes to the Newton tolerance (R_u = the contact and reaction forces
at equilibrium). A remesh (:meth:`StaticEnergy.remeshed`) changes the elastic energy (the transferred
stress is not the old one) at the same load: W_int takes that change, so the plastic dissipation goes
on from its value and the change shows in ``balance_error`` as the remesh's error (what the
re-equilibration moves is counted so too). Scenes with tractions or pressure loads, or contact between
two groups of the body, are refused by the ``energy`` output (their work is not counted here).
"""
from __future__ import annotations

import numpy as np
from mpi4py import MPI

from fenics_plast.thermal.plastic_heat import flow_stress_integral

__all__ = ["StaticEnergy"]


class StaticEnergy:
    """The energies of a static run on its current solver (``b``: :func:`fenics_plast.runner_static.build_static`'s
    namespace: solver, pairs, tools, material); ``axisymmetric``: volumes of revolution."""

    def __init__(self, b, axisymmetric: bool):
        self.axisymmetric = axisymmetric
        self.W_int = self.W_tool = self.W_bc = self.W_c = 0.0
        self._attach(b)

    # -- the state at the last update ------------------------------------------------------------
    def _attach(self, b):
        self.b = b
        s = b.solver
        self.n_owned = s.W.dofmap.index_map.size_local * s.W.dofmap.index_map_bs
        from fenics_plast import dolfinx_compat as dc
        constrained = np.zeros(len(s.w.x.array), dtype=bool)
        for bc in s.bcs:
            constrained[dc.bc_dofs(bc)] = True
        self.constrained = constrained[: self.n_owned]
        self._snapshot()

    def _pairs(self):
        """The pairs with a rigid tool and nodal forces (``hist``: the compiled tool route)."""
        return [(n, p) for n, p in self.b.pairs.items() if hasattr(p, "hist") and p.tool is not None]

    def _snapshot(self):
        s = self.b.solver
        self.f = np.array(s.internal_force()[: self.n_owned])
        self.w = np.array(s.w.x.array[: self.n_owned])
        self.tools = {}
        for n, p in self._pairs():
            p.evaluate()
            self.tools[n] = (np.asarray(p.force(), dtype=float), p._translation(s.lam), p.f.copy(),
                             s.w.x.array[p.idx].copy())

    def resumed(self):
        """The solver's state was set from a checkpoint (and the accumulators by the caller): the next
        increment's work counts from here. The stresses of the loaded state are computed first (a
        checkpoint holds b_e^-1 and eqps, not tau; the internal force needs tau)."""
        self.b.solver.qmap.update(tangent=False)
        self._snapshot()

    def update(self):
        """Add the work of the increment since the last update (collective)."""
        s, comm = self.b.solver, self.b.solver.comm
        f_old, w_old, tools_old = self.f, self.w, self.tools
        self._snapshot()
        dw = self.w - w_old
        mid = 0.5 * (self.f + f_old)
        local = np.array([float(mid @ dw), float(mid[self.constrained] @ dw[self.constrained]), 0.0])
        for n, (F, d, f, u) in self.tools.items():
            F0, d0, f0, u0 = tools_old[n]
            self.W_tool += float(0.5 * (F + F0) @ (d - d0))                   # (already summed over ranks)
            local[2] -= float(np.sum(0.5 * (f + f0) * ((u - u0) - (d - d0))))
        w_int, w_bc, w_c = comm.allreduce(local, op=MPI.SUM) if comm.size > 1 else local
        self.W_int += w_int
        self.W_bc += w_bc
        self.W_c += w_c
        return s

    def remeshed(self, b_new, elastic_old: float):
        """Go on with the new mesh's solver ``b_new`` (at equilibrium at the remesh load); the internal
        work takes the change of elastic energy from ``elastic_old`` [N mm] (before the remesh)."""
        self._attach(b_new)
        self.W_int += self.elastic() - elastic_old

    # -- reports ---------------------------------------------------------------------------------
    def _point_volumes(self):
        """(b_e^-1 (points, 3, 3), stress-free volumes dV0 (points,) [mm^3]) of the owned points now."""
        from fenics_plast.remeshing.quality import deformed_nodes
        from fenics_plast.remeshing.transfer import point_volumes
        s = self.b.solver
        binv = s.qmap.state()["binv"].reshape(-1, 3, 3)
        return binv, point_volumes(s.mesh, s.qmap.degree, self.axisymmetric, binv,
                                   deformed_nodes(s.displacement_function()))[1]

    def elastic(self) -> float:
        """Stored elastic energy [N mm] of the body now (collective)."""
        binv, dV0 = self._point_volumes()
        return self.b.solver.comm.allreduce(float(np.sum(self.b.material.energy(binv) * dV0)), op=MPI.SUM)

    def plastic_from_state(self) -> float | None:
        """The plastic dissipation [N mm] the state's eqps implies: sum over the points of dV0 times the
        integral of the flow stress from 0 to eqps (``thermal.plastic_heat.flow_stress_integral``; dV0 = dv / J_e, the point's
        stress-free volume), for one rate- and temperature-independent hardening law (None otherwise;
        collective). Independent of :meth:`energies`' plastic term (internal work minus elastic energy):
        the two agree where the flow stress is the Kirchhoff one of the isochoric model and remeshing
        keeps eqps (each transfer smooths eqps, which shows as a difference)."""
        s = self.b.solver
        h = getattr(self.b.material, "hardening", None)
        if h is None or h.thermal or h.law == "johnson_cook":
            return None
        eqps = np.asarray(s.qmap.state()["eqps"]).reshape(-1)
        _, dV0 = self._point_volumes()
        integral = flow_stress_integral(h, np.zeros_like(eqps), eqps)
        return s.comm.allreduce(float(np.sum(integral * dV0)), op=MPI.SUM)

    def energies(self) -> dict:
        """The energies [N mm] and the relative balance error, named as the explicit solver names them
        (kinetic 0; collective)."""
        el = self.elastic()
        w_ext = self.W_tool + self.W_bc
        err = abs(self.W_int + self.W_c - w_ext) / (abs(w_ext) if w_ext != 0.0 else 1.0)
        return dict(kinetic=0.0, elastic=el, internal_work=self.W_int, plastic=self.W_int - el, external_work=w_ext,
                    tool_work=self.W_tool, boundary_work=self.W_bc, contact_work=self.W_c, balance_error=err)
