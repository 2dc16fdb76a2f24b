"""Static solver cost, before and after: time per Newton iteration split by phase, and the process time.

    python benchmarks/bench_static.py                          # 2-D punch, 3-D quarter punch, bar: before/after
    python benchmarks/bench_static.py --before-blas reference openblas   # before on each BLAS, then after
    python benchmarks/bench_static.py --scenes punch_3d --before 1ecb83e
    python benchmarks/bench_static.py --scenes --large         # the >= 50k-dof 3-D punch: mumps/gamg, 1/2 ranks
    python benchmarks/bench_static.py --scenes --large --large-runs gamg:2
    python benchmarks/bench_static.py --scenes --process       # process against solve time, 2-D punch, Taylor bar
    python benchmarks/bench_static.py --before none --rates    # Newton's observed convergence orders

"Before" is the tree of git revision ``--before`` (default: the commit before the static-speed work),
exported with ``git archive`` into a temporary folder and run from there; "after" is this tree. Each tree first
runs each scene once untimed, which compiles its numba kernels into its cache. All columns run one after the other in this invocation,
as the CLI (``fenics-plast run``) in a process of their own, under cProfile and PETSc's ``-log_view`` (the
same instruments for all; cProfile adds ~3 % here), without XDMF. Per run:

* dofs, Newton iterations, Jacobians assembled (PETSc's SNESJacobianEval count);
* per Newton iteration [ms]: material update (``QuadratureMap.update``: Fu at the points and the return map,
  with the tangent), assembly (dolfinx's assemble_matrix, assemble_vector, apply_lifting and coefficient
  packing), factorisation (PETSc's MatLUFactor* events), triangular solves (MatSolve) and the rest of the
  linear work (SNES.solve less the callbacks and those two);
* contact: a tree with the compiled tool contact (``fenics_plast.solvers.static_tool_contact``): its terms' time
  in the run's profile (not a part of "assembly"); a tree whose contact is UFL forms: the cost of assembling
  those forms alone (Jacobian and residual, measured in this process, times the run's Jacobians and
  residuals), a part of "assembly";
* solve [s]: the load stepping (``StaticSolver.run``); process [s]: the whole CLI process, start to exit;
  the numeric and symbolic factorisation counts and the maximum punch force (or force) of each column.

The machine is shared: compare the columns of one invocation only. Measured (2-core machine, one
invocation, ``--scenes punch_3d punch_2d --before-blas reference openblas``), 3-D quarter punch, process:
before on the reference BLAS 122.3 s, before on OpenBLAS 81.4 s, after 35.6 s (3.44x; 254 -> 169 Newton
iterations, the contact predictor; force 1.2e-3 apart, the increments differ); per Newton iteration after:
material 28, assembly 58, compiled contact 2.7 (the contact forms had cost 32 of the assembly's 128),
factorisation 95 ms. (Counts before 2026-11-26 evening, 157.8 s
before and 3.80x, timed the "before" kernels' compilation: the runs inherited the NUMBA_CACHE_DIR that this
script's own import of the after tree set; they start from :data:`ENVIRONMENT` now.)

``--large`` runs the 3-D punch refined twice in every direction (10,800 hexahedra, 52,665 dofs) to 4 mm of
punch travel, after only, with MUMPS and GAMG, on 1 and 2 ranks (``--large-runs``): time per Newton
iteration, its split, and the peak memory of the largest process. Measured: MUMPS 6.45 s (1 rank, 831 MB), 5.05 s (2 ranks, 622 MB); GAMG 14.7 s (1 rank, 720 MB),
19.1 s (2 ranks, 523 MB, with another job on the cores); 70 Newton iterations each, the same force.
"""
from __future__ import annotations

import argparse
import json
import os
import pstats
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BEFORE = "1ecb83e"          # the last commit before the static-speed issue
NO_FILES = ["--set", "output.xdmf=false"]       # the scenes' plots stay (their cost is part of the process)

