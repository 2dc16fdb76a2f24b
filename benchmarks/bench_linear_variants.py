"""What the static solver's linear solve could do instead of full Newton with MUMPS LU of the mixed matrix,
measured on a whole run: the 3-D quarter punch by default.

    python benchmarks/bench_linear_variants.py                       # 3-D punch, every variant, 3 rounds
    python benchmarks/bench_linear_variants.py --rounds 1 --variants shipped condensed
    python benchmarks/bench_linear_variants.py --scene demos/punch_stretching.toml

Variants (each a process of its own running the scene through the CLI, no XDMF, no plots; the solver is
changed from outside, by this script, so that the package keeps one way to solve):

* ``shipped``: full Newton, MUMPS LU of the mixed (u, theta) Jacobian, MUMPS's own ordering.
* ``condensed``: q1p0's DG0 dilatation condensed out exactly before MUMPS
  (:class:`fenics_plast.solvers.krylov.CondensedDilatation`, GAMG's route, with MUMPS LU as its inner
  solver; the condensed matrix kept as one object so that MUMPS analyses it once and only refactorises).
* ``lagged-k`` (k = 3, 6): Krylov-accelerated modified Newton: the Jacobian assembled at every iteration,
  factorised only every k-th iteration (PETSc's ``snes_lag_preconditioner``, kept across increments) and
  used as the preconditioner of GMRES (relative tolerance 1e-10, at most 50 iterations) on the current
  Jacobian: an exact Newton step while GMRES converges, without most factorisations.

Per variant: the process's wall time (median over the rounds; the rounds interleave the variants, so a
busy machine slows all of them alike), Newton iterations, LU factorisations and their time, triangular
solves, GMRES iterations, and the maximum punch force (the Newton tolerance is the scene's).

Measured (2-core shared machine, one invocation, medians of 3 rounds), 3-D quarter punch, 7,839 dofs:

    variant     wall[s] ratio newton  LU  LU[ms] analyses tri-solves GMRES  max force [kN]
    shipped       19.38  1.00    169  169   50.2        1        169     -  63.279657226
    condensed     21.65  1.12    169  169   46.7        1        169     -  63.279657226
    lagged-3      30.91  1.60    208   71   52.5        1       2904  2267  63.347943505
    lagged-6      42.03  2.17    221   40   52.9        1       4964  3968  63.359407621

Neither pays (docs/DESIGN.md, "The static Newton iteration and what it costs"): the condensation saves 7 %
of a factorisation and costs more than that; with the factorisation lagged, GMRES needs ~11 iterations per
Newton step and sometimes stops unconverged at 50, so Newton takes more iterations (and other increments:
the forces differ by 1e-3, the step-size error of the increments, not of Newton).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
VARIANTS = ("shipped", "condensed", "lagged-3", "lagged-6")

#: the child process: patch the solver for the variant, run the CLI, print one JSON line of figures
CHILD = r'''
import json, sys, time
from petsc4py import PETSc
PETSc.Log.begin()
from fenics_plast.solvers import krylov, static

variant, scene, out = sys.argv[1:4]
gmres = []


class PersistentCondensed(krylov.CondensedDilatation):
    """The package's condensation, with the condensed matrix given to MUMPS kept as one object whose values
    are copied in (an operator extracted anew is a new pattern to PETSc: MUMPS would analyse it every time)."""
    fixed = None

    def setUp(self, pc):
        ksp, self.ksp = self.ksp, _NoOperators()
        super().setUp(pc)           # S = A_uu - A_ut D^-1 A_tu, as the package computes it
        self.ksp = ksp
        if self.fixed is None:
            self.fixed = self.S.copy()
            ksp.setOperators(self.fixed)
        else:
            self.S.copy(self.fixed, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)


class _NoOperators:
    def setOperators(self, *args):
        pass


setup = static.StaticSolver.setup


def patched_setup(self):
    setup(self)
    o = PETSc.Options()
    if variant == "condensed" and self.mixed:
        inner = self.prefix + "inner_"
        for k, v in {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps",
                     "mat_mumps_icntl_14": 100}.items():
            o[inner + k] = v
        is_u, is_t = krylov.displacement_index_sets(self.W, self.V, self.theta_dofs, self.kin.gdim)
        self._condensed = PersistentCondensed(self.comm, is_u, is_t, [], inner, self.kin.gdim)
        pc = self.snes.getKSP().getPC()
        pc.setType(PETSc.PC.Type.PYTHON)
        pc.setPythonContext(self._condensed)
    elif variant.startswith("lagged-"):
        for k, v in {"ksp_type": "gmres", "ksp_rtol": 1e-10, "ksp_atol": 0.0, "ksp_max_it": 50,
                     "snes_lag_preconditioner": int(variant.split("-")[1]),
                     "snes_lag_preconditioner_persists": True}.items():
            o[self.prefix + k] = v
        self.snes.setFromOptions()
        self.snes.getKSP().setFromOptions()


monitor = static.StaticSolver._monitor


def patched_monitor(self, snes, its, norm):
    monitor(self, snes, its, norm)
    if its > 0:
        gmres.append(snes.getKSP().getIterationNumber())


static.StaticSolver.setup = patched_setup
static.StaticSolver._monitor = patched_monitor
from fenics_plast import cli
t0 = time.perf_counter()
status = cli.main(["run", scene, "--out", out, "--set", "output.xdmf=false", "--set", "output.plots=false"])
wall = time.perf_counter() - t0
summary = json.load(open(out + "/summary.json"))
ev = {e: PETSc.Log.Event(e).getPerfInfo() for e in ("MatLUFactorNum", "MatLUFactorSym", "MatSolve")}
force = max((v for k, v in summary.items() if k.startswith("max_") and k.endswith("force_kN")), default=None)
print(json.dumps(dict(status=status, wall=wall, newton=summary.get("newton_iterations"),
                      lu=ev["MatLUFactorNum"]["count"], lu_s=ev["MatLUFactorNum"]["time"],
                      analyses=ev["MatLUFactorSym"]["count"], solves=ev["MatSolve"]["count"],
                      gmres=sum(gmres) if variant.startswith("lagged-") else None, force=force)))
sys.stdout.flush()
'''


def run(variant: str, scene: str, tmp: Path, tag: str) -> dict:
    out = tmp / f"{variant}_{tag}"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    p = subprocess.run([sys.executable, "-c", CHILD, variant, scene, str(out)], cwd=ROOT, env=env,
                       capture_output=True, text=True)
    lines = [line for line in p.stdout.splitlines() if line.startswith("{")]
    if p.returncode != 0 or not lines:
        raise RuntimeError(f"{variant}: exit {p.returncode}\n{p.stderr[-2000:]}")
    return json.loads(lines[-1])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", default="demos/punch_stretching_3d.toml")
    ap.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=VARIANTS)
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    results = {v: [] for v in args.variants}
    with tempfile.TemporaryDirectory(prefix="fp_linear_") as tmp:
        run(args.variants[0], args.scene, Path(tmp), "warm-up")      # the numba kernels into their cache
        for r in range(args.rounds):
            for v in args.variants:
                results[v].append(run(v, args.scene, Path(tmp), str(r)))
                print(f"  round {r + 1} {v:10s} {results[v][-1]['wall']:7.2f} s", flush=True)
    base = statistics.median(x["wall"] for x in results[args.variants[0]])
    print(f"\n{args.scene}: median of {args.rounds} interleaved rounds (wall: the CLI's run in its process)")
    print(f"{'variant':11s} {'wall[s]':>8s} {'ratio':>6s} {'newton':>6s} {'LU':>4s} {'LU[ms]':>7s} {'analyses':>8s} "
          f"{'tri-solves':>10s} {'GMRES':>6s} {'max force':>14s}")
    for v, rs in results.items():
        wall = statistics.median(x["wall"] for x in rs)
        x = rs[0]
        lu_ms = 1e3 * statistics.median(y["lu_s"] / max(y["lu"], 1) for y in rs)
        print(f"{v:11s} {wall:8.2f} {wall / base:6.2f} {x['newton']:6d} {x['lu']:4d} {lu_ms:7.1f} {x['analyses']:8d} "
              f"{x['solves']:10d} {str(x['gmres'] or '-'):>6s} {x['force']:14.9f}")


if __name__ == "__main__":
    main()
