"""Explicit central-difference dynamics with a lumped mass (Taylor bar impact and friends).

Scheme (central differences written in velocity-Verlet form, which allows a variable step; with
prescribed motion, loads and contact see :mod:`fenics_plast.solvers.integrator`):

    a_n       = -M^-1 f_int(u_n)                 (a = 0 on velocity-constrained dofs)
    v_{n+1/2} = v_n + dt/2 a_n
    u_{n+1}   = u_n + dt v_{n+1/2}
    theta_{n+1} = int_cell J w dV / int_cell w dV   (Q1/P0 dilatation, DG0; q1: none)
    material update from the committed state with Fu = Fbar(u_{n+1}) Fbar(u_n)^-1, commit
    a_{n+1}   = -M^-1 f_int(u_{n+1});  v_{n+1} = v_{n+1/2} + dt/2 a_{n+1}

* The mass is the row-sum lumped mass  M_i = int rho N_i w dV  (w = 2 pi r in axisymmetry).
* The internal force: the default route, ``internal_force="fused"``, runs kinematics, material
  update and nodal force in one compiled pass over the cells
  (:mod:`fenics_plast.solvers.fused_force`, ~5x cheaper per step); serial runs take the steps
  between two checks in one compiled call (:func:`integrator.advance`). The definition that
  pass is held to is the UFL residual ``Kinematics.internal_virtual_work`` (R_u of DESIGN.md,
  shared with the static solver; tests/test_fused_force.py checks force, stress and state against
  it to round-off); ``"ufl"`` evaluates the UFL expression of Fu, calls ``QuadratureMap.update``
  and assembles that form with dolfinx. Both use the same material kernels.
* Velocity boundary conditions ``velocity_bcs`` are homogeneous (sliding supports, fixed walls):
  those dofs keep zero velocity and zero acceleration; their internal force is the support reaction.
* Drivers (before the first step): prescribed velocity or displacement of one component on a dof
  set as a function of time (:meth:`ExplicitDynamics.add_prescribed_velocity`,
  :meth:`~ExplicitDynamics.add_prescribed_displacement`; reactions :meth:`~ExplicitDynamics.reaction`),
  external forces (:meth:`~ExplicitDynamics.add_external_force`, dead tractions
  :meth:`~ExplicitDynamics.add_traction`) and penalty contact with friction against rigid tools
  (:meth:`~ExplicitDynamics.add_contact`, :mod:`fenics_plast.solvers.explicit_contact`).
* Several materials (:class:`~fenics_plast.material.regions.MaterialRegions`, one density each):
  the mass uses each cell's density, the stable step each cell's wave speed (min over cells of
  h_c / c_c); one material keeps the plain path (h_min / c, a constant density).
* Geometry "3d" (``Kinematics(mesh, "3d")``, hexahedral mesh): 3 components per node (nodal
  vectors are entry ``3 node + component``), trilinear hexahedra with 2 x 2 x 2 Gauss points, the
  fused pass's hexahedral kernels (:mod:`fenics_plast.solvers.fused_force_hex`, held to the UFL
  residual by tests/test_fused_force_3d.py) and the hexahedral stable step
  (:mod:`fenics_plast.solvers.hex_step`: size estimate kappa V / A_max / c, the element step
  2 / omega_max where that is below the minimum, taken as the cell's step). 2-D code paths unchanged.
* Stable step: per cell the larger of h / c and 2 / omega_max of its elastic element
  (``stable_step="element"``, the default; "size": h / c alone), h the smallest edge or altitude of
  the deformed quad and c = sqrt((lambda + 2 mu) / rho) the dilatational wave speed, see
  :meth:`~ExplicitDynamics.stable_dt`; the minimum over the cells,
  with contact pairs combined with the penalty springs' limit (explicit_contact.py); re-estimated
  every ``reestimate_every`` steps; the step used is dt_safety * dt_stable.
* Time-step floor: when the stable step falls below ``dt_floor`` times its initial value, the run
  stops with a :class:`~fenics_plast.solvers.collapse.TimeStepCollapse` naming the cell (position,
  size, aspect ratio, volume ratio, corner angles, its element's own step) and the remedies
  (:mod:`fenics_plast.solvers.collapse`); the runner writes the outputs, fields and a checkpoint at
  the stop.
* Fold guard (every step, both routes): the force pass first checks the new displacement's point
  Jacobians (:func:`fused_force.folded_cell`: det F <= 0, F_hh <= 0 or not finite, in a living cell
  that erosion does not take); a step that would fold a cell writes nothing of the state, stress or
  force, is undone (u = u_n, v and du kept before it: ``guard``, :mod:`~fenics_plast.solvers.step_guard`)
  and the run stops at that last finite state with a :class:`~fenics_plast.solvers.collapse.CellFold`,
  handled by the runner as a collapse. A fold is not a collapse of the stable step: in the Taylor bar
  above 300 m/s the axis cells fold at 1.2-11 % of the initial step (at 5000 m/s in the third step, at
  66 % of it), far above the floor, and the point Jacobian goes through zero within one step.
* Selective mass scaling (``mass_scaling_dt``, :meth:`~ExplicitDynamics.scale_mass`): at every
  re-estimate the cells whose stable step is below the target get density (factor s_c, never
  lowered) so that theirs reaches it; the mass goes to their nodes (assembled over the ranks) and
  keeps the nodes' velocity.
* Energies: kinetic 1/2 v.M.v (integer-step velocity), internal work by the trapezoidal rule
  W += du.(f_n + f_{n+1})/2, external work of the support reactions likewise (zero for fixed
  walls), of prescribed motion, loads and moving tools (integrator.py), contact work
  E_c (penalty energy + friction dissipation), stored elastic energy int psi(binv) w dV, plastic
  dissipation = W_int - elastic, the kinetic energy brought in by mass scaling E_ms (1/2 dm v^2 at
  each addition). Balance error |KE + W_int + E_c - KE0 - W_ext - E_ms| / (KE0 + |W_ext| + E_ms)
  (= / (KE0 + E_ms) without drivers; absolute when that is 0).
"""
from __future__ import annotations