#: name -> (scene file, --set overrides)
SCENES = {
    "punch_2d": ("demos/punch_stretching.toml", []),
    "punch_3d": ("demos/punch_stretching_3d.toml", []),
    "bar": ("demos/bar_tension.toml", []),
}
#: the >= 50k-dof scene: the 3-D quarter punch, mesh refined 2x, to 4 mm of punch travel in 8 increments
LARGE = ("demos/punch_stretching_3d.toml",
         ["--set", "mesh.refine=2", "--set", "steps.to_20mm.end=0.05", "--set", "steps.to_20mm.increments=4",
          "--set", "steps.to_40mm.end=0.1", "--set", "steps.to_40mm.increments=4", "--set", "output.plots=false"])

#: the small scenes whose process time should be dominated by their solve
PROCESS_SCENES = ("demos/punch_stretching.toml", "demos/taylor_bar.toml")

#: a CLI run under cProfile that ends as the command does (``cli.exit_promptly``, where the tree has it): the
#: profile is written first (``python -m cProfile`` writes it at an exit that the prompt one skips)
PROFILED = """import cProfile, sys
from fenics_plast import cli
profile = cProfile.Profile()
status = profile.runcall(cli.main, {args!r})
profile.dump_stats({prof!r})
getattr(cli, "exit_promptly", sys.exit)(status)"""

#: the environment the runs start from, as this script found it: importing fenics_plast here (the contact
#: cost, in process) sets NUMBA_CACHE_DIR to the kernel cache of this tree's sources, which a run of another
#: tree must not inherit (it would compile into, or load from, the wrong tree's cache)
ENVIRONMENT = dict(os.environ)

BLAS_DIRS = {"reference": "/usr/lib/x86_64-linux-gnu/blas", "openblas": "/usr/lib/x86_64-linux-gnu/openblas-serial"}


def export_tree(rev: str, dest: Path) -> Path:
    """The files of git revision ``rev`` in ``dest`` (git archive; no checkout, the repository untouched)."""
    dest.mkdir(parents=True)
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", rev], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(dest)], input=archive, check=True)
    return dest


def petsc_events(path: Path) -> dict:
    """{event: (count, max time [s])} from a PETSc -log_view file."""
    events = {}
    for line in path.read_text(errors="replace").splitlines():
        m = re.match(r"^(\w+)\s+(\d+)\s+[\d.]+\s+([\d.e+-]+)\s", line)
        if m:
            events[m.group(1)] = (int(m.group(2)), float(m.group(3)))
    return events


def profile_times(path: Path) -> dict:
    """Seconds by phase from a cProfile file of a CLI run."""
    st = pstats.Stats(str(path)).stats      # (file, line, name) -> (cc, nc, tottime, cumtime, callers)
    tot = lambda pred: sum(v[2] for k, v in st.items() if pred(k))    # noqa: E731
    cum = lambda pred: max([v[3] for k, v in st.items() if pred(k)] or [0.0])   # noqa: E731
    assembly = {f"<built-in method dolfinx.cpp.fem.{f}>" for f in
                ("petsc.assemble_matrix", "assemble_matrix", "assemble_vector", "apply_lifting", "pack_coefficients")}
    return dict(
        material=cum(lambda k: k[0].endswith("quadrature.py") and k[2] == "update"),
        assembly=tot(lambda k: k[0] == "~" and k[2] in assembly),
        snes=tot(lambda k: k[0] == "~" and "'solve' of 'petsc4py.PETSc.SNES'" in k[2]),
        solve=cum(lambda k: k[0].endswith(os.path.join("solvers", "static.py")) and k[2] == "run"),
        # the compiled contact terms (a tree whose contact is forms has none: its cost is part of assembly)
        contact=sum(v[3] for k, v in st.items() if k[2] in ("residual", "jacobian")
                    and k[0].endswith(("static_tool_contact.py", "static_surface_contact.py"))),
    )


