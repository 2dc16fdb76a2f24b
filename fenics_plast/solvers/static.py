"""Quasi-static finite-strain solver: one load increment by PETSc SNES Newton (:meth:`StaticSolver.solve_increment`);
the increments, cut-back and retries are driven by :mod:`fenics_plast.solvers.load_stepping`.

Unknowns: Q1 displacement u and (element "q1p0") a DG0 dilatation theta (F-bar, Q1/P0 of
docs/DESIGN.md); element "q1" is plain Q1 (theta := J). The residual callback evaluates the
incremental deformation gradient Fu = Fbar(u, theta) Fbar(u_n, theta_n)^-1 at the quadrature
points, runs the material update from the committed state, and assembles; the Jacobian is
assembled from the consistent tangent computed in the same update.

Loading is a scalar load factor ``lam`` in [0, 1]: Dirichlet values are ``lam * value`` (``dirichlet``,
:mod:`fenics_plast.solvers.dirichlet`) and extra residual terms (pressures) may use ``solver.load`` (a
fem.Constant equal to lam). A resumed run's state: ``restart`` (:mod:`fenics_plast.solvers.static_restart`).

Geometries: those of :class:`fenics_plast.kinematics.Kinematics` (2-D quadrilaterals, 3-D
hexahedra). Linear solves: ``linear_solver="mumps"`` (LU, the default) or ``"gamg"`` (GMRES + GAMG
with rigid-body modes; q1p0 condenses the dilatation exactly first: :mod:`fenics_plast.solvers.krylov`).
"""
from __future__ import annotations

import itertools
import math
import weakref
import time

import numpy as np
import ufl
from dolfinx import fem
import dolfinx.fem.petsc as fpetsc
from mpi4py import MPI
from petsc4py import PETSc

from fenics_plast import dolfinx_compat as dc
from fenics_plast.quadrature import MaterialUpdateError, QuadratureMap

from fenics_plast.errors import RunError
from fenics_plast.schema import choices, default
from fenics_plast.solvers import krylov, load_stepping
from fenics_plast.solvers.dirichlet import DirichletConditions
from fenics_plast.solvers.static_restart import StaticRestart

_prefix_counter = itertools.count()


def _weak(method):
    """A callable that forwards to the bound ``method`` without keeping its object alive."""
    ref = weakref.WeakMethod(method)

    def call(*args):
        m = ref()
        return None if m is None else m(*args)
    return call
MUMPS_WORKSPACE_ERRORS = (-8, -9, -11, -12, -14)   # INFOG(1): a MUMPS work array too small
MUMPS_MAX_ICNTL14 = 5000    # largest ICNTL(14) [% extra workspace] tried before giving up (start: 100)
SNES_DIVERGENCE_TOLERANCE = 1e4   # |R| / |R_0| above which Newton has diverged (PETSc's default divtol)
ROUNDOFF_FACTOR = 10.0      # safety factor of the residual round-off floor (see StaticSolver._jacobian)