import math
import time

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

from fenics_plast import dolfinx_compat as dc
from fenics_plast.material import MaterialRegions
from fenics_plast.quadrature import MaterialUpdateError, QuadratureMap
from fenics_plast.schema import choices, default, key
from fenics_plast.solvers import fused_force
from fenics_plast.solvers.fused_force_hex import HexGeometry
from fenics_plast.solvers import integrator as ti
from fenics_plast.solvers import time_stepping
from fenics_plast.solvers.cell_steps import CellSteps, cell_masses
from fenics_plast.solvers.body_surface import TwoPassPair
from fenics_plast.solvers.explicit_contact import ContactSet
from fenics_plast.solvers.explicit_restart import ExplicitRestart
from fenics_plast.solvers.step_guard import StepGuard
from fenics_plast.solvers.walls import RigidWalls


class ExplicitDynamics:
    """Central differences on a Q1 (element "q1") or Q1/P0 F-bar ("q1p0") displacement field.

    Parameters
    ----------
    mesh, kin : dolfinx mesh and ``fenics_plast.kinematics.Kinematics``.
    material : ``fenics_plast.material.Material`` (``update_into``, ``energy``, ``wave_speed``,
        ``kernel_args``) or ``MaterialRegions`` (several materials, one per set of cells).
    density : tonne/mm^3; with a ``MaterialRegions``, one density per material (in its order).
    velocity_bcs : list of (component, facet indices): that velocity component is held at 0.
    element : "q1p0" (DG0 mean dilatation, F-bar) or "q1" (theta = None).
    internal_force : "fused" (one compiled pass: kinematics + material + force) or "ufl" (UFL
        expression + QuadratureMap + dolfinx assembly of the UFL form); same numbers, see module doc.
    stable_step : "element" (the larger of h / c and the cell's elastic element step 2 / omega_max)
        or "size" (h / c of each cell), see :meth:`stable_dt`.
    erosion_ratio : element erosion (fused route only): a cell whose smallest quadrature-point
        Jacobian falls below this fraction of its mean dilatation (about to fold) is eroded: its points
        keep their state and stress, it adds no force and no stable-step limit, its nodes keep their
        mass (``alive``, ``cell_steps.erosion_stats``). 0: off.

    Drivers are added after construction and before the first step (collective calls):
    :meth:`add_prescribed_velocity`, :meth:`add_prescribed_displacement`, :meth:`add_external_force`,
    :meth:`add_traction`, :meth:`add_contact`, :meth:`add_wall`. Prescribed sets are a component of a set of nodes
    (block indices of ``V``, :meth:`boundary_dofs`); nodal vectors (loads, masses, ``u.x.array``)
    are unrolled, entry ``2 node + component``.

    Besides the nodal vectors, its collaborators read ``reference_positions`` (n_nodes, gdim), the
    owned + ghost nodes' reference positions [mm], ``cell_nodes`` (nc, 4 or 8), the owned cells' nodes
    (basix order), and ``cell_steps``, the :class:`~fenics_plast.solvers.cell_steps.CellSteps` of the
    stable step per cell, selective mass scaling and the erosion statistics.
    """

    INTERNAL_FORCE_ROUTES = choices("analysis.internal_force")
    STABLE_STEPS = choices("analysis.stable_step")

    def __init__(self, mesh, kin, material, density, velocity_bcs=(), element=default("mesh.element"),
                 reestimate_every=10, log=None, internal_force=default("analysis.internal_force"),
                 stable_step=default("analysis.stable_step"), erosion_ratio=default("analysis.erosion_ratio")):
        if element not in choices("mesh.element"):
            raise ValueError(f"element must be one of {choices('mesh.element')}, got {element!r}")
        if internal_force not in self.INTERNAL_FORCE_ROUTES:
            raise ValueError(f"internal_force must be one of {self.INTERNAL_FORCE_ROUTES}, got {internal_force!r}")
        cellname = mesh.ufl_cell().cellname()
        if cellname != ("hexahedron" if kin.three_d else "quadrilateral"):
            raise ValueError(f"the explicit solver takes quadrilaterals in 2-D and hexahedra in 3-D, got "
                             f"{cellname} cells with geometry {kin.geometry!r}")
        if stable_step not in self.STABLE_STEPS:
            raise ValueError(f"stable_step must be one of {self.STABLE_STEPS}, got {stable_step!r}")
        self.stable_step = stable_step
        erosion_range = key("analysis.erosion_ratio")       # the range is the schema's
        if not erosion_range.in_range(erosion_ratio):
            raise ValueError(f"erosion_ratio must satisfy {erosion_range.range_text('erosion_ratio')}, "
                             f"got {erosion_ratio}")
        if erosion_ratio > 0.0 and internal_force != "fused":
            raise ValueError("element erosion (erosion_ratio > 0) is of the fused internal-force pass only")
        self.erosion_ratio = float(erosion_ratio)
        self.internal_force_route = internal_force
        self.fused = internal_force == "fused"
        self.mesh, self.kin, self.material = mesh, kin, material
        self.regions = isinstance(material, MaterialRegions)
        self.density = np.asarray(density, dtype=float).reshape(-1) if self.regions else float(density)
        self.comm = mesh.comm
        self.element = element
        self.reestimate_every = int(reestimate_every)
        self.log = log if log is not None else (self._print if self.comm.rank == 0 else (lambda msg: None))
        self.timings = {}
        t0 = time.perf_counter()

        V = dc.vector_space(mesh)
        self.V = V
        self.u = fem.Function(V, name="displacement")
        self.u_n = fem.Function(V, name="displacement_previous")
        self.v = fem.Function(V, name="velocity")
        imap = V.dofmap.index_map
        self.bs = V.dofmap.index_map_bs
        self.n_own = imap.size_local * self.bs            # owned scalar dofs (unrolled)
        self.dofs_global = imap.size_global * self.bs
        tdim = mesh.topology.dim
        self.n_cells_own = mesh.topology.index_map(tdim).size_local
        self.cells_global = mesh.topology.index_map(tdim).size_global

        # reference positions of the dofs' nodes (n, gdim) [mm], cell -> nodes (basix order)
        self.three_d = kin.three_d
        X = V.tabulate_dof_coordinates()[:, : self.bs]
        self.reference_positions = np.ascontiguousarray(X)
        cell_nodes = np.ascontiguousarray(dc.cell_dofs(V)[: self.n_cells_own], dtype=np.int64)
        self.cell_nodes = cell_nodes
        if self.regions:
            # per cell wave speed for the stable step; c: the fastest material (messages, round-off floor)
            speeds = material.wave_speeds(self.density)
            cell_c = material.per_cell(speeds)
            self.c = float(speeds.max())
        else:
            cell_c = None
            self.c = material.wave_speed(self.density)
        if self.three_d:
            points, weights = fused_force.quadrature(kin.degree, "hexahedron")   # the rule of kin.dx, QuadratureMap
            self.geometry = HexGeometry(self.reference_positions[cell_nodes], points, weights)
        else:
            points, weights = fused_force.quadrature(kin.degree)        # the rule of kin.dx and QuadratureMap
            self.geometry = fused_force.CellGeometry(self.reference_positions[cell_nodes], points, weights,
                                                     kin.axisymmetric)

        self.alive = np.ones(self.n_cells_own, dtype=np.uint8)      # 0: eroded cell (erosion_ratio)
        self.eroded_reported = 0                                    # eroded cells already reported
        vt = ufl.TestFunction(V)
        if self.fused:
            self._setup_fused(kin)
        else:
            self._setup_ufl(kin, vt)
        # reference quadrature weights w |det J0| q_w, for energy integrals
        self._wq = self.geometry.W.reshape(-1)

        # lumped mass (row sums), weighted by kin.weight
        ones = fem.Constant(mesh, PETSc.ScalarType((1.0,) * self.bs))
        rho = self._cell_density() if self.regions else self.density
        M = fem_petsc.assemble_vector(fem.form(rho * ufl.inner(ones, vt) * kin.weight * kin.dx))
        M.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        self.mass = M.array.copy()
        M.destroy()
        self.minv = 1.0 / self.mass

        # velocity constraints (owned unrolled dofs)
        fdim = tdim - 1
        mesh.topology.create_connectivity(fdim, tdim)
        fixed = []
        for comp, facets in velocity_bcs:
            d = fem.locate_dofs_topological(V.sub(comp), fdim, np.asarray(facets, dtype=np.int32))
            fixed.append(np.asarray(d))
        fixed = np.unique(np.concatenate(fixed)) if fixed else np.zeros(0, dtype=np.int32)
        self.fixed = fixed[fixed < self.n_own].astype(np.int64)
        self.free_minv = self.minv.copy()
        self.free_minv[self.fixed] = 0.0                            # a = -f * free_minv: zero on fixed dofs

        # buffers
        self.a = np.zeros(self.n_own)
        self.du = np.zeros(self.n_own)
        self.guard = StepGuard(self)              # a step that would fold a cell or is not finite: undone
        self.t = 0.0
        self.step_count = 0
        self.W_int = 0.0          # local (owned) accumulators, reduced when reported
        self.W_ext = 0.0
        self.KE0 = None
        # the stable step per cell, selective mass scaling (run(mass_scaling_dt=...), :meth:`scale_mass`)
        # and the erosion statistics: each cell's share of its nodes' mass and its Lame constants
        cell_mass, lam, mu = cell_masses(material, self.density, self.regions, self.geometry.N, self.geometry.W)
        self.cell_steps = CellSteps(self.reference_positions, self.u.x.array, cell_nodes, self.three_d,
                                    kin.axisymmetric, element == "q1p0", stable_step, self.c, cell_c, cell_mass,
                                    lam, mu, self.geometry.W, self.alive, self.erosion_ratio, self.mass,
                                    self.v.x.array, V, mesh.topology.original_cell_index, self.comm)
        # drivers: contact pairs, prescribed motion and loads (and the steps that integrate them)
        self.contact = ContactSet(self)
        self.walls = RigidWalls(self)
        self.restart = ExplicitRestart(self)        # the state a resumed run needs (checkpoints)
        self.drivers = ti.Drivers(self)
        self.timings["setup_s"] = time.perf_counter() - t0

    def _cell_density(self):
        """DG0 density of each cell [tonne/mm^3] (several materials)."""
        D0 = dc.function_space(self.mesh, "DG", 0)
        rho = fem.Function(D0, name="density")
        dofs = dc.cell_dofs(D0).reshape(-1)[: self.n_cells_own]
        rho.x.array[dofs] = self.material.per_cell(self.density)
        rho.x.scatter_forward()
        return rho

    def _setup_fused(self, kin):
        """Data of the compiled pass: reference geometry at the quadrature points, work arrays."""
        self.qmap = QuadratureMap(self.mesh, kin, self.material, None, degree=kin.degree, tangent=False)
        n = self.qmap.n
        self._Fu = np.zeros((n, 3, 3))              # off-block entries stay 0 (2-D kinematics)
        # F^-1: (n, 5) on quadrilaterals, (n, 3, 3) on hexahedra (which picks the fused pass's kernels)
        self._Finv = np.zeros((n, 3, 3)) if self.three_d else np.zeros((n, 5))
        self._factor = np.zeros(n)
        self.theta_cells = np.ones(self.n_cells_own)
        self.theta = self.theta_n = None
        self._ffun = fem.Function(self.V, name="internal_force")
        self._f_all = self._ffun.x.array                            # owned + ghost, filled by the pass
        self.f = self._f_all[: self.n_own]
        g, q = self.geometry, self.qmap
        # the arrays of the compiled pass: persistent, updated in place
        model, lmbda, mu, law, hp, yield_tol = self.material.kernel_args()
        self.force_args = fused_force.FusedPass(
            u=self.u.x.array, u_n=self.u_n.x.array, cell_dofs=self.cell_nodes, dNdX=g.dNdX, N=g.N, Rinv=g.Rinv,
            W=g.W, fbar=self.element == "q1p0", alive=self.alive, erosion_ratio=self.erosion_ratio, model=model,
            lmbda=lmbda, mu=mu, law=law, hp=hp, yield_tol=yield_tol,
            regions=self.material.point_layout(q.nq) if self.regions else None, binv=q.binv, eqps=q.eqps,
            temp=q.temperature, dt=q.dt, tau=q.tau_values, Fu=self._Fu, Finv=self._Finv, factor=self._factor,
            theta=self.theta_cells, f=self._f_all)

    def _setup_ufl(self, kin, vt):
        """Forms and expression of the dolfinx route (compiled once)."""
        mesh = self.mesh
        if self.element == "q1p0":
            D0 = dc.function_space(mesh, "DG", 0)
            self.D0 = D0
            self.theta = fem.Function(D0, name="theta")
            self.theta_n = fem.Function(D0, name="theta_previous")
            self.theta.x.array[:] = 1.0
            self.theta_n.x.array[:] = 1.0
            q = ufl.TestFunction(D0)
            self._L_theta = fem.form(kin.J(self.u) * kin.weight * q * kin.dx)
            vol = fem_petsc.assemble_vector(fem.form(kin.weight * q * kin.dx))
            self._n_theta = D0.dofmap.index_map.size_local
            self._cellvol_inv = 1.0 / vol.array.copy()
            vol.destroy()
            self._b_theta = fem_petsc.create_vector(self._L_theta)
            self._b_theta_arr = self._b_theta.getArray()           # owned view
        else:
            self.theta = self.theta_n = None
        # Fu = Fbar(u, theta) Fbar(u_n, theta_n)^-1 at the qps, compiled once
        Fu_expr = kin.Fu(self.u, self.theta, self.u_n, self.theta_n)
        self.qmap = QuadratureMap(mesh, kin, self.material, Fu_expr, degree=kin.degree, tangent=False)
        # internal force: the shared R_u, compiled once, reused Vec
        self._L_int = fem.form(kin.internal_virtual_work(self.u, self.theta, self.qmap.tau, vt))
        self._f = fem_petsc.create_vector(self._L_int)
        self.f = self._f.getArray()                                 # owned view, refreshed in place

    @staticmethod
    def _print(msg):
        print(msg, flush=True)

    # ------------------------------------------------------------------------------------------
    def set_velocity(self, value):
        """Initial velocity [mm/s]: (vr, vz) ((vx, vy, vz) in 3-D) for the whole body, or one row per
        local node (owned and ghost; shape (n, gdim)); constrained components are set to zero."""
        self.v.x.array.reshape(-1, self.bs)[:] = np.asarray(value, dtype=float)
        self.v.x.array[self.fixed] = 0.0
        self.v.x.scatter_forward()

    # -- drivers -------------------------------------------------------------------------------
    @property
    def has_drivers(self):
        """True with prescribed motion, loads or contact (the general step kernels)."""
        return self.drivers.active

    def _before_start(self, what):
        if self.KE0 is not None:
            raise RuntimeError(f"{what} must be added before the first step (initialize)")

    def boundary_dofs(self, facets):
        """The nodes (block indices of ``V``, owned + ghost) of ``facets`` (local facet indices, e.g.
        ``facet_tags.find(tag)``): ``fem.locate_dofs_topological(V, fdim, facets)``. Component c of
        node i is entry ``bs i + c`` of ``u.x.array``."""
        fdim = self.mesh.topology.dim - 1
        return np.asarray(fem.locate_dofs_topological(self.V, fdim, np.asarray(facets, dtype=np.int32)),
                          dtype=np.int64)

    def _add_prescribed(self, component, dofs, fun, kind, name):
        self._before_start("prescribed motion")
        k = self.drivers.add_set(component, dofs, kind, fun, name)
        self.free_minv[self.drivers.pdofs] = 0.0
        return k

    def add_prescribed_velocity(self, component, dofs, velocity, name=None) -> int:
        """Prescribe velocity component ``component`` (0: x/r, 1: y/z) of the nodes ``dofs`` (block
        indices of ``V``, see :meth:`boundary_dofs`; ghosts ignored) as ``velocity(t)`` [mm/s] (a
        callable of t [s] or a number).
        The half-step velocity is velocity(t_n + dt/2), the step-end velocity velocity(t_{n+1}).
        Returns the set id for :meth:`reaction` and :meth:`prescribed_work`."""
        return self._add_prescribed(component, dofs, velocity, ti.VELOCITY, name)

    def add_prescribed_displacement(self, component, dofs, displacement, name=None) -> int:
        """Prescribe displacement component ``component`` on ``dofs`` as ``displacement(t)`` [mm]
        (absolute: u = displacement(t)): u = displacement(t_{n+1}) at every step end (the step
        imposes the velocity (d(t_{n+1}) - d(t_n)) / dt) and u = displacement(t0) at the start.
        Returns the set id."""
        return self._add_prescribed(component, dofs, displacement, ti.DISPLACEMENT, name)

    def reaction(self, set_id) -> np.ndarray:
        """Force (Fx, Fy) [N] the prescribed set ``set_id`` exerts on the body at the current time:
        internal force - loads - contact + inertia M a on its dofs, a over the last half step
        (2 pi r included in axisymmetry; collective, all ranks)."""
        out = self.drivers.reaction(set_id)
        return self.comm.allreduce(out, op=MPI.SUM) if self.comm.size > 1 else out

    def prescribed_work(self, set_id) -> float:
        """Work of the prescribed set's reaction since t = 0 [N mm] (collective)."""
        return self.allreduce(float(self.drivers.wset[set_id]), MPI.SUM)

    def add_external_force(self, force):
        """An external nodal force ``force(t)`` [N] (t [s]): a callable returning the owned unrolled
        dofs' values (n_own,) (or the owned + ghost array, of which the owned part is used)."""
        self._before_start("external forces")
        self.drivers.add_load(None, force)

    def add_traction(self, facet_tags, tag, traction):
        """Dead-load traction ``traction = (tx, ty)`` [MPa] on the facets tagged ``tag`` (per reference
        area, weight 2 pi r in axisymmetry), tx, ty callables of t [s] or numbers: the load vectors
        int N_i e_k w dA0 of unit tractions are assembled once and scaled by tx(t), ty(t)."""
        self._before_start("tractions")
        ds = ufl.Measure("ds", domain=self.mesh, subdomain_data=facet_tags)(tag)
        vt = ufl.TestFunction(self.V)
        for k in range(self.bs):
            c = fem.Constant(self.mesh, PETSc.ScalarType(tuple(float(i == k) for i in range(self.bs))))
            b = fem_petsc.assemble_vector(fem.form(ufl.inner(c, vt) * self.kin.weight * ds))
            b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            self.drivers.add_load(b.array.copy(), traction[k])
            b.destroy()

    def add_contact(self, tool, facet_tags, tag, penalty, friction=default("contact.*.friction"),
                    law=default("contact.*.law"), tangential_penalty=None, name=None):
        """Penalty contact (+ Coulomb friction) of the nodes of the facets tagged ``tag`` against the
        rigid ``tool`` (``gap_np(x, t)``, ``translation(t, use_ufl=False)``; time t [s] as its load
        factor). penalty, tangential_penalty (default: penalty) [N/mm^3]; friction mu; law
        "coulomb" | "quasi-coulomb" (friction and law default to the schema's, as in the static
        :class:`~fenics_plast.contact.PenaltyContact`). Returns the
        :class:`~fenics_plast.solvers.explicit_contact.ExplicitContactPair` (force, work,
        penetration). Lowers :meth:`stable_dt`. Collective."""
        self._before_start("contact pairs")
        return self.contact.add(tool, facet_tags, tag, penalty=penalty, friction=friction, law=law,
                                tangential_penalty=tangential_penalty, name=name)

    def add_surface_contact(self, facet_tags, tag, master_tag, penalty, two_pass=True,
                            friction=default("contact.*.friction"), law=default("contact.*.law"),
                            tangential_penalty=None, mirror_tags=(), name=None):
        """Penalty contact (+ Coulomb friction) of the nodes of the facets tagged ``tag`` against the body's
        own facets tagged ``master_tag`` at their current positions, the reactions on the master facets'
        nodes (:mod:`~fenics_plast.solvers.body_surface`); ``two_pass``: also the master group's nodes
        against the facets tagged ``tag``; the surfaces continue across the facets tagged ``mirror_tags``
        (the model's symmetry planes and axis). Other arguments as :meth:`add_contact`. Returns the
        :class:`~fenics_plast.solvers.explicit_contact.ExplicitContactPair` (one pass) or
        :class:`~fenics_plast.solvers.body_surface.TwoPassPair`. Lowers :meth:`stable_dt`. Collective."""
        self._before_start("contact pairs")
        options = dict(penalty=penalty, friction=friction, law=law, tangential_penalty=tangential_penalty)
        forward = self.contact.add(self.contact.surface(facet_tags, master_tag, mirror_tags), facet_tags, tag,
                                   **options, name=name)
        if not two_pass:
            return forward
        backward = self.contact.add(self.contact.surface(facet_tags, tag, mirror_tags), facet_tags, master_tag,
                                    **options, name=name)
        return TwoPassPair(forward, backward)

    # ------------------------------------------------------------------------------------------
    def add_wall(self, component, position, nodes=None, name=None):
        """A rigid frictionless wall x_component = position [mm] that ``nodes`` (local node indices;
        None: every node) cannot pass (:class:`~fenics_plast.solvers.walls.RigidWalls`; collective)."""
        self._before_start("walls")
        self.walls.add(component, position, nodes, name)

    def _update_theta(self):
        b = self._b_theta
        with b.localForm() as bl:
            bl.set(0.0)
        fem_petsc.assemble_vector(b, self._L_theta)
        # cell-local: no reverse scatter needed (owned cells own their DG0 dof)
        self.theta.x.array[: self._n_theta] = self._b_theta_arr * self._cellvol_inv
        self.theta.x.scatter_forward()

    def internal_force(self):
        """Material update + commit at the current u, then f_int into self.f (owned). Returns, the
        same on every rank (one or two small collectives per step under MPI):
        ``ti.STEP_OK``; ``ti.STEP_FOLDS`` when a cell folds at u on some rank (a quadrature point's
        Jacobian <= 0 or not finite: :func:`fused_force.folded_cell`, checked first on both routes):
        no rank has written anything of its quadrature state, stress or force, and the step is to be
        undone (``guard``, a :class:`~fenics_plast.solvers.step_guard.StepGuard`); or ``ti.STEP_NONFINITE``
        when a stress or force is not finite on some rank (``guard.step_failure`` says which, on every rank;
        the fused route has committed that update, the ufl route has not)."""
        if self.fused:
            if not self.guard.no_fold(fused_force.folded_cell(self.force_args)):
                return ti.STEP_FOLDS
            ok = fused_force.update_and_force(self.force_args)
            if self.comm.size > 1:
                dc.scatter_reverse_add(self._ffun)
            why = None if ok else f"non-finite stress or internal force at step {self.step_count + 1}"
            return self.guard.agree(why)
        if not self.guard.no_fold(self.guard.folded_cells()):
            return ti.STEP_FOLDS
        if self.theta is not None:
            self._update_theta()
        why = None
        try:
            self.qmap.update(tangent=False)      # into the trial state (collective writes, then raises)
        except MaterialUpdateError as e:
            why = f"{e} at step {self.step_count + 1}"
        if self.guard.agree(why) != ti.STEP_OK:
            return ti.STEP_NONFINITE            # nothing committed, no force assembled, on any rank
        self.qmap.commit()
        b = self._f
        with b.localForm() as bl:
            bl.set(0.0)
        fem_petsc.assemble_vector(b, self._L_int)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        return ti.STEP_OK

    def initialize(self):
        """Internal force and energies at t = 0 (call after set_velocity)."""
        if self.has_drivers:
            self.drivers.initialize()
        else:
            self.internal_force()
            np.multiply(self.f, self.free_minv, out=self.a)
            np.negative(self.a, out=self.a)
            self.KE0 = self.kinetic_energy()
        if self.fused and self.comm.size == 1 and self.contact.chunkable:
            self.advance(0, 0.0)          # compiles (or loads) the chunked loop now, not inside the run

    def step(self, dt):
        """One central-difference step of size dt [s] (velocity-Verlet form, see module doc). A step
        that would fold a cell is not taken: the state stays the last finite one and
        ``guard.pending_fold`` says where."""
        self.qmap.dt[0] = dt              # the material update's time increment (Johnson-Cook rate, heating)
        n = self.n_own
        self.guard.keep()                           # v, du before the step (undone if it fails)
        if self.has_drivers:
            status = self.drivers.step(dt)
            if status != ti.STEP_OK:
                self.guard.step_failed(status, dt)
                return
            self.t += dt
            self.step_count += 1
            return
        v = self.v.x.array
        # half-step velocity, displacement increment (u_n keeps the previous u, ghosts included)
        w_old = ti.kick_drift(v, self.a, self.f, self.du, self.u.x.array, self.u_n.x.array, dt, n, self.mass,
                              self.walls.args)
        if self.theta is not None:
            self.theta_n.x.array[:] = self.theta.x.array
        if self.comm.size > 1:
            self.u.x.scatter_forward()
        status = self.internal_force()
        if status != ti.STEP_OK:
            self.guard.step_failed(status, dt)   # back to the last finite u, v (no kick, not counted)
            return
        # trapezoidal work of the internal forces. Constrained dofs have du = 0 (homogeneous
        # velocity BCs: fixed sliding walls), so the support reactions do no work: W_ext stays 0.
        w_new = ti.kick(v, self.a, self.f, self.free_minv, self.du, dt, n, self.mass, self.walls.args)
        self.W_int += 0.5 * (w_old + w_new)
        self.t += dt
        self.step_count += 1

    def advance(self, nsteps, dt):
        """``nsteps`` steps of size dt in one compiled call (serial fused route; same arithmetic as
        ``nsteps`` calls of :meth:`step`, which it stops at the first failed step as :meth:`step`
        does)."""
        self.qmap.dt[0] = dt              # the material update's time increment (Johnson-Cook rate, heating)
        if self.has_drivers:
            done, status = self.drivers.advance(nsteps, dt)
        else:
            work = np.array([self.W_int])
            done, status = ti.advance(nsteps, dt, self.v.x.array, self.a, self.free_minv, self.du,
                                      self.n_own, self.force_args, work, self.mass, self.walls.args,
                                      self.guard.kept)
            self.W_int = float(work[0])
        for _ in range(done):
            self.t += dt
        self.step_count += done
        if status != ti.STEP_OK:          # the next step failed: not taken (serial)
            if status == ti.STEP_NONFINITE and self.guard.step_failure is None:
                self.guard.step_failure = f"non-finite stress or internal force at step {self.step_count + 1}"
            self.guard.step_failed(ti.STEP_FOLDS if status >= 0 else status, dt)

    def allreduce(self, x, op):
        """Global reduction of a float (no MPI call in serial: it is checked every few steps)."""
        return x if self.comm.size == 1 else self.comm.allreduce(x, op=op)

    # ------------------------------------------------------------------------------------------
    def kinetic_energy(self):
        v = self.v.x.array[: self.n_own]
        return self.allreduce(0.5 * float(np.dot(self.mass * v, v)), MPI.SUM)

    def elastic_energy(self):
        psi = self.material.energy(self.qmap.binv)
        return self.comm.allreduce(float(np.dot(psi, self._wq)), op=MPI.SUM)

    def energies(self):
        """Global energies [N mm] and the relative balance error (collective).

        kinetic, elastic, internal_work, plastic (= internal_work - elastic), external_work (supports,
        prescribed sets, loads, moving tools), its parts prescribed_work, load_work, tool_work, and
        contact_work (penalty energy + friction dissipation), contact_stored (penalty energy now);
        mass_scaling (the kinetic energy that selective mass scaling brought in: the added mass takes
        the node's velocity, 1/2 dm v^2 at each addition) and added_mass_kinetic (the kinetic energy
        of the added mass now, part of kinetic); wall (the energy the rigid walls' stops took);
        balance_error = |KE + W_int + E_c + E_wall - KE0 - W_ext - E_ms| / (KE0 + |W_ext| + E_ms)
        (absolute if that is 0), E_ms = mass_scaling, E_wall = wall.
        """
        ke = self.kinetic_energy()
        el = self.elastic_energy()
        w_int = self.comm.allreduce(self.W_int, op=MPI.SUM)
        w_ext = self.comm.allreduce(self.W_ext, op=MPI.SUM)
        ms = dict(mass_scaling=0.0, added_mass_kinetic=0.0)
        if self.cell_steps.mass_scaled:
            m = self.cell_steps.mass_scaling_stats()
            ms = dict(mass_scaling=m["energy"], added_mass_kinetic=m["kinetic"])
        e_ms = ms["mass_scaling"]
        e_wall = self.walls.energy() if self.walls.active else 0.0
        if not self.has_drivers:
            # relative to the initial kinetic energy; a body at rest (KE0 = 0) reports the absolute error
            scale = self.KE0 + e_ms
            err = abs(ke + w_int + e_wall - self.KE0 - w_ext - e_ms) / (scale if scale > 0.0 else 1.0)
            return dict(kinetic=ke, elastic=el, internal_work=w_int, plastic=w_int - el,
                        external_work=w_ext, balance_error=err, prescribed_work=0.0, load_work=0.0,
                        tool_work=0.0, contact_work=0.0, contact_stored=0.0, wall=e_wall, **ms)
        e = dict(kinetic=ke, elastic=el, internal_work=w_int, plastic=w_int - el, wall=e_wall)
        e.update(self.drivers.energies(ke, w_int, w_ext, self.comm, e_ms, e_wall))
        e.update(ms)
        return e

    def ke_limit(self):
        """Kinetic energy above which a run is taken as unstable: 1.5 KE0, with drivers
        1.5 (KE0 + |W_ext| + energy stored at the start) + a round-off floor (collective then)."""
        lim = self.drivers.ke_limit() if self.has_drivers else 1.5 * self.KE0 + 1e-30
        cs = self.cell_steps
        return lim + 1.5 * self.allreduce(cs.E_mass, MPI.SUM) if cs.mass_scaled else lim

    def max_eqps(self):
        loc = float(self.qmap.eqps.max()) if self.qmap.eqps.size else 0.0
        return self.comm.allreduce(loc, op=MPI.MAX)

    def nodal_positions(self):
        """Current positions of the owned+ghost dofs' nodes (n, gdim)."""
        return self.reference_positions + self.u.x.array.reshape(-1, self.bs)

    # -- the stable step and selective mass scaling (the cells' part: ``cell_steps``) --------------
    def stable_dt(self):
        """The stable step [s] on the current (deformed) mesh: the cells' step
        (:meth:`CellSteps.stable_dt <fenics_plast.solvers.cell_steps.CellSteps.stable_dt>`, the minimum
        over the cells and ranks of each cell's size estimate or element step) and, with contact pairs,
        the smallest penalty-spring limit dt_c = min 2 sqrt(m_i / (eps A_i)) of the contact nodes,
        combined as 1 / sqrt(1 / dt^2 + 1 / dt_c^2) (explicit_contact.py). Collective."""
        dt = self.cell_steps.stable_dt()
        if not self.contact.pairs:
            return dt
        dtc = self.contact.dt_stable
        return 1.0 / math.sqrt(1.0 / dt ** 2 + 1.0 / dtc ** 2)

    def scale_mass(self, target):
        """Selective mass scaling to the stable step ``target`` [s] (collective; called by :meth:`run`
        at every step-size check when ``mass_scaling_dt`` is set): the cells below it get density and
        their nodes mass (:meth:`CellSteps.scale_mass <fenics_plast.solvers.cell_steps.CellSteps.scale_mass>`,
        which accumulates the kinetic energy the added mass brings in, a term of the energy balance,
        :meth:`energies`); the acceleration of the changed dofs is recomputed with the new mass, the
        contact springs' step limit too. Returns the number of cells scaled now (all ranks)."""
        n_low, ch = self.cell_steps.scale_mass(target)
        if n_low == 0:
            return 0
        self.minv[ch] = 1.0 / self.mass[ch]
        self.free_minv[ch] = self.minv[ch]
        self.free_minv[self.fixed] = 0.0
        if self.has_drivers:
            d = self.drivers
            self.free_minv[d.pdofs] = 0.0
            self.a[ch] = (d.fload[ch] + d.fcon[ch] - self.f[ch]) * self.free_minv[ch]
        else:
            self.a[ch] = -self.f[ch] * self.free_minv[ch]
        if self.contact.pairs:
            self.contact.mass_changed()
        return n_low

    # ------------------------------------------------------------------------------------------
    def run(self, end_time, dt_safety=default("analysis.dt_safety"), steps=None, rows=2, on_row=None, progress=10,
            max_steps=None, bar=None, checkpoint_every=default("output.checkpoint_every", analysis="explicit"),
            on_checkpoint=None, resume=None, dt_floor=default("analysis.dt_floor"),
            mass_scaling_dt=default("analysis.mass_scaling_dt"), on_check=None):
        """Integrate to ``end_time`` [s]: :func:`fenics_plast.solvers.time_stepping.drive` (the step size, the
        rows, checks, progress and checkpoints; this class takes one step, :meth:`step`, or a chunk, :meth:`advance`).

        steps=None: dt = dt_safety * dt_stable, re-estimated every ``reestimate_every`` steps and
        shortened to land on the history-row times; steps=N: fixed dt = end_time / N, refused with a
        RunError when above the stable limit. ``on_row(solver, t)`` is called at ``rows`` equally
        spaced times (t = 0 and t = end_time included). ``max_steps`` stops the run early (benchmarks).
        ``progress``: number of log lines with energies; ``bar``: a :class:`fenics_plast.progress.Progress`
        over the simulated time in us, updated every ``reestimate_every`` steps.
        ``on_checkpoint(solver, loop)`` is called after the step that completes ``checkpoint_every``
        steps since the last call (at the end of a chunk: no per-step cost), with ``loop`` the run-loop
        variables (JSON-able); ``resume=loop`` continues such a run after ``restart.load_state`` (no row
        at t = 0 then).
        ``mass_scaling_dt`` [s] > 0: selective mass scaling to that stable step at every step-size
        check (:meth:`scale_mass`; with fixed steps at the checks after each ``reestimate_every``
        steps). ``dt_floor``: the adaptive run stops with a :class:`TimeStepCollapse` (a RunError
        naming the cell, carrying the statistics and loop variables so far) when the stable step
        falls below ``dt_floor`` times its initial value (0: never). A step that would fold a cell
        (a quadrature point's Jacobian <= 0: the material update has no answer there) is not taken:
        the run stops at the last finite state with a :class:`~fenics_plast.solvers.collapse.CellFold`
        (a TimeStepCollapse naming the cell and the remedies, with the statistics and loop variables);
        a stress or force that is non-finite otherwise raises a RunError at once (the step not taken).
        The errors' messages name the solver's arguments (a :class:`~fenics_plast.errors.Message` of
        :class:`~fenics_plast.errors.Arg`: ``dt_safety``, ``steps``, ``dt_floor``, ``mass_scaling_dt``,
        ``stable_step``, ``erosion_ratio``, ``element``, and ``mesh``, ``material.model``, ``add_wall``);
        ``str()`` words them so, a driver in its own terms (``RunError.worded``).
        ``on_check(solver)`` is called at every step-size check (each ``reestimate_every`` steps); True stops
        the run there, the statistics then with ``loop`` (``resume=loop`` goes on, e.g. on a new mesh).
        Returns a dict of run statistics.
        """
        return time_stepping.drive(self, end_time, dt_safety, steps, rows, on_row, progress, max_steps, bar,
                                   checkpoint_every, on_checkpoint, resume, dt_floor, mass_scaling_dt, on_check)

    def log_erosion(self):
        """A log line when cells have been eroded since the last call (collective)."""
        e = self.cell_steps.erosion_stats()
        if e["cells"] > self.eroded_reported:
            self.log(f"  t = {self.t * 1e6:8.3f} us  {e['cells'] - self.eroded_reported} cell(s) eroded (about to "
                     f"fold); {e['cells']} in all, {100 * e['volume_fraction']:.3g} % of the volume")
            self.eroded_reported = e["cells"]
