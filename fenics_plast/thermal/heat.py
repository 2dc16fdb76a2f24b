r"""Transient heat conduction in the deforming body (issue 37): the temperature T [K] as a continuous
Q1 field on the body's mesh, a second unknown beside the displacement, advanced by one backward-Euler
step after each converged mechanical increment (a staggered, isothermal split: the mechanics of an
increment sees the temperature of the increment before, the heat step the converged deformation).

>>> heat = HeatConduction(kin, u, rho_c, conductivity, T0, [(spec, facets), ...], facet_tags)
>>> heat.advance(dt, plastic_heat)          # dt [s]; plastic_heat (owned points,) [mJ/mm^3]
>>> heat.T, heat.heat_balance()             # the field; the accumulated heats [mJ]

Written on the reference configuration X of the mesh for the current one x = X + u (F = I + Grad u,
J = det F, the 3x3 kinematics of :class:`fenics_plast.kinematics.Kinematics`; w = 2 pi R in
axisymmetry, 1 otherwise), for every test function v of the Q1 space:

    int rho_c (T - T_n) v w dX  +  dt int k J (F^-T Grad T) . (F^-T Grad v) w dX
        =  int q_p v w dX  +  sum_nodes q_f v  +  dt sum_groups int (a + b T) v J |F^-T N| w dS
           +  dt sum_tools int h chi (T_tool - T) v J |F^-T N| w dS

rho_c [mJ/(mm^3 K)]: density x specific heat per REFERENCE volume (the mass of a reference volume is
conserved); k [mW/(mm K)] (= W/(m K)); the conduction term is k grad_x T . grad_x v dv of the current
body; q_p [mJ/mm^3 per reference volume]: the heat the step's plastic work released
(:mod:`fenics_plast.thermal.plastic_heat`); a + b T [mW/mm^2]: the flux into the body of each
thermal boundary (:mod:`fenics_plast.thermal.boundaries`) over the current area, Nanson's
n da = J F^-T N dA; q_f [mJ]: the friction heat released at the contact nodes over the step; h
[mW/(mm^2 K)]: a tool contact's conductance, chi the Q1 indicator of the nodes in contact, T_tool the
tool's temperature. Prescribed temperatures are Dirichlet conditions. Backward Euler is first order
in time and unconditionally stable; Q1 second order in space (measured: tests/test_heat_conduction.py).
The linear system (symmetric positive definite) is solved by MUMPS LU, as the mechanics.

The heat balance is accumulated step by step: ``stored`` = int rho_c (T - T_0) w dX, ``plastic`` =
sum of int q_p w dX, ``friction`` = sum of q_f, and, per thermal boundary and tool contact, the heat in
through it: a flux boundary's
dt int (a + b T) da, a prescribed temperature's the heat equation's reaction on its nodes (the
residual of the unconstrained equations there). stored = plastic + friction + the boundaries' holds to
the linear solver's tolerance, by construction of the scheme (the test functions sum to 1).

Shapes: ``rho_c`` and ``conductivity`` are DG0 Functions (per cell); point arrays are the
:class:`fenics_plast.quadrature.QuadratureMap` layout (owned cells x nq).
"""
from __future__ import annotations

import time

import numpy as np
import ufl
from dolfinx import fem
import dolfinx.fem.petsc as fpetsc
from mpi4py import MPI
from petsc4py import PETSc

from fenics_plast import dolfinx_compat as dc
from fenics_plast.errors import RunError

__all__ = ["HeatConduction"]


