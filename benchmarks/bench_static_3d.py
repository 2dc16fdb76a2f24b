"""3-D static benchmark: the quarter round bar (meshes/round_bar_quarter.geo) clamped at z = 0 and pulled
into the plastic range at z = L, solved with MUMPS and with GMRES/CG + GAMG (analysis.linear_solver).

    python benchmarks/bench_static_3d.py                      # refine 4: 62,208 hexahedra, ~250k dofs, gamg
    python benchmarks/bench_static_3d.py --refine 2 --solver mumps gamg --element q1
    python benchmarks/bench_static_3d.py --refine 2 --ksp cg  # CG in place of GMRES (q1p0: the condensed solve)

Prints per run: cells, dofs, set-up time, solve time [s], Newton iterations, the linear iterations per
Newton step, the grip force [N], and (several solvers) the largest displacement difference between
them relative to the largest displacement. Not part of the test suite (minutes at refine 4).

Measured (shared 2-core machine, 1 rank, q1p0, linear rtol 1e-8; 2 increments):
  refine 1:    972 cells,   5,079 dofs: mumps 2.6 s, gamg 2.1 s (18 Newton its; 30-61 GMRES its)
  refine 2:  7,776 cells,  35,589 dofs: mumps 49.0 s, gamg 23.2 s (16 Newton its; 41-75 GMRES its);
             max |u_gamg - u_mumps| / max |u| = 3.6e-14
  refine 4: 62,208 cells, 266,223 dofs: gamg set-up 26.6 s, solve 368 s (19 Newton its, 55-87 GMRES
             its, mean 80; ~19 s per Newton iteration), grip force 33,362 N
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from fenics_plast.problem import parse_problem  # noqa: E402
from fenics_plast.runner_static import build_static  # noqa: E402

SCENE = f"""
[scene]
name = "bench_static_3d"
[analysis]
type = "static"
increments = 2
max_increment = 0.5
rtol = 1e-9
atol = 1e-6
[mesh]
file = "{ROOT / 'meshes' / 'round_bar_quarter.geo'}"
geometry = "3d"
[mesh.parameters]
radius = 6.4
length = 32.4
cells_radial = 6
cells_axial = 36
[materials.steel]
E = 200e3
nu = 0.3
[materials.steel.hardening]
law = "linear"
yield_stress = 250.0
modulus = 2000.0
[boundary.plane_x]
group = "symmetry_x"
type = "symmetry"
[boundary.plane_y]
group = "symmetry_y"
type = "symmetry"
[boundary.clamp]
group = "bottom"
type = "fixed"
components = ["x", "y", "z"]
[boundary.grip]
group = "top"
type = "displacement"
components = ["z"]
value = "0.2 * t"
"""


def run(refine, element, solver, ksp, rtol):
    comm = MPI.COMM_WORLD
    sets = [f"mesh.refine={refine}", f"mesh.element={element}", f"analysis.linear_solver={solver}",
            f"analysis.linear_rtol={rtol}"]
    problem = parse_problem(SCENE, ROOT / "benchmarks" / "bench.toml", sets)
    t0 = time.perf_counter()
    b = build_static(problem, comm)
    s = b.solver
    s.verbose = False
    if ksp is not None and solver == "gamg":
        key = s.prefix + ("inner_" if s.mixed else "") + "ksp_type"
        PETSc.Options()[key] = ksp
        (s._condensed.ksp if s.mixed else s.snes.getKSP()).setFromOptions()
    t_setup = time.perf_counter() - t0
    t0 = time.perf_counter()
    s.run(increments=2, max_increment=0.5)
    t_solve = time.perf_counter() - t0
    X = b.body.X
    u = b.positions() - X
    top = s.constrained_dofs(2, b.facet_tags, b.groups["top"][1])
    force = 4 * s.reaction(top)                     # the whole bar
    cells = b.mesh.topology.index_map(3).size_global
    res = dict(cells=cells, dofs=s.dofs, setup_s=t_setup, solve_s=t_solve, newton=s.total_iterations,
               linear=s.linear_iterations, force_N=force)
    s.close()
    return res, X, u


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--refine", type=int, default=4)
    ap.add_argument("--element", default="q1p0", choices=("q1p0", "q1"))
    ap.add_argument("--solver", nargs="+", default=["gamg"], choices=("mumps", "gamg"))
    ap.add_argument("--ksp", default=None, choices=("gmres", "cg"), help="Krylov method of the gamg solve")
    ap.add_argument("--rtol", type=float, default=1e-8)
    a = ap.parse_args()
    comm = MPI.COMM_WORLD
    out = {}
    for solver in a.solver:
        res, X, u = run(a.refine, a.element, solver, a.ksp, a.rtol)
        out[solver] = u
        if comm.rank == 0:
            lin = res["linear"]
            lin_text = f", linear its {min(lin)}-{max(lin)} (mean {np.mean(lin):.0f})" if lin else ""
            print(f"{solver:5s} {a.element} refine {a.refine}: {res['cells']} cells, {res['dofs']} dofs, "
                  f"{comm.size} rank(s): set-up {res['setup_s']:.1f} s, solve {res['solve_s']:.1f} s, "
                  f"{res['newton']} Newton its{lin_text}, force {res['force_N']:.6g} N", flush=True)
    if len(out) == 2:
        d = comm.allreduce(float(np.abs(out["mumps"] - out["gamg"]).max()), op=MPI.MAX)
        m = comm.allreduce(float(np.abs(out["mumps"]).max()), op=MPI.MAX)
        if comm.rank == 0:
            print(f"max |u_gamg - u_mumps| / max |u| = {d / m:.2e}")


if __name__ == "__main__":
    main()