def run_cli(tree: Path, scene: str, sets: list, out: Path, ranks: int = 1, blas: str | None = None,
            profile: bool = True, as_shipped: bool = False) -> dict:
    """One CLI run of ``scene`` with the package of ``tree``; its figures. No XDMF unless ``as_shipped``."""
    env = dict(ENVIRONMENT, PYTHONPATH=str(tree), PETSC_OPTIONS=f"-log_view :{out}.petsclog")
    env.pop("PYTHONDONTWRITEBYTECODE", None)    # as a user runs: the bytecode compiled once (in the warm-up)
    if blas:
        env["LD_LIBRARY_PATH"] = BLAS_DIRS[blas]
    args = ["run", str(ROOT / scene), "--out", str(out), *([] if as_shipped else NO_FILES), *sets]
    cmd = [sys.executable, "-c", PROFILED.format(prof=f"{out}.prof", args=args)] if profile else \
        [sys.executable, "-m", "fenics_plast.cli", *args]
    if ranks > 1:
        cmd = ["mpirun", "-n", str(ranks), *cmd]
        env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    t0 = time.perf_counter()
    p = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise SystemExit(f"bench_static: {' '.join(cmd)} failed ({p.returncode}):\n{p.stderr[-3000:]}")
    summary = json.loads((out / "summary.json").read_text())
    ev = petsc_events(Path(f"{out}.petsclog"))
    res = dict(process=wall, dofs=summary.get("dofs"), newton=summary.get("newton_iterations", 0),
               jacobians=ev.get("SNESJacobianEval", (0, 0))[0], residuals=ev.get("SNESFunctionEval", (0, 0))[0],
               factorisation=sum(t for k, (n, t) in ev.items() if "FactorNum" in k or "FactorSym" in k
                                 or k.startswith("MatCholFctr") or k.startswith("MatLUFactor")),
               triangular=ev.get("MatSolve", (0, 0.0))[1],
               symbolic=ev.get("MatLUFactorSym", (0, 0.0))[0], numeric=ev.get("MatLUFactorNum", (0, 0.0))[0],
               peak_mb=summary.get("peak_memory_mb", float("nan")),
               force=summary.get("max_punch_force_kN", summary.get("max_force_kN")))
    if profile:
        res.update(profile_times(Path(f"{out}.prof")))
    return res


def contact_cost(scene: str, sets: list) -> tuple[float, float]:
    """(s per Jacobian, s per residual) of the scene's tool contact assembled as UFL forms (the route of the trees
    before the compiled contact, where it is a part of assembly), on this tree (in process)."""
    from mpi4py import MPI
    import dolfinx.fem.petsc as fpetsc
    from dolfinx import fem
    from fenics_plast.contact import PenaltyContact
    from fenics_plast.problem import load_problem
    from fenics_plast.runner_static import build_static
    from fenics_plast.solvers.static_tool_contact import ToolContactTerm
    overrides = [sets[i + 1] for i in range(0, len(sets), 2) if sets[i] == "--set"]
    b = build_static(load_problem(ROOT / scene, overrides), MPI.COMM_SELF)
    s = b.solver
    if b.contact is None:
        return 0.0, 0.0
    forms = PenaltyContact(s, compiled=False)
    for p in b.contact.pairs:
        if not isinstance(p, ToolContactTerm):  # a pair between facet groups of the body: no forms route
            continue
        forms.add_pair(p.tool, p.facet_tags, p.tag, penalty=p.penalty, friction=p.friction, law=p.law,
                       tangential_penalty=p.tangential_penalty)
    if not forms.pairs:
        return 0.0, 0.0
    J = fem.form(forms.jacobian())
    R = fem.form(forms.residual())
    A, vec = fpetsc.create_matrix(J), fpetsc.create_vector(R)
    tj, tr = [], []
    for _ in range(5):
        t0 = time.perf_counter()
        A.zeroEntries()
        fpetsc.assemble_matrix(A, J, bcs=s.bcs)
        A.assemble()
        t1 = time.perf_counter()
        with vec.localForm() as v:
            v.set(0.0)
        fpetsc.assemble_vector(vec, R)
        tr.append(time.perf_counter() - t1)
        tj.append(t1 - t0)
    s.close()
    return sorted(tj)[2], sorted(tr)[2]


