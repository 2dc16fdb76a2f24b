"""Command line: ``fenics-plast run | point | keys | study | plot``.

Exit status: 0 success; 1 the run failed (summary.json still written, with ``converged: false``
and ``error``); 2 invalid scene file or bad arguments (nothing written).
"""
from __future__ import annotations

import argparse
import csv
import logging
import os
import socket
import sys
import time
import traceback
from pathlib import Path

import numpy as np

from .errors import SceneError
from .keys_doc import keys_markdown

EXIT_OK, EXIT_RUN_FAILED, EXIT_USAGE = 0, 1, 2

F_COLUMNS = [f"F{i}{j}" for i in range(1, 4) for j in range(1, 4)]


def _env_rank() -> int:
    """MPI rank without importing mpi4py (validation must stay fast and MPI-free)."""
    for var in ("OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK", "MPI_LOCALRANKID"):
        if var in os.environ:
            try:
                return int(os.environ[var])
            except ValueError:
                pass
    return 0


def _error(msg: str) -> None:
    if _env_rank() == 0:
        print(f"error: {msg}", file=sys.stderr, flush=True)


def _say(msg: str) -> None:
    if _env_rank() == 0:
        print(msg, flush=True)


# ----------------------------------------------------------------------------------------------
# run


def cmd_run(args) -> int:
    if args.accuracy:
        return cmd_accuracy(args)
    for flag in ("time_budget", "memory_budget", "np"):
        if getattr(args, flag) is not None:
            _error(f"--{flag.replace('_', '-')} goes with --accuracy")
            return EXIT_USAGE
    from .problem import load_problem      # the dolfinx stack, imported while libgmsh loads (main)
    try:
        problem = load_problem(args.scene, args.set or ())
    except SceneError as e:
        _error(str(e))
        return EXIT_USAGE

    out_dir = Path(args.out) if args.out else Path("results") / problem.name
    resume = getattr(args, "resume", None)
    if resume:
        if args.out and Path(args.out).resolve() != Path(resume).resolve():
            _error(f"--out {args.out} and --resume {resume} name different directories: a resumed run "
                   f"continues in the directory it resumes (leave out --out)")
            return EXIT_USAGE
        out_dir = Path(resume)

    from mpi4py import MPI
    comm = MPI.COMM_WORLD
    from .checkpoint import DIRNAME, CheckpointError, check_fingerprint, check_resume, remove_own

    if resume:
        try:
            manifest = check_resume(out_dir, problem, comm.size)
        except CheckpointError as e:
            _error(str(e))
            return EXIT_USAGE
        _say(f"fenics-plast: resuming {out_dir} from checkpoint {manifest['counter']}")
    why = _out_dir_problem(out_dir, problem.name, getattr(args, "overwrite", False), bool(resume), comm,
                           problem)
    if why:
        _error(why)
        return EXIT_USAGE

    from .runner import prepare, read_mesh
    try:                               # the mesh's groups are checked before anything is written
        mesh_data = read_mesh(problem, comm, trust_mesh_script=getattr(args, "trust_mesh_script", False))
    except SceneError as e:
        _error(str(e))
        return EXIT_USAGE
    fingerprint = None
    if mesh_data is not None and (resume or problem.output.checkpoint_every > 0):   # checkpoints carry it
        fingerprint = _fingerprint(problem, mesh_data[0])
    if resume:
        try:
            check_fingerprint(out_dir, manifest, fingerprint)
        except CheckpointError as e:
            _error(str(e))
            return EXIT_USAGE
    try:                               # the set-up too: what it refuses is the scene's (exit 2, nothing written)
        prepared = prepare(problem, comm, mesh_data)
    except SceneError as e:
        _error(str(e))
        return EXIT_USAGE
    except Exception as e:  # noqa: BLE001 - not the scene's fault: the run reports it (exit 1, summary.json)
        prepared = e
    lock, why = _take_out_dir(out_dir, problem.name, comm, wait=bool(resume))
    if why:
        _error(why)
        return EXIT_USAGE
    if not resume and comm.rank == 0:   # a fresh run: an earlier run's files and checkpoints go (only those)
        from .output import remove_listed
        if (out_dir / "summary.json").is_file() or (out_dir / "history.csv").is_file():
            _say(f"fenics-plast: {out_dir} holds the results of an earlier run: they are replaced")
        remove_listed(out_dir)
        remove_own(out_dir / DIRNAME)
    try:
        return _run_in(problem, out_dir, comm, resume, prepared, fingerprint)
    finally:
        if lock is not None:
            lock.release()          # also after a failure or Ctrl-C