class StaticSolver:
    """Newton (SNES newtonls + line search, MUMPS LU) with incremental loading."""

    def __init__(self, kin, material, element=default("mesh.element"), rtol=default("analysis.rtol"),
                 atol=default("analysis.atol"), max_iterations=default("analysis.max_iterations"),
                 linesearch=default("analysis.linesearch"), stol=0.0, verbose=True, log=None, progress=None,
                 linear_solver=default("analysis.linear_solver"), linear_rtol=default("analysis.linear_rtol"),
                 linear_max_iterations=default("analysis.linear_max_iterations"),
                 jacobian_every=default("analysis.jacobian_every"), jacobian_rate=default("analysis.jacobian_rate"),
                 predictor=default("analysis.predictor")):
        if element not in choices("mesh.element"):
            raise ValueError(f"element must be one of {choices('mesh.element')}, got {element!r}")
        if predictor not in choices("analysis.predictor"):
            raise ValueError(f"predictor must be one of {choices('analysis.predictor')}, got {predictor!r}")
        if linear_solver not in choices("analysis.linear_solver"):
            raise ValueError(f"linear_solver must be one of {choices('analysis.linear_solver')}, got "
                             f"{linear_solver!r}")
        self.kin = kin
        self.mesh = mesh = kin.mesh
        self.comm = mesh.comm
        self.material = material
        self.element = element
        self.mixed = element == "q1p0"
        self.verbose = verbose
        self.log_to = log          # where log lines go: a callable taking a line, or None (print)
        self.progress = progress    # fenics_plast.progress.Progress over the load factor (total 1), or None
        displacement = ("Lagrange", 1, (mesh.geometry.dim,))
        if self.mixed:
            self.W = dc.mixed_space(mesh, [displacement, ("DG", 0, None)])
            self.V = self.W.sub(0)
        else:
            self.W = dc.function_space(mesh, *displacement)
            self.V = self.W
        self.w = fem.Function(self.W, name="state")
        self.w_n = fem.Function(self.W, name="state_n")       # last converged
        self.w_nm1 = fem.Function(self.W, name="state_nm1")   # the one before (predictor)
        if self.mixed:
            _, self.theta_dofs = self.W.sub(1).collapse()
            self.theta_dofs = np.asarray(self.theta_dofs)
            for f in (self.w, self.w_n, self.w_nm1):
                f.x.array[self.theta_dofs] = 1.0
            self.u, self.theta = ufl.split(self.w)
            u_n, theta_n = ufl.split(self.w_n)
            self.v, self.q = ufl.TestFunctions(self.W)
            self.du, self.dtheta = ufl.TrialFunctions(self.W)
        else:
            self.u, self.theta = self.w, None
            u_n, theta_n = self.w_n, None
            self.v, self.q = ufl.TestFunction(self.W), None
            self.du, self.dtheta = ufl.TrialFunction(self.W), None
        self.u_n = u_n
        self.Fu_expr = kin.Fu(self.u, self.theta, u_n, theta_n)
        self.qmap = QuadratureMap(mesh, kin, material, self.Fu_expr, degree=kin.degree, tangent=True)
        tau, a = self.qmap.tau, self.qmap.a
        self.R_int = kin.internal_virtual_work(self.u, self.theta, tau, self.v)
        self.J_int = kin.internal_virtual_work_derivative(self.u, self.theta, tau, a, self.v,
                                                          self.du, self.dtheta)
        if self.mixed:
            self.R_int = self.R_int + kin.dilatation_residual(self.u, self.theta, self.q)
            self.J_int = self.J_int + kin.dilatation_residual_derivative(self.u, self.q, self.du,
                                                                         self.dtheta)
        self.load = fem.Constant(mesh, PETSc.ScalarType(0.0))
        self.lam = 0.0
        self._extra_R = []
        self._extra_J = []
        # corrections of the extrapolated predictor, predict(lam), each changing owned entries of w (the
        # contact pairs keep their committed gaps: PenaltyContact.attach); applied with predictor "contact"
        self.predictors = []
        # called with no argument whenever the state w is set (Newton iterates, line-search trials): what
        # depends on it outside UFL (a meshed tool's nodal gaps: ContactPair._nodal_gap)
        self.state_hooks = []
        # terms assembled outside the forms (contact between facet groups of the body:
        # static_surface_contact.SurfaceContactTerm): residual(b) adds to the residual vector, jacobian(A) to
        # the Jacobian, both with global indices, at the state of the last residual
        self.terms = []
        self.dirichlet = DirichletConditions(self.V, self.W)    # prescribed displacements, scaled by lam
        self.options = dict(rtol=rtol, atol=atol, max_iterations=max_iterations,
                            linesearch=linesearch, stol=stol, linear_solver=linear_solver,
                            linear_rtol=linear_rtol, linear_max_iterations=linear_max_iterations,
                            jacobian_every=int(jacobian_every), jacobian_rate=float(jacobian_rate),
                            predictor=predictor)
        self._condensed = None      # the python PC of linear_solver "gamg" with q1p0
        self._ksp_iterations = []   # GMRES iterations per Newton step (linear_solver "gamg", q1)
        self.is_set_up = False     # setup() done: forms compiled, SNES and its linear solver built
        # records
        self.increments = []    # dicts per converged increment
        self.norms = []         # residual norms of the current solve
        self.total_iterations = 0
        self.cutbacks = []      # failed attempts followed by a halved step (load_factor, step, iterations, reason)
        self.linesearch_retries = []    # failed attempts retried at the same step with the other line search
        self.total_iterations_failed = 0
        self.mumps_workspace_raises = []    # (load_factor, infog1, icntl14) per ICNTL(14) raise
        # where the time goes [s], summed over the solver's life (benchmarks/bench_static.py): the material
        # update, the residual's assembly (with lifting and boundary values), the Jacobian's assembly, and the
        # linear solves (SNES.solve less its callbacks: factorisations, triangular solves, line-search vector
        # work); ``jacobians``: the Jacobians assembled (and so factorised)
        self.times = dict(material=0.0, residual_assembly=0.0, jacobian_assembly=0.0, linear=0.0)
        self.restart = StaticRestart(self)          # the state a resumed run needs (checkpoints)
        self.jacobians = 0

    # -- problem definition -------------------------------------------------------------------
    def log(self, msg):
        if self.verbose and self.comm.rank == 0:
            if self.log_to is not None:
                self.log_to(msg)
            else:
                print(msg, flush=True)

    def add_dirichlet(self, component, facet_tags, tag, value=0.0, where=None):
        """u[component] = lam * value on the facets: :meth:`DirichletConditions.add
        <fenics_plast.solvers.dirichlet.DirichletConditions.add>`."""
        return self.dirichlet.add(component, facet_tags, tag, value, where, self.lam)

    def add_prescribed(self, component, facet_tags, tag, value):
        """u[component] = value(X, lam) on the facets: :meth:`DirichletConditions.add_prescribed
        <fenics_plast.solvers.dirichlet.DirichletConditions.add_prescribed>`."""
        return self.dirichlet.add_prescribed(component, facet_tags, tag, value, self.lam)

    def add_residual(self, R, J=None):
        """Extra residual term (e.g. a pressure, using self.load, self.u, self.v)."""
        self._extra_R.append(R)
        if J is None:
            J = ufl.derivative(R, self.w, ufl.TrialFunction(self.W))
        self._extra_J.append(J)

    def constrained_dofs(self, component, facet_tags, tag, where=None):
        """Owned W-dof indices of u[component] on the facets (reactions): :meth:`DirichletConditions.dofs
        <fenics_plast.solvers.dirichlet.DirichletConditions.dofs>`."""
        return self.dirichlet.dofs(component, facet_tags, tag, where)

    @property
    def bcs(self):
        return self.dirichlet.bcs

    # -- PETSc objects ------------------------------------------------------------------------
    def setup(self):
        """Compile the forms (with the extra terms added so far) and create the SNES; calling it again
        (after adding terms) replaces the previous SNES and its options."""
        self.close()
        R = self.R_int
        J = self.J_int
        for r in self._extra_R:
            R = R + r
        for j in self._extra_J:
            J = J + j
        self.R_form = fem.form(R)
        self.J_form = fem.form(J)
        self.Rint_form = fem.form(self.R_int)
        self.b = fpetsc.create_vector(self.R_form)
        self.r_int = fpetsc.create_vector(self.Rint_form)
        self.A = fpetsc.create_matrix(self.J_form)
        if self.terms:          # their entries couple nodes the forms do not: the pattern grows
            self.A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
        self.x = dc.petsc_vec(self.w).duplicate()   # SNES solution, distinct from w's own Vec
        self.prefix = f"fp_static_{next(_prefix_counter)}_"
        opts = PETSc.Options()
        o = self.options
        snes_opts = {
            "snes_type": "newtonls", "snes_linesearch_type": o["linesearch"],
            "snes_rtol": o["rtol"], "snes_atol": o["atol"], "snes_stol": o["stol"],
            "snes_max_it": o["max_iterations"], "snes_max_funcs": 10 * o["max_iterations"] + 10,
            "snes_error_if_not_converged": False,
        }
        gamg = o["linear_solver"] == "gamg"
        if not gamg:
            snes_opts.update({"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps",
                              "mat_mumps_icntl_14": 100, "ksp_error_if_not_converged": False})
        elif self.mixed:        # outer preonly around the condensing python PC; its inner GMRES + GAMG
            snes_opts.update({"ksp_type": "preonly", "ksp_error_if_not_converged": False})
            snes_opts.update({k[len(self.prefix):]: v for k, v in krylov.gamg_options(
                self.prefix + "inner_", o["linear_rtol"], o["linear_max_iterations"]).items()})
        else:
            snes_opts.update({k[len(self.prefix):]: v for k, v in krylov.gamg_options(
                self.prefix, o["linear_rtol"], o["linear_max_iterations"]).items()})
        for k, v in snes_opts.items():
            opts[self.prefix + k] = v
        xg = self.mesh.geometry.x
        self._extent = self.comm.allreduce(float(np.abs(xg).max()) if xg.size else 0.0, op=MPI.MAX)
        self.snes = snes = PETSc.SNES().create(self.comm)
        snes.setOptionsPrefix(self.prefix)
        # weak callbacks: SNES holds them strongly, and a strong reference back to the solver would be a
        # cycle through PETSc that the garbage collector cannot see (the solver would never be freed)
        snes.setFunction(_weak(self._residual), self.b)
        snes.setJacobian(_weak(self._jacobian), self.A)
        snes.setMonitor(_weak(self._monitor))
        snes.setConvergenceTest(_weak(self._converged))
        snes.setFromOptions()
        snes.getKSP().setFromOptions()
        if gamg:
            self._setup_gamg()
        self.is_set_up = True

    def _setup_gamg(self):
        """Rigid-body modes on the Jacobian (q1), or the condensing python PC (q1p0)."""
        modes = krylov.rigid_body_modes(self.V, self.x, self.kin.geometry)
        if not self.mixed:
            self.A.setNearNullSpace(PETSc.NullSpace().create(vectors=modes, comm=self.comm))
            return
        is_u, is_t = krylov.displacement_index_sets(self.W, self.V, self.theta_dofs, self.kin.gdim)
        self._condensed = krylov.CondensedDilatation(self.comm, is_u, is_t, modes, self.prefix + "inner_",
                                                     self.kin.gdim)
        pc = self.snes.getKSP().getPC()
        pc.setType(PETSc.PC.Type.PYTHON)
        pc.setPythonContext(self._condensed)

    @property
    def linear_solver_text(self) -> str:
        """The linear solve of a Newton iteration, in words (the run's log)."""
        newton = ("" if self.options["jacobian_every"] <= 1 else
                  f"; modified Newton, a new Jacobian every {self.options['jacobian_every']} iterations at most")
        if self.options["linear_solver"] == "gamg":
            return "gamg (GMRES + GAMG" + (", the dilatation condensed first" if self.mixed else "") + newton + ")"
        return f"mumps (LU{newton})"

    @property
    def linear_iterations(self):
        """Iterations of the iterative linear solves so far (linear_solver "gamg"), one per Newton step;
        empty for MUMPS."""
        if self._condensed is not None:
            return list(self._condensed.iterations)
        return list(getattr(self, "_ksp_iterations", []))

    def close(self):
        """Destroy the SNES and remove this solver's entries from PETSc's global options database, which
        holds at most 512 (tests and studies create many solvers). Called by :meth:`setup` and when the
        solver is garbage-collected; a later :meth:`run` sets up again."""
        prefix = getattr(self, "prefix", None)
        if prefix is None:
            return
        opts = PETSc.Options()
        for name in [k for k in opts.getAll() if k.startswith(prefix)]:
            opts.delValue(name)
        self.prefix = None
        if getattr(self, "_condensed", None) is not None:
            self._condensed.destroy()
            self._condensed = None
        if getattr(self, "snes", None) is not None:
            self.snes.destroy()
            self.snes = None
        self.is_set_up = False

    def __del__(self):
        try:
            self.close()
        except Exception:       # interpreter shutdown: PETSc may be gone already
            pass

    def set_linesearch(self, kind):
        PETSc.Options()[self.prefix + "snes_linesearch_type"] = kind
        self.snes.setFromOptions()

    def _monitor(self, snes, its, norm):
        self.norms.append(float(norm))
        if its > 0 and self._condensed is None and self.options["linear_solver"] == "gamg":
            self._ksp_iterations.append(snes.getKSP().getIterationNumber())
        if self.progress is not None:       # live Newton count within the increment (throttled)
            self.progress.update(self.lam_converged, newton=its)

    def _converged(self, snes, its, norms):
        """SNES convergence test: PETSc's default one (SNESConvergedDefault: atol, rtol relative to the
        first residual, stol, divergence, function count), and a stall at the round-off floor
        (|R| <= roundoff_floor and less than a tenfold decrease), which counts as converged. It is a
        test and not the monitor's doing because PETSc 3.18 calls the monitor before the test of an
        iteration and PETSc 3.22 after it."""
        xnorm, ynorm, fnorm = norms
        R = PETSc.SNES.ConvergedReason
        rtol, atol, stol, _ = snes.getTolerances()
        previous = self._fnorm_previous
        self._fnorm_previous = fnorm
        if its == 0:
            self._fnorm_first = fnorm
        if fnorm != fnorm:
            return R.DIVERGED_FNORM_NAN
        if fnorm < atol:
            return R.CONVERGED_FNORM_ABS
        if snes.getFunctionEvaluations() >= snes.getMaxFunctionEvaluations() >= 0:
            return R.DIVERGED_FUNCTION_COUNT
        if its > 0:
            if fnorm <= rtol * self._fnorm_first:
                return R.CONVERGED_FNORM_RELATIVE
            if ynorm < stol * xnorm:
                return R.CONVERGED_SNORM_RELATIVE
            if fnorm > SNES_DIVERGENCE_TOLERANCE * self._fnorm_first:
                return R.DIVERGED_DTOL
            if fnorm <= self.roundoff_floor and fnorm > 0.1 * previous:
                return R.CONVERGED_FNORM_ABS
        return R.ITERATING

    _fnorm_first = _fnorm_previous = math.inf

    def _set_state(self, x):
        # SNES trial vectors (line search: x - s dx) carry stale ghost values; apply_lifting reads them
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        x.copy(dc.petsc_vec(self.w))
        self.w.x.scatter_forward()
        for hook in self.state_hooks:
            hook()

    def _residual(self, snes, x, b):
        t0 = time.perf_counter()
        self._set_state(x)
        bad = False
        try:
            self.qmap.update(tangent=True)
        except MaterialUpdateError as e:
            bad = True
            self._bad_message = str(e)
        t1 = time.perf_counter()
        # every rank assembles (collective); a failed update anywhere poisons the residual
        with b.localForm() as bl:
            bl.set(0.0)
        fpetsc.assemble_vector(b, self.R_form)
        if not self.dirichlet.values_reached(x):   # else the lifting A (g - x) is zero: skipped, same vector
            dc.apply_lifting(b, [self.J_form], bcs=[self.bcs], x0=[x], alpha=-1.0)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        if self.terms:
            for term in self.terms:
                term.residual(b)
            b.assemble()
        fpetsc.set_bc(b, self.bcs, x, -1.0)
        self._bad_update = bad      # of the latest evaluation (the state SNES ends on)
        if bad:
            with b.localForm() as bl:
                bl.set(np.nan)
        t2 = time.perf_counter()
        self.times["material"] += t1 - t0
        self.times["residual_assembly"] += t2 - t1
        self._callback_time += t2 - t0

    def _jacobian(self, snes, x, A, P):
        if not self._jacobian_due(snes.getIterationNumber()):
            return          # A untouched: its state is unchanged, so PETSc keeps its factorisation
        t0 = time.perf_counter()
        A.zeroEntries()
        fpetsc.assemble_matrix(A, self.J_form, bcs=self.bcs)
        if self.terms:
            A.assemble(PETSc.Mat.AssemblyType.FLUSH)
            for term in self.terms:
                term.jacobian(A)
        A.assemble()
        dt = time.perf_counter() - t0
        self.times["jacobian_assembly"] += dt
        self._callback_time += dt
        self.jacobians += 1
        # Round-off floor of the residual [N]: eps |A|_inf (extent + |x|_inf) x ROUNDOFF_FACTOR. A nearly
        # incompressible material (bulk modulus >> shear modulus) or a stiff contact penalty lifts it
        # above atol, where Newton stalls (measured: 0.2 to 2 x the estimate); see _at_roundoff.
        self.roundoff_floor = ROUNDOFF_FACTOR * np.finfo(float).eps * A.norm(PETSc.NormType.INFINITY) * (
            self._extent + x.norm(PETSc.NormType.INFINITY))

    def _jacobian_due(self, its) -> bool:
        """Whether iteration ``its`` of an increment assembles and factorises a new Jacobian: always with
        ``jacobian_every`` = 1 (full Newton); otherwise (modified Newton) at the first iteration of every
        increment, at every ``jacobian_every``-th iteration, and whenever the last iteration reduced the
        residual by less than the factor ``jacobian_rate`` (|R_k| > jacobian_rate |R_k-1|)."""
        o = self.options
        every = o["jacobian_every"]
        if every <= 1 or its == 0 or its % every == 0:
            return True
        n = self.norms
        return len(n) >= 2 and n[-1] > o["jacobian_rate"] * n[-2]

    _callback_time = 0.0    # seconds spent in the residual and Jacobian callbacks of the current SNES solve
    #: the physical time of a unit of load factor [s] (analysis.duration): the material update's time increment
    #: (Johnson-Cook's strain rate) is the increment's share of it; 0: no physical time (no rate term)
    time_scale = 0.0

    # -- loading ------------------------------------------------------------------------------
    def set_load(self, lam):
        self.lam = float(lam)
        self.load.value = self.lam
        self.dirichlet.set_load(self.lam)

    def solve_increment(self, lam, lam_prev_step=None, tangent_predictor=False):
        """Newton solve at load factor lam from the last converged state. Returns (ok, its, reason).
        The predictor (Newton's first iterate) is :meth:`_predict`'s."""
        if not self.is_set_up:
            self.setup()
        self.set_load(lam)
        self.qmap.dt[0] = (self.lam - self.lam_converged) * self.time_scale    # [s]; 0: no physical time
        self._predict(lam, lam_prev_step, tangent_predictor)
        self.norms = []
        self._bad_update = False
        # absolute tolerance: atol, or rtol x the internal-force norm of the last converged state
        # (a residual below ~1e-12 of the forces is round-off; tiny cut-back steps must not chase it)
        o = self.options
        self.snes.setTolerances(atol=max(o["atol"], o["rtol"] * self.force_scale))
        self._callback_time = 0.0
        t0 = time.perf_counter()
        try:
            self.snes.solve(None, self.x)
        except PETSc.Error as e:   # pragma: no cover - callbacks catch the expected failures
            self.log(f"  SNES error: {e}")
            return False, self.snes.getIterationNumber(), "petsc-error"
        finally:
            self.times["linear"] += time.perf_counter() - t0 - self._callback_time
        reason = self.snes.getConvergedReason()
        its = self.snes.getIterationNumber()
        ksp_reason = self.snes.getKSP().getConvergedReason()
        if self._condensed is not None and self._condensed.failed_reason < 0:
            ksp_reason, self._condensed.failed_reason = self._condensed.failed_reason, 0
        bad = self.comm.allreduce(bool(self._bad_update), op=MPI.LOR)
        if bad and not self._bad_update:
            self._bad_message = "material update failed on another rank"
        self._bad_update = bad
        ok = reason > 0 and not bad and all(np.isfinite(self.norms))
        why = _REASONS.get(reason, str(reason))
        if not ok and not bad and ksp_reason >= 0 and self._at_roundoff():
            ok, why = True, f"{why}, residual below its round-off floor {self.roundoff_floor:.3g} N"
        if self._bad_update:
            why = "material update failed: " + self._bad_message
        elif ksp_reason < 0:
            why += f" (linear solve failed, KSP reason {ksp_reason}{self._mumps_info()})"
        if ok:
            self.total_iterations += its
            self._set_state(self.x)
            self.qmap.update(tangent=False)
        else:
            self.total_iterations_failed += its
        return ok, its, why

    def _predict(self, lam, lam_prev_step, tangent_predictor):
        """Set Newton's first iterate ``self.x`` (and ``w``) for the increment from the converged state to lam.

        * extrapolation (``lam_prev_step``, the last converged increment, and not ``tangent_predictor``): that
          increment scaled to this one, corrected by ``self.predictors`` (contact nodes at their committed
          gaps; option ``predictor`` "contact" only), then the Dirichlet values at lam on their nodes;
        * tangent predictor (``tangent_predictor`` without ``lam_prev_step``): the converged state, the
          Dirichlet values too, so that Newton's first correction imposes their increment through the
          consistent tangent, which spreads it over the body (imposing a large increment on the boundary
          nodes alone can invert the cells next to them);
        * both given (the first increment of a load step after another, option ``predictor`` "contact": the
          load stepping offers the last increment then): whichever of the two starts with
          the smaller residual (two residual evaluations). A step that goes on moving the tools and
          boundaries as the last one did is extrapolated (the tangent predictor leaves every contact node
          where it was while the tool moves into it: the 3-D quarter punch's second step took 36 Newton
          iterations and a cut-back to get going); one that reverses them (unloading) takes the tangent;
        * neither: the converged state with the Dirichlet values at lam."""
        extrapolate = bool(lam_prev_step) and lam_prev_step > 0
        if tangent_predictor and extrapolate:
            self._predict(lam, lam_prev_step, False)
            r_extrapolated = self._predictor_residual()
            self._predict(lam, None, True)
            r_tangent = self._predictor_residual()
            chosen = "extrapolated" if r_extrapolated < r_tangent else "tangent"
            if chosen == "extrapolated":
                self._predict(lam, lam_prev_step, False)
            self.log(f"  new load step at {self.lam_converged:.6g}: {chosen} predictor (|R| {r_extrapolated:.3e} "
                     f"extrapolated, {r_tangent:.3e} tangent)")
            return
        self.w.x.array[:] = self.w_n.x.array
        if extrapolate and not tangent_predictor:
            s = (lam - self.lam_converged) / lam_prev_step
            self.w.x.array[:] += s * (self.w_n.x.array - self.w_nm1.x.array)
            if self.options["predictor"] == "contact":
                for predict in self.predictors:
                    predict(lam)
                self.w.x.scatter_forward()
        dc.petsc_vec(self.w).copy(self.x)
        if not tangent_predictor:
            fpetsc.set_bc(self.x, self.bcs)
        self.x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)

    def _predictor_residual(self) -> float:
        """|R| at ``self.x`` (collective; inf where the material update fails or the residual is not finite)."""
        self._residual(self.snes, self.x, self.b)
        r = self.b.norm()
        self._bad_update = False
        return r if np.isfinite(r) else math.inf

    def _mumps_info(self):
        try:
            F = self.snes.getKSP().getPC().getFactorMatrix()
            return f", MUMPS INFOG(1) = {F.getMumpsInfog(1)}"
        except Exception:  # noqa: BLE001
            return ""

    def failure(self, message):
        """RunError ending with what converged so far, carrying it in its results."""
        return RunError(f"{message} {len(self.increments)} increments converged up to load factor "
                        f"{self.lam_converged:.6g}.",
                        results={"converged": False, "increments": len(self.increments),
                                 "load_factor": self.lam_converged})

    def raise_mumps_workspace(self):
        """After a failed solve: if MUMPS ran out of workspace (INFOG(1) in MUMPS_WORKSPACE_ERRORS),
        double ICNTL(14) (extra workspace in %, at least 20) and return True: retry the same step.
        Raises RunError when ICNTL(14) would exceed MUMPS_MAX_ICNTL14; False for any other failure."""
        ksp = self.snes.getKSP()
        if ksp.getConvergedReason() >= 0:
            return False
        try:
            F = ksp.getPC().getFactorMatrix()
            info, icntl14 = F.getMumpsInfog(1), F.getMumpsIcntl(14)
        except Exception:  # noqa: BLE001 - not MUMPS, or no factor
            return False
        if info not in MUMPS_WORKSPACE_ERRORS:
            return False
        new = max(2 * icntl14, 20)
        if new > MUMPS_MAX_ICNTL14:
            raise self.failure(
                f"static solver: the direct solver MUMPS ran out of workspace (INFOG(1) = {info}) at load "
                f"factor {self.lam:.6g} even with ICNTL(14) = {icntl14} % extra workspace: the linear system "
                f"is extremely ill-conditioned (Poisson's ratio too close to 0.5, or a huge contact penalty?).")
        self.log(f"  MUMPS ran out of workspace (INFOG(1) = {info}) at load {self.lam:.6g}: "
                 f"ICNTL(14) {icntl14} -> {new} %, same step again")
        PETSc.Options()[self.prefix + "mat_mumps_icntl_14"] = new
        ksp.getPC().reset()             # the next set-up builds a new factor with the new option
        ksp.setFromOptions()
        self.mumps_workspace_raises.append(dict(load_factor=self.lam, infog1=info, icntl14=new))
        return True

    def _at_roundoff(self):
        """Whether the residual at SNES's final iterate is below the round-off floor (collective): Newton
        stalled where the arithmetic cannot do better, which counts as converged."""
        if not self.roundoff_floor > 0.0:
            return False
        self._residual(self.snes, self.x, self.b)
        r = self.b.norm()                 # NaN on every rank if the update failed on one
        if not np.isfinite(r) or r > self.roundoff_floor:
            return False
        self.norms.append(float(r))
        return True

    force_scale = 0.0
    roundoff_floor = 0.0    # residual round-off estimate [N], updated with every Jacobian

    def commit(self):
        self.force_scale = self.internal_force_norm()
        self.qmap.commit()
        self.w_nm1.x.array[:] = self.w_n.x.array
        self.w_n.x.array[:] = self.w.x.array
        self.lam_converged = self.lam

    def restore(self):
        self.w.x.array[:] = self.w_n.x.array
        self.set_load(self.lam_converged)

    lam_converged = 0.0

    def out_of_balance(self, lam):
        """The residual [N] (owned entries of w's equations, Dirichlet rows zero) at the converged state
        with the load at ``lam``: the force a Newton solve there has to remove (collective)."""
        self.restore()
        self._predict(lam, None, False)
        self._residual(self.snes, self.x, self.b)
        return np.array(self.b.array_r)

    def run(self, increments=default("analysis.increments"), min_increment=default("analysis.min_increment"),
            max_increment=default("analysis.max_increment"), lam_end=1.0, callback=None, growth=1.5,
            fast_iterations=default("analysis.fast_iterations"), checkpoint_every=default("output.checkpoint_every", analysis="static"),
            on_checkpoint=None, resume=None):
        """Drive lam from its current value to lam_end: :func:`fenics_plast.solvers.load_stepping.drive`
        (the increments, cut-back and retries; this class solves one increment, :meth:`solve_increment`)."""
        return load_stepping.drive(self, increments, min_increment, max_increment, lam_end, callback, growth,
                                   fast_iterations, checkpoint_every, on_checkpoint, resume)

    # -- post-processing ----------------------------------------------------------------------
    def internal_force(self):
        """Assembled internal force R_u (no BCs), ghost-accumulated; returns the owned array."""
        with self.r_int.localForm() as rl:
            rl.set(0.0)
        fpetsc.assemble_vector(self.r_int, self.Rint_form)
        self.r_int.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        return self.r_int.array_r

    def internal_force_norm(self):
        """2-norm of the assembled internal force (reactions included), all ranks."""
        self.internal_force()
        return self.r_int.norm()

    def reaction(self, dofs):
        """Total reaction (sum of R_u over the given owned dofs, all ranks)."""
        local = float(np.sum(self.internal_force()[dofs]))
        return self.comm.allreduce(local, op=MPI.SUM)

    def equation_numbers(self, local_w):
        """Global equation numbers (PETSc's) of the entries ``local_w`` (any shape) of ``w``'s local array, -1
        where a Dirichlet condition holds the dof (PETSc skips negative indices): the rows and columns of
        terms assembled outside the forms (``terms``). Call after every Dirichlet condition is added."""
        imap, bs = self.W.dofmap.index_map, self.W.dofmap.index_map_bs
        local_w = np.asarray(local_w, dtype=np.int64)
        flat = local_w.ravel()
        glob = imap.local_to_global((flat // bs).astype(np.int32)).astype(np.int64) * bs + flat % bs
        constrained = np.zeros(len(self.w.x.array), dtype=bool)
        for bc in self.bcs:
            constrained[dc.bc_dofs(bc)] = True
        return np.where(constrained[flat], -1, glob).reshape(local_w.shape).astype(PETSc.IntType)

    def displacement_space(self):
        """(the displacement space as a space of its own, the map from its unrolled dofs into
        ``w``): the collapsed subspace for q1p0 (mixed with the dilatation), the space itself for q1."""
        if self.mixed:
            Vc, m = self.V.collapse()
            return Vc, np.asarray(m)
        im = self.V.dofmap.index_map
        return self.V, np.arange((im.size_local + im.num_ghosts) * self.V.dofmap.index_map_bs, dtype=np.int64)

    def displacement_function(self):
        """A persistent CG1 Function named "displacement" holding the current u (for XDMF)."""
        if not hasattr(self, "_u_out"):
            Vc, m = self.displacement_space()
            self._u_map = m if self.mixed else None
            self._u_out = fem.Function(Vc, name="displacement")
        if self._u_map is None:
            self._u_out.x.array[:] = self.w.x.array
        else:
            self._u_out.x.array[:] = self.w.x.array[self._u_map]
        return self._u_out

    def qp_jacobian(self):
        """det Fbar (= theta for q1p0, J for q1) at the owned quadrature points, shape (n,)."""
        if not hasattr(self, "_J_expr"):
            self._J_expr = fem.Expression(ufl.det(self.kin.Fbar(self.u, self.theta)), self.qmap.points)
            self._J_buf = np.zeros((self.qmap.n_owned, self.qmap.nq))
        dc.eval_expression(self._J_expr, self.mesh, self.qmap.cells, self._J_buf)
        return self._J_buf.reshape(-1)

    @property
    def dofs(self):
        imap = self.W.dofmap.index_map
        return imap.size_global * self.W.dofmap.index_map_bs


_REASONS = {v: k for k, v in PETSc.SNES.ConvergedReason.__dict__.items() if not k.startswith("_")}