def convergence_orders(scene: str) -> list[float]:
    """The observed order of Newton's last step, log(r_k+1 / r_k) / log(r_k / r_k-1), of every increment of the
    scene (this tree, in process) with three residuals above its round-off (1e-12 of its largest)."""
    import math
    from mpi4py import MPI
    from fenics_plast.problem import load_problem
    from fenics_plast.runner_static import build_static, load_steps
    problem = load_problem(ROOT / scene)
    b = build_static(problem, MPI.COMM_SELF)
    s = b.solver
    s.verbose = False
    commit = (lambda solver: b.contact.commit()) if b.contact is not None else None
    for _, end, increments, max_increment in load_steps(problem):
        s.run(increments=increments, min_increment=problem.analysis.min_increment, max_increment=max_increment,
              lam_end=end, callback=commit)
    floor = 1e-12 * max(max(rec["norms"]) for rec in s.increments)
    orders = []
    for rec in s.increments:
        r = [x for x in rec["norms"] if x > floor]
        if len(r) >= 3 and r[-2] < r[-3]:
            orders.append(math.log(r[-1] / r[-2]) / math.log(r[-2] / r[-3]))
    s.close()
    return orders


def per_iteration_row(tag, r, contact):
    """One column's row; contact: the compiled terms' time of the run's profile, else (a tree with contact forms)
    the forms' cost ``contact`` (s per Jacobian, s per residual) times the run's Jacobians and residuals."""
    n = max(r["newton"], 1)
    c = r.get("contact") or contact[0] * r["jacobians"] + contact[1] * r["residuals"]
    ms = lambda t: f"{1e3 * t / n:8.1f}"      # noqa: E731
    return (f"  {tag:17s} {r['dofs']:7d} {r['newton']:6d} {r['jacobians']:5d} {ms(r['material'])} "
            f"{ms(r['assembly'])} {ms(c)} {ms(r['factorisation'])} {ms(r['triangular'])} "
            f"{ms(r['snes'] - r['factorisation'] - r['triangular'])} {r['solve']:7.2f} {r['process']:8.2f}")