def _out_dir_problem(out_dir, scene, overwrite, resume, comm, problem=None) -> str | None:
    """Why the run may not write into ``out_dir`` (rank 0 checks; every rank gets the answer)."""
    from .output import OutputDirError, check_out_dir, run_file_names
    why = None
    if comm.rank == 0:
        try:
            check_out_dir(out_dir, scene, overwrite=overwrite, resume=resume,
                          names=run_file_names(problem) if problem is not None else ())
        except OutputDirError as e:
            why = str(e)
    return comm.bcast(why, root=0) if comm.size > 1 else why


def _take_out_dir(out_dir, scene, comm, wait=False):
    """Rank 0: create the output folder (and missing parents), take its lock for every rank's process,
    mark it as a results folder of ``scene``. ``wait``: a resumed run waits for the processes of the
    killed run that still hold the folder (:data:`fenics_plast.run_lock.RESUME_WAIT_S`). Returns
    ``(lock or None, why it failed or None)``; a failure removes the folders it created (collective)."""
    from .output import OutputDirError, make_out_dir, mark_results_folder, remove_created
    from .run_lock import RESUME_WAIT_S, RunLock, this_process
    mine = (socket.gethostname(), *this_process())
    ranks = comm.gather(mine, root=0) if comm.size > 1 else [mine]
    lock, why = None, None
    if comm.rank == 0:
        created = []
        try:
            created = make_out_dir(out_dir)
            lock = RunLock.acquire(out_dir, [(pid, start) for host, pid, start in ranks if host == mine[0]],
                                   wait_s=RESUME_WAIT_S if wait else 0.0, say=_say)
            if lock.warning:
                print(lock.warning, file=sys.stderr, flush=True)
            mark_results_folder(out_dir, scene)
        except (OutputDirError, OSError) as e:
            if lock is not None:
                lock.release()
                lock = None
            remove_created(created)
            why = str(e) if isinstance(e, OutputDirError) else f"--out {out_dir}: {e.strerror or e}"
    why = comm.bcast(why, root=0) if comm.size > 1 else why
    return lock, why


def _fingerprint(problem, mesh) -> dict:
    """The problem's fingerprint for checkpoints: the mesh and the files it is read from (collective)."""
    from .checkpoint import fingerprint
    from .geo_screen import input_files
    files = input_files(problem.mesh_file, problem.path.parent) if mesh.comm.rank == 0 else []
    return fingerprint(mesh, files, problem.path.parent)


def _run_in(problem, out_dir, comm, resume, mesh_data, fingerprint) -> int:
    """The run in its (locked) output folder: results, summary.json, exit status."""
    from .checkpoint import CheckpointError
    from .errors import RunError
    from .expressions import ExpressionError
    from .output import LinkRefused, RunOutput
    from .runner import run
    output = RunOutput(out_dir, comm, resume=bool(resume))
    output.fingerprint = fingerprint
    _say(f"fenics-plast: scene {problem.name!r} ({problem.analysis.type}; physics: "
         f"{', '.join(problem.active_physics) or 'elastic'}) on {comm.size} rank(s) -> {out_dir}")

    summary = {
        "scene": problem.name,
        "analysis": problem.analysis.type,
        "scene_file": str(problem.path),
        "overrides": list(problem.overrides),
        "active_physics": problem.active_physics,
        "mpi_ranks": comm.size,
    }
    t0 = time.perf_counter()
    status = EXIT_OK
    try:
        try:
            results = run(problem, output, mesh_data)
        finally:
            output.end_progress()       # the bar's line ends before any error message
        if results is None:
            results = {}
        summary.update(results)
        summary.setdefault("converged", True)
        if not summary["converged"]:
            status = EXIT_RUN_FAILED
            _error(f"run of {problem.name!r} did not converge")
    except SceneError as e:            # found while setting up (e.g. a symmetry group that is not straight)
        status = EXIT_USAGE
        summary.update(converged=False, error=str(e))
        _error(str(e))
    except RunError as e:
        status = EXIT_RUN_FAILED
        summary.update(e.results)
        summary.update(converged=False, error=str(e))
        _error(str(e))
    except CheckpointError as e:       # the checkpoint does not fit this run (found while loading it)
        status = EXIT_RUN_FAILED
        summary.update(converged=False, error=str(e))
        _error(str(e))
    except ExpressionError as e:       # a load or output not finite during the run (checked where it can be before)
        status = EXIT_RUN_FAILED
        msg = f"{problem.path}: {e}: the run stopped there"
        summary.update(converged=False, error=msg)
        _error(msg)
    except LinkRefused as e:           # a link where the run writes, not seen before the run (refused there)
        status = EXIT_USAGE
        summary.update(converged=False, error=str(e))
        _error(str(e))
    except KeyboardInterrupt:
        status = 130
        summary.update(converged=False, error="interrupted")
        _error("interrupted")
    except Exception as e:  # a bug: keep what we have, show the traceback
        status = EXIT_RUN_FAILED
        summary.update(converged=False, error=f"{type(e).__name__}: {e}")
        if comm.rank == 0:
            traceback.print_exc()
        _error(f"run of {problem.name!r} crashed: {type(e).__name__}: {e}")
    summary["wall_time_s"] = time.perf_counter() - t0
    ckpt = output.checkpointer
    if ckpt is not None:
        summary.update(ckpt.summary())
        if ckpt.warnings:                   # e.g. resumed from an older checkpoint: the newest was corrupt
            summary["warnings"] = list(summary.get("warnings") or []) + ckpt.warnings
    summary["scene_settings"] = problem.to_dict()
    try:
        path = output.finish(summary)
    except LinkRefused as e:
        _error(str(e))
        return EXIT_USAGE
    if ckpt is not None and status == EXIT_OK:
        ckpt.clear()            # after summary.json: a kill in between leaves a resumable run
    _say(f"fenics-plast: {'done' if status == EXIT_OK else 'FAILED'} in {summary['wall_time_s']:.1f} s; "
         f"results in {out_dir}/ (summary: {path})")
    return status