class HeatConduction:
    """The temperature field of one body and its backward-Euler step (module docstring).

    kin : :class:`fenics_plast.kinematics.Kinematics` of the mesh (geometry, weight, quadrature).
    u : the displacement [mm] as UFL (the mechanical solver's; the current configuration).
    rho_c, conductivity : DG0 Functions [mJ/(mm^3 K)], [mW/(mm K)].
    initial_temperature : T at t = 0 [K], uniform.
    boundaries : [(name, ThermalBoundaryType, spec, tag)]: each thermal boundary, its type
        (:data:`fenics_plast.thermal.boundaries.TYPES`), its scene table and its facet tag.
    facet_tags : the mesh's facet tags.
    contacts : [(name, tag, h [mW/(mm^2 K)], T_tool [K])]: contact with a rigid isothermal tool over the facets
        tagged ``tag``, q = h chi (T_tool - T) into the body, chi (``in_contact[name]``, a Q1 Function the caller
        sets before each step) 1 at the nodes in contact (or less: a pressure-dependent conductance), 0 elsewhere.
    """

    def __init__(self, kin, u, rho_c, conductivity, initial_temperature: float, boundaries, facet_tags,
                 contacts=()):
        mesh = kin.mesh
        self.mesh, self.comm = mesh, mesh.comm
        self.V = dc.function_space(mesh, "Lagrange", 1)
        self.T = fem.Function(self.V, name="temperature")
        self.T_n = fem.Function(self.V, name="temperature_n")
        self.T_initial = float(initial_temperature)
        self.T.x.array[:] = self.T_initial
        self.T_n.x.array[:] = self.T_initial
        self.dt = fem.Constant(mesh, PETSc.ScalarType(0.0))
        self.plastic_heat = fem.Function(dc.quadrature_space(mesh, kin.degree, ()), name="plastic_heat")
        qdofs = np.asarray(dc.cell_dofs(self.plastic_heat.function_space))
        n_owned = mesh.topology.index_map(mesh.topology.dim).size_local
        self._qdofs = qdofs[:n_owned].reshape(-1)          # the owned points' entries, point order

        w, dx = kin.weight, kin.dx
        F = kin.F(u)
        J = ufl.det(F)
        Finv_T = ufl.inv(F).T
        self.dx, self.current_volume = dx, J * w      # dv = current_volume dx (reference measure)
        T, v = ufl.TrialFunction(self.V), ufl.TestFunction(self.V)

        def grad3(f):
            g = ufl.grad(f)
            return g if kin.three_d else ufl.as_vector([g[0], g[1], 0.0])

        def current(g):
            return ufl.dot(Finv_T, g)

        N = ufl.FacetNormal(mesh)
        N3 = N if kin.three_d else ufl.as_vector([N[0], N[1], 0.0])
        da = J * ufl.sqrt(ufl.dot(current(N3), current(N3))) * w       # current area per reference dS
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=facet_tags, metadata=kin.metadata)

        a = (rho_c * T * v * w * dx
             + self.dt * conductivity * J * ufl.dot(current(grad3(T)), current(grad3(v))) * w * dx)
        L = rho_c * self.T_n * v * w * dx + self.plastic_heat * v * w * dx
        self.names = []
        self.bcs, self._bc_dofs, self._flux_forms = [], {}, {}
        fdim = mesh.topology.dim - 1
        for name, kind, spec, tag in boundaries:
            self.names.append(name)
            facets = facet_tags.find(tag)
            if kind.dirichlet:
                dofs = fem.locate_dofs_topological(self.V, fdim, facets)
                self.bcs.append(fem.dirichletbc(PETSc.ScalarType(spec.temperature), dofs, self.V))
                owned = self.V.dofmap.index_map.size_local
                taken = np.concatenate([d for d in self._bc_dofs.values()] or [np.zeros(0, dtype=np.int32)])
                self._bc_dofs[name] = np.setdiff1d(dofs[dofs < owned], taken)   # a shared node: the first
                continue
            coefficient, slope = kind.flux_terms(spec, self.T_n)
            a = a - self.dt * slope * T * v * da * ds(tag)
            L = L + self.dt * coefficient * v * da * ds(tag)
            self._flux_forms[name] = fem.form(self.dt * (coefficient + slope * self.T) * da * ds(tag))
        self.in_contact = {}
        for name, tag, h, T_tool in contacts:
            self.names.append(name)
            chi = self.in_contact[name] = fem.Function(self.V, name=f"in_contact_{name}")
            a = a + self.dt * h * chi * T * v * da * ds(tag)
            L = L + self.dt * h * chi * T_tool * v * da * ds(tag)
            self._flux_forms[name] = fem.form(self.dt * h * chi * (T_tool - self.T) * da * ds(tag))
        self.a_form, self.L_form = fem.form(a), fem.form(L)
        self.residual_form = fem.form(ufl.action(a, self.T) - L)     # the equations' residual at T
        self.stored_form = fem.form(rho_c * (self.T - self.T_initial) * w * dx)
        self.rho_c = rho_c
        self._capacity_form = fem.form(rho_c * w * dx)
        self.update_capacity()
        self.plastic_form = fem.form(self.plastic_heat * w * dx)
        self.A = fpetsc.create_matrix(self.a_form)
        # (conductance links between two bodies add entries outside the forms' pattern: allowed)
        self.A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
        self.b = fpetsc.create_vector(self.L_form)
        self.r = fpetsc.create_vector(self.residual_form)
        self.ksp = PETSc.KSP().create(self.comm)
        self.ksp.setOperators(self.A)
        self.ksp.setType("preonly")
        pc = self.ksp.getPC()
        pc.setType("lu")
        pc.setFactorSolverType("mumps")
        self.heat = dict(plastic=0.0, friction=0.0, **{n: 0.0 for n in self.names})
        self._nodal = np.zeros(self.V.dofmap.index_map.size_local)
        self.last_rate = {n: 0.0 for n in self.names}     # each boundary's heat rate over the last step [mW]
        #: heat passed between two parts of the body through a conductance since t = 0, by pair [mJ] (the
        #: callers' account: inside the body, not in the balance), and its rate over the last step [mW]
        self.exchanged, self.exchange_rate = {}, {}
        self.steps = 0
        self.time = 0.0             # wall time in the steps (assembly, solve, the balance) [s]

    def constrained_global(self) -> np.ndarray:
        """The global dofs of :attr:`V` with a prescribed temperature, all ranks' (sorted; collective)."""
        imap = self.V.dofmap.index_map
        owned = np.unique(np.concatenate([dc.bc_dofs(bc) for bc in self.bcs] or [np.zeros(0, dtype=np.int32)]))
        owned = owned[owned < imap.size_local].astype(np.int32)
        mine = imap.local_to_global(owned).astype(np.int64)
        return np.unique(np.concatenate(self.comm.allgather(mine)))

    def close(self) -> None:
        """Free the PETSc objects now, on every rank at the same point (a replaced mesh's; collective)."""
        for obj in (self.ksp, self.A, self.b, self.r):
            obj.destroy()

    def update_capacity(self) -> None:
        """:attr:`capacity`, the body's heat capacity int rho_c dV [mJ/K], from :attr:`rho_c` as it stands
        (collective; after a change of rho_c: a remesh's carried one)."""
        self.capacity = self.comm.allreduce(fem.assemble_scalar(self._capacity_form), op=MPI.SUM)

    # -- the step --------------------------------------------------------------------------------
    def advance(self, dt: float, plastic_heat: np.ndarray | None = None, friction_heat: np.ndarray | None = None,
                links=None) -> None:
        """One backward-Euler step of ``dt`` [s] from the present T, the deformation as it stands,
        with ``plastic_heat`` (owned points,) [mJ/mm^3 per reference volume] and ``friction_heat`` (owned
        dofs of :attr:`V`,) [mJ] at the nodes released over the step (None: none); ``links``: (rows (m, r)
        global dofs, -1 left out; G (m, r, r) [mW/K]) conductances between dofs (two bodies in contact,
        :class:`fenics_plast.thermal.body_conductance.BodyConductance`), dt G added to the matrix. Collective."""
        start = time.perf_counter()
        self.T_n.x.array[:] = self.T.x.array
        self.dt.value = float(dt)
        q = self.plastic_heat.x.array
        q[:] = 0.0
        if plastic_heat is not None:
            q[self._qdofs] = plastic_heat
        self.plastic_heat.x.scatter_forward()
        self.A.zeroEntries()
        fpetsc.assemble_matrix(self.A, self.a_form, bcs=self.bcs)
        self.A.assemble()
        if links is not None:
            rows, G = links
            if len(rows):
                rows = np.ascontiguousarray(rows, dtype=PETSc.IntType)
                self.A.setValuesRCV(rows, rows, np.ascontiguousarray(float(dt) * G), addv=PETSc.InsertMode.ADD)
            self.A.assemble()
        with self.b.localForm() as loc:
            loc.set(0.0)
        fpetsc.assemble_vector(self.b, self.L_form)
        self._nodal[:] = 0.0 if friction_heat is None else friction_heat
        with self.b.localForm() as loc:
            loc.array[:len(self._nodal)] += self._nodal
        dc.apply_lifting(self.b, [self.a_form], [self.bcs])
        self.b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        fpetsc.set_bc(self.b, self.bcs)
        x = dc.petsc_vec(self.T)
        self.ksp.solve(self.b, x)
        self.T.x.scatter_forward()
        failed = self.ksp.getConvergedReason() < 0 or not np.isfinite(self.T.x.array).all()
        if self.comm.allreduce(failed, op=MPI.LOR):
            raise RunError(f"heat conduction: the heat step of {dt:.4g} s failed (KSP reason "
                           f"{self.ksp.getConvergedReason()}, or a temperature that is not finite): check the "
                           f"materials' conductivity and specific_heat and the thermal boundaries' values")
        self._account()
        self.steps += 1
        self.time += time.perf_counter() - start

    def _account(self) -> None:
        """Add the step's heats to :attr:`heat` (collective)."""
        def total(form):
            return self.comm.allreduce(fem.assemble_scalar(form), op=MPI.SUM)
        self.heat["plastic"] += total(self.plastic_form)
        self.heat["friction"] += self.comm.allreduce(float(self._nodal.sum()), op=MPI.SUM)
        dt = float(self.dt.value)
        for name, form in self._flux_forms.items():
            q = total(form)
            self.heat[name] += q
            self.last_rate[name] = q / dt if dt > 0.0 else 0.0
        if self._bc_dofs:
            with self.r.localForm() as loc:
                loc.set(0.0)
            fpetsc.assemble_vector(self.r, self.residual_form)
            with self.r.localForm() as loc:
                loc.array[:len(self._nodal)] -= self._nodal
            self.r.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            r = self.r.getArray(readonly=True)
            for name, dofs in self._bc_dofs.items():
                q = self.comm.allreduce(float(r[dofs].sum()), op=MPI.SUM)
                self.heat[name] += q
                self.last_rate[name] = q / dt if dt > 0.0 else 0.0

    # -- what it reports -------------------------------------------------------------------------
    def heat_balance(self) -> dict:
        """The heats since t = 0 [mJ]: ``stored`` (int rho_c (T - T_0) dV), ``plastic``, ``friction`` (the
        share of the friction's dissipation released in the body), each thermal boundary's and tool
        contact's (by name, into the body), ``boundaries`` (their sum) and ``balance_error`` = |stored -
        plastic - friction - boundaries| over the largest of them, 0 while they are all below the heat of
        1e-9 K over the body (collective)."""
        stored = self.comm.allreduce(fem.assemble_scalar(self.stored_form), op=MPI.SUM)
        out = dict(stored=stored, **self.heat)
        out["boundaries"] = sum(self.heat[n] for n in self.names)
        sources = out["plastic"] + out["friction"] + out["boundaries"]
        scale = max(abs(stored), abs(out["plastic"]), abs(out["friction"]), abs(out["boundaries"]))
        # (no heat yet: what round-off leaves of 0, against the heat of 1e-9 K over the body, is no error)
        out["balance_error"] = abs(stored - sources) / scale if scale > 1e-9 * self.capacity else 0.0
        return out

    # -- restart -----------------------------------------------------------------------------------
    def state_dict(self, keys) -> dict:
        """What a resumed run needs (collective): T's owned values keyed by ``keys`` (the checkpoint's
        dof keys of :attr:`V`), rho_c's keyed by cell (a remesh carries it) and the accumulated heats."""
        from fenics_plast.checkpoint import owned_keyed
        return dict(temperature=owned_keyed(self.T, keys), rho_c=owned_keyed(self.rho_c), heat=dict(self.heat),
                    exchanged=dict(self.exchanged), heat_steps=self.steps)

    def load_state(self, d, keys) -> None:
        """Restore :meth:`state_dict`'s values, matched to this mesh's numbering by ``keys`` (the dof keys
        of :attr:`V`; collective: CheckpointError on every rank when the checkpoint is of another mesh)."""
        from fenics_plast import checkpoint as ck
        n = self.V.dofmap.index_map.size_local
        cells = self.rho_c.function_space.dofmap.index_map.size_local
        why, values, rho_c = None, None, None
        try:
            values = d["temperature"].take(keys[:n])
            rho_c = d["rho_c"].take(ck.dof_keys(self.rho_c.function_space)[:cells])
        except ck.CheckpointError as e:
            why = str(e)
        ck.raise_on_any(self.comm, why)
        ck.set_owned(self.T, values)
        ck.set_owned(self.rho_c, rho_c)
        self.update_capacity()
        self.T_n.x.array[:] = self.T.x.array
        self.heat.update(d["heat"])
        self.exchanged.update(d["exchanged"])
        self.steps = int(d["heat_steps"])