HEADER = (f"  {'':17s} {'dofs':>7s} {'newton':>6s} {'jacs':>5s} {'material':>8s} {'assembly':>8s} "
          f"{'contact':>8s} {'factor':>8s} {'tri-solve':>8s} {'other-lin':>8s} {'solve[s]':>7s} {'process[s]':>8s}"
          "\n  (per Newton iteration in ms; contact: the compiled contact terms, or the contact forms' part of "
          "assembly)")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="*", default=list(SCENES), choices=list(SCENES))
    ap.add_argument("--before", default=BEFORE, help="git revision of the 'before' column (none: skip it)")
    ap.add_argument("--blas", choices=list(BLAS_DIRS), default=None,
                    help="force this BLAS on both runs (default: the system's; docs/guide/install.md, Dependencies)")
    ap.add_argument("--before-blas", nargs="+", choices=list(BLAS_DIRS), default=None,
                    help="a 'before' column on each of these BLAS (reference: the code and install as they were)")
    ap.add_argument("--rates", action="store_true", help="Newton's observed convergence orders of --scenes")
    ap.add_argument("--large-runs", nargs="+", default=["mumps:1", "mumps:2", "gamg:1", "gamg:2"],
                    help="the --large runs, solver:ranks")
    ap.add_argument("--process", action="store_true", help="process against solve time of the small scenes")
    ap.add_argument("--large", action="store_true", help="also the >= 50k-dof 3-D punch (after only; minutes)")
    a = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="bench_static_"))
    try:
        runs = [("after", ROOT, a.blas)]            # (column, tree, BLAS)
        if a.before != "none":
            try:
                old = export_tree(a.before, tmp / "before_tree")
                runs = [("before", old, blas) for blas in (a.before_blas or [a.blas])] + runs
            except (subprocess.CalledProcessError, OSError) as e:
                print(f"bench_static: no revision {a.before} to compare with ({e}): after only", flush=True)
        # each tree runs each scene once untimed first: its numba kernels compile into the tree's cache (a short
        # 2-D run did not compile all that the full scenes need: a "before" column then timed the compiler)
        for tag, tree in dict((tag, tree) for tag, tree, _ in runs).items():
            for name in a.scenes:
                run_cli(tree, *SCENES[name], tmp / f"warm_up_{tag}_{name}", profile=False)
        for name in a.scenes:
            scene, sets = SCENES[name]
            contact = contact_cost(scene, sets)
            print(f"{name} ({scene})\n{HEADER}", flush=True)
            res = {}
            for tag, tree, blas in runs:
                label = tag + (f"/{blas}" if blas else "")
                res[label] = run_cli(tree, scene, sets, tmp / f"{name}_{label.replace('/', '_')}", blas=blas)
                print(per_iteration_row(label, res[label], contact), flush=True)
            f = res[runs[-1][0] + (f"/{runs[-1][2]}" if runs[-1][2] else "")]
            for label, b in list(res.items())[:-1]:
                print(f"  {label} -> after: process {b['process'] / f['process']:.2f}x faster, solve "
                      f"{b['solve'] / f['solve']:.2f}x; force {b['force']} -> {f['force']} kN "
                      f"(relative {abs(f['force'] - b['force']) / abs(b['force']):.1e}); LU numeric / symbolic "
                      f"{b['numeric']} / {b['symbolic']} -> {f['numeric']} / {f['symbolic']}", flush=True)
            print(f"  process / solve after: {f['process'] / f['solve']:.2f}", flush=True)
        if a.rates:
            import numpy as np
            print("Newton's observed convergence order at the last step of each increment (after)", flush=True)
            for name in a.scenes:
                o = np.array(convergence_orders(SCENES[name][0]))
                print(f"  {name:9s} {len(o)} increments: median {np.median(o):.2f}, quartiles "
                      f"{np.percentile(o, 25):.2f} / {np.percentile(o, 75):.2f}, >= 1.5 in {np.mean(o >= 1.5):.0%}",
                      flush=True)
        if a.process:
            print("process time against solve time (median of 3 plain runs, no profiler; solve: the load stepping "
                  "or the explicit step loop)", flush=True)
            for scene in PROCESS_SCENES:
                runs = []
                for k in range(3):
                    out = tmp / f"process_{Path(scene).stem}_{k}"
                    r = run_cli(ROOT, scene, [], out, profile=False, as_shipped=True)
                    summary = json.loads((out / "summary.json").read_text())
                    runs.append((r["process"], summary.get("solve_time_s", summary.get("step_loop_time_s"))))
                process, solve = sorted(runs)[1]
                print(f"  {scene:32s} process {process:6.2f} s  solve {solve:6.2f} s  ratio {process / solve:5.2f}",
                      flush=True)
        if a.large:
            scene, sets = LARGE
            print(f"large: {scene} {' '.join(sets[1::2])}\n  {'solver':6s} {'ranks':>5s} {'dofs':>7s} "
                  f"{'newton':>6s} {'s/newton':>8s} {'solve[s]':>8s} {'peak MB':>8s} {'force kN':>9s}", flush=True)
            for solver, ranks in [(c.split(":")[0], int(c.split(":")[1])) for c in a.large_runs]:
                r = run_cli(ROOT, scene, sets + ["--set", f"analysis.linear_solver={solver}"],
                            tmp / f"large_{solver}_{ranks}", ranks=ranks, profile=False)
                summary = json.loads((tmp / f"large_{solver}_{ranks}" / "summary.json").read_text())
                times = summary["solver_times_s"]
                solve = sum(times.values())
                split = ", ".join(f"{k} {v / max(r['newton'], 1):.2f}" for k, v in times.items())
                print(f"  {solver:6s} {ranks:5d} {r['dofs']:7d} {r['newton']:6d} "
                      f"{solve / max(r['newton'], 1):8.2f} {solve:8.1f} {r['peak_mb']:8.0f} {r['force']:9.4g}"
                      f"   (s per Newton iteration: {split}; process {r['process']:.0f} s)", flush=True)
    finally:
        shutil.rmtree(tmp)          # only what this run wrote


if __name__ == "__main__":
    main()