# ----------------------------------------------------------------------------------------------
# point


def read_deformation_table(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read a CSV with header ``t,F11,F12,F13,F21,F22,F23,F31,F32,F33`` (row-major F, one state per row,
    ``t`` a pseudo-time/label). Returns ``(t (n,), F (n,3,3))``. Raises ValueError with a clear message."""
    path = Path(path)
    with open(path, newline="", encoding="utf-8") as f:
        rows = [r for r in csv.reader(f) if r and not r[0].lstrip().startswith("#")]
    if not rows:
        raise ValueError(f"{path}: empty table")
    header = [h.strip() for h in rows[0]]
    missing = [c for c in ["t"] + F_COLUMNS if c not in header]
    if missing:
        raise ValueError(f"{path}: header must be t,{','.join(F_COLUMNS)} (missing: {', '.join(missing)})")
    try:
        data = np.array([[float(x) for x in r] for r in rows[1:]], dtype=float)
    except ValueError as e:
        raise ValueError(f"{path}: not a number: {e}") from None
    if data.ndim != 2 or data.shape[0] < 1 or data.shape[1] != len(header):
        raise ValueError(f"{path}: every row needs {len(header)} numbers")
    bad = np.nonzero(~np.all(np.isfinite(data), axis=1))[0]
    if bad.size:
        col = header[int(np.nonzero(~np.isfinite(data[bad[0]]))[0][0])]
        raise ValueError(f"{path}: data row {int(bad[0]) + 1}: {col} = {float(data[bad[0]][header.index(col)])!r} is not a "
                         f"finite number")
    idx = {h: i for i, h in enumerate(header)}
    t = data[:, idx["t"]]
    F = np.stack([data[:, idx[c]] for c in F_COLUMNS], axis=1).reshape(-1, 3, 3)
    bad = np.nonzero(np.linalg.det(F) <= 0)[0]
    if bad.size:
        raise ValueError(f"{path}: det F <= 0 in data row {int(bad[0]) + 1}")
    return t, F


def _columns(result: dict) -> dict[str, np.ndarray]:
    cols = {}
    for k, v in result.items():
        a = np.asarray(v)
        if a.ndim <= 1:
            cols[k] = np.atleast_1d(a)
        else:  # (n, 3, 3) and the like -> k_11, k_12, ...
            n = a.shape[0]
            flat = a.reshape(n, -1)
            idx = np.ndindex(*a.shape[1:])
            for j, ij in enumerate(idx):
                cols[f"{k}_{''.join(str(i + 1) for i in ij)}"] = flat[:, j]
    return cols


def _csv_cell(v):
    if isinstance(v, (bool, np.bool_)):
        return int(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        return repr(float(v))
    return v


def cmd_point(args) -> int:
    from .problem import load_problem
    try:
        problem = load_problem(args.scene, args.set or ())
    except SceneError as e:
        _error(str(e))
        return EXIT_USAGE
    names = list(problem.materials)
    name = args.material if args.material is not None else (names[0] if len(names) == 1 else None)
    if name not in problem.materials:
        _error(f"{problem.path}: " + (f"--material {args.material!r} is not a material of the scene"
                                      if args.material is not None else "the scene has several materials")
               + f": choose one with --material ({', '.join(names)})")
        return EXIT_USAGE
    if args.path in ("uniaxial", "shear") and args.to is None:
        _error(f"--path {args.path} needs --to VALUE (log strain for uniaxial, shear gamma for shear)")
        return EXIT_USAGE
    if args.path == "table" and not args.table:
        _error("--path table needs --table F.csv (header t,F11,F12,F13,F21,F22,F23,F31,F32,F33)")
        return EXIT_USAGE
    if args.steps < 1:
        _error("--steps must be >= 1")
        return EXIT_USAGE
    if args.rate is not None and not (np.isfinite(args.rate) and args.rate > 0):
        _error(f"--rate must be a positive number [1/s], got {args.rate}")
        return EXIT_USAGE
    out = Path(args.out) if args.out else Path("results") / problem.name / f"point_{args.path}.csv"
    why = _point_out_problem(out)
    if why:
        _error(why)
        return EXIT_USAGE
    t = None
    if args.path == "table":
        try:
            t, F = read_deformation_table(args.table)
        except (OSError, ValueError) as e:
            _error(str(e))
            return EXIT_USAGE
    from .errors import RunError
    from .material import point
    from .build import material_of
    material = material_of(problem.materials[name])
    try:
        if args.path == "uniaxial":
            result = point.uniaxial_stress(material, args.to, args.steps, rate=args.rate)
        elif args.path == "shear":
            result = point.simple_shear(material, args.to, args.steps, rate=args.rate)
        else:
            result = point.deformation_table(material, F, rate=args.rate)
    except RunError as e:
        _error(str(e))
        return EXIT_RUN_FAILED
    result = dict(result)
    cols = _columns(result)
    lengths = {len(c) for c in cols.values()}
    if len(lengths) > 1:
        _error(f"material point driver returned columns of different lengths: "
               f"{ {k: len(c) for k, c in cols.items()} }")
        return EXIT_RUN_FAILED
    n = lengths.pop() if lengths else 0
    for k, c in cols.items():
        c = np.asarray(c)
        if c.dtype.kind in "fc" and not np.all(np.isfinite(c)):
            row = int(np.nonzero(~np.isfinite(c))[0][0])
            _error(f"fenics-plast point: {k} is not finite in row {row + 1} of the path (the deformation is out of "
                   f"the material's range, e.g. a huge F in --table): nothing written")
            return EXIT_USAGE
    if t is not None and "t" not in cols:
        # the driver may prepend the undeformed state (F = I) as row 0: its t is left empty
        tcol = np.array([""] * (n - len(t)) + [repr(float(x)) for x in t], dtype=object)
        cols = {"t": tcol, **cols}
    from .out_files import LinkRefused, open_write
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        with open_write(out, newline="", encoding="utf-8") as f:
            w = csv.writer(f)
            w.writerow(list(cols))
            for i in range(n):
                w.writerow([_csv_cell(c[i]) for c in cols.values()])
    except LinkRefused as e:
        _error(str(e))
        return EXIT_USAGE
    except OSError as e:
        _error(f"--out {out}: cannot write the table: {e.strerror or e}")
        return EXIT_USAGE
    _say(f"fenics-plast point: {n} rows ({', '.join(cols)}) -> {out}")
    return EXIT_OK


def _point_out_problem(out: Path) -> str | None:
    """Why ``point`` may not write its table to ``out`` (a folder, a link, under a file)."""
    if os.path.islink(out):
        return (f"--out {out}: is a symbolic link: fenics-plast does not write through links; remove it or "
                f"choose another file name")
    if out.is_dir():
        return f"--out {out}: is a folder: give the name of the CSV file to write (e.g. {out / 'point.csv'})"
    parent = out.absolute().parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        return f"--out {out}: cannot create the file: {parent} is a file, not a folder"
    return None


# ----------------------------------------------------------------------------------------------
# plot


def cmd_plot(args) -> int:
    from .out_files import LinkRefused
    from .plots import PlotError, draw_declared
    try:
        paths = draw_declared(args.dir)
    except (PlotError, LinkRefused) as e:
        _error(str(e))
        return EXIT_USAGE
    _say(f"fenics-plast plot: {len(paths)} figure(s): {', '.join(p.name for p in paths)} in {args.dir}")
    return EXIT_OK


# ----------------------------------------------------------------------------------------------
# keys


def cmd_keys(args) -> int:
    sys.stdout.write(keys_markdown())
    return EXIT_OK


def cmd_accuracy(args) -> int:
    """``run --accuracy``: the ladder, the final run and the results with error bars (exit 0: every
    tolerance met; 1: refused or not met, with the reason in accuracy.md; 2: bad arguments)."""
    from mpi4py import MPI
    from .accuracy import AccuracyError, lines, parse_tolerance, run_accuracy
    if MPI.COMM_WORLD.size > 1:
        _error("run --accuracy starts its own runs: give --np N instead of launching it under mpirun")
        return EXIT_USAGE
    if args.resume:
        _error("--resume does not go with --accuracy: asking again with the same --out reuses the runs made")
        return EXIT_USAGE
    try:
        tolerances = [parse_tolerance(t) for t in args.accuracy]
        if args.out:
            out = Path(args.out)
        else:
            from .problem import load_problem
            out = Path("results") / f"accuracy_{load_problem(args.scene, args.set or ()).name}"
        outcome = run_accuracy(args.scene, tolerances, out, args.set or (), np_ranks=args.np or 1,
                               time_budget=args.time_budget, memory_budget=args.memory_budget,
                               trust_mesh_script=args.trust_mesh_script, overwrite=args.overwrite,
                               log=_say)
    except (AccuracyError, SceneError) as e:
        _error(str(e))
        return EXIT_USAGE
    _say(f"fenics-plast: accuracy {outcome.status}: {out / 'accuracy.md'}")
    for line in lines(outcome):
        _say(line)
    return 0 if outcome.status == "met" else 1


def cmd_study(args) -> int:
    from .study import study_from_args
    return study_from_args(args)


# ----------------------------------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="fenics-plast",
        description="Finite-strain J2 elastoplasticity (Simo-Ortiz / Garcia Garino) on FEniCSx.",
        epilog="Scene keys: docs/SCENE_KEYS.md (or `fenics-plast keys`).")
    sub = p.add_subparsers(dest="command", required=True)

    r = sub.add_parser("run", help="run a scene file",
                       description="Validate SCENE.toml and run it; writes summary.json, history.csv, "
                                   "fields.xdmf and plots into --out (default results/<scene name>).")
    r.add_argument("scene", help="scene file (TOML)")
    r.add_argument("--out", help="output directory (default results/<scene name>)")
    r.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a scene key by dotted path, e.g. --set contact.punch.friction=0.15 "
                        "(repeatable)")
    r.add_argument("--overwrite", action="store_true",
                   help="let --out name a results folder of another scene (its results are replaced); a "
                        "non-empty folder that is not a results folder is refused all the same")
    r.add_argument("--trust-mesh-script", action="store_true",
                   help="let the scene's Gmsh .geo run any command it contains (programs, file writes, Includes "
                        "from anywhere): without it, such a script is refused before Gmsh reads it")
    r.add_argument("--resume", metavar="DIR",
                   help="continue the killed run whose output directory is DIR from its newest complete "
                        "checkpoint (same scene file, --set options and number of MPI ranks); output "
                        "goes on in DIR")
    r.add_argument("--accuracy", action="append", metavar="RESULT=TOL",
                   help="a tolerance on a result (summary.json key): radius_mm=0.5%% (relative) or "
                        "radius_mm=0.02 (its unit); 1%% alone: every key result (repeatable). Runs a ladder of "
                        "meshes (and probes of the time step and the contact penalty), then the cheapest setting "
                        "predicted to meet every tolerance; reports each result as value +- error bar into "
                        "--out (default results/accuracy_<scene name>): accuracy.md, accuracy.json, runs/. "
                        "Asking again with the same --out reuses the runs")
    r.add_argument("--time-budget", type=float, metavar="S",
                   help="with --accuracy: refuse (with the table) a final run predicted to take longer [s]")
    r.add_argument("--memory-budget", type=float, metavar="MB",
                   help="with --accuracy: refuse a final run predicted to need more peak memory [MB]")
    r.add_argument("--np", type=int, help="with --accuracy: MPI ranks of each run (mpirun -n NP)")
    r.set_defaults(func=cmd_run)

    q = sub.add_parser("point", help="drive the material of a scene at one material point",
                       description="Material-point driver: stress-strain paths without a mesh.")
    q.add_argument("scene", help="scene file (TOML); only its [materials] are used")
    q.add_argument("--material", help="which [materials.<name>] (default: the scene's only material)")
    q.add_argument("--path", required=True, choices=("uniaxial", "shear", "table"),
                   help="uniaxial stress to log strain --to; simple shear to gamma --to; "
                        "or a table of deformation gradients (--table)")
    q.add_argument("--to", type=float, help="final log strain (uniaxial) or shear gamma (shear)")
    q.add_argument("--steps", type=int, default=100, help="number of steps (default 100)")
    q.add_argument("--rate", type=float, metavar="PER_S",
                   help="drive the path in time at this constant rate [1/s]: axial log-strain rate (uniaxial), "
                        "shear rate (shear), or rows per second (table); Johnson-Cook materials then see the "
                        "plastic strain rate and heat adiabatically (columns time_s, temperature_K). Without "
                        "it: no physical time (no rate term, no heating)")
    q.add_argument("--table", help="CSV with header t,F11,F12,F13,F21,F22,F23,F31,F32,F33 (row-major F)")
    q.add_argument("--out", help="output CSV (default results/<scene name>/point_<path>.csv)")
    q.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene key (repeatable)")
    q.set_defaults(func=cmd_point)

    k = sub.add_parser("keys", help="print the scene key reference (docs/SCENE_KEYS.md)")
    k.set_defaults(func=cmd_keys)

    pl = sub.add_parser("plot", help="redraw the PNG plots of a results folder",
                        description="Redraws the figures the scene declares ([plots]) in DIR from its "
                                    "history.csv and profile CSV files (the scene settings are in summary.json).")
    pl.add_argument("dir", help="results folder of `fenics-plast run` (summary.json, history.csv)")
    pl.set_defaults(func=cmd_plot)

    from .study import add_study_arguments
    st = sub.add_parser("study", help="run combinations of scene-key overrides; tabulate cost and error",
                        description="Runs every combination of the --vary values (one process each) and "
                                    "writes study.csv, study.md and study.png (error against wall time) "
                                    "into --out (default results/study_<scene name>).")
    add_study_arguments(st)
    st.set_defaults(func=cmd_study)
    return p


def _library_warnings_only() -> None:
    """Let libraries' log records reach stderr from WARNING up, nothing below.

    FFCx calls ``logging.basicConfig()`` when imported, and on a cold cache its compiler builds each
    form through setuptools, whose distutils logger (Debian 12) logs every gcc call at INFO on the
    root logger: the user would see "INFO:root:running build_ext" before our own messages. Raising
    the root handlers' own levels keeps those build notes out whatever level a library sets."""
    root = logging.getLogger()
    if not root.handlers:
        root.addHandler(logging.StreamHandler(sys.stderr))
    for handler in root.handlers:
        handler.setLevel(max(handler.level, logging.WARNING))


def main(argv: list[str] | None = None) -> int:
    _library_warnings_only()
    args = build_parser().parse_args(argv)
    if args.func is cmd_run:        # libgmsh loads in a thread while cmd_run imports dolfinx (preload.py)
        from .preload import single_process_mpi, start_gmsh
        single_process_mpi()
        start_gmsh()
    return args.func(args)


def console() -> None:
    """The ``fenics-plast`` command (and ``python -m fenics_plast.cli``): :func:`main`, then
    :func:`exit_promptly` with its status. An exception, or argparse's exit, leaves the usual way."""
    exit_promptly(main())


def exit_promptly(status: int | None) -> None:
    """End the process once everything is written, without the interpreter's teardown: freeing the compiled
    kernels' LLVM state and every dolfinx and PETSc object one by one costs ~0.3 s, as much as a fifth of a
    small scene's solve. Every output is closed by then (fields, history, summary, plots, checkpoints: the runners
    close them before returning); what is left is flushed here: the standard streams, logging, PETSc
    (``-log_view`` prints at its finalize) and MPI (finalized, as mpirun expects)."""
    sys.stdout.flush()
    sys.stderr.flush()
    logging.shutdown()
    petsc = sys.modules.get("petsc4py.PETSc")
    if petsc is not None and petsc.Sys.isInitialized() and not petsc.Sys.isFinalized():
        petsc._finalize()
    mpi = sys.modules.get("mpi4py.MPI")
    if mpi is not None and mpi.Is_initialized() and not mpi.Is_finalized():
        mpi.Finalize()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status or 0)


if __name__ == "__main__":
    console()
