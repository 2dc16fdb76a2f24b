"""One study from start to end: :func:`run_study` checks the arguments, plans the runs, executes
them one process each, takes the key results, info columns and published references the runs
declare in their summary.json, computes the references and errors, and writes study.csv,
study.md and study.png.

Published references (summary.json ``references``) are compared with only when every key the
study varies or fixes with ``--set`` is a discretisation key (:data:`~fenics_plast.study.plan.ORDERED_KEYS`):
a study of another velocity, material or end time is not the published problem.
"""
from __future__ import annotations

from pathlib import Path
from typing import Callable, Iterable, Sequence

from ..out_files import LinkRefused, make_dir
from ..output import LOCK, MARKER, OutputDirError, STUDY_FILES, mark_results_folder, remove_listed
from ..run_lock import take_results_folder
from .execute import Run, execute, prevalidate
from .plan import StudyError, Vary, combinations, non_discretisation_keys, run_label, run_name, study_command
from .references import references
from .report import write_csv, write_markdown, write_plot
from .table import Study, declared_outputs


def _check(varies: Sequence[Vary], np_ranks: int) -> None:
    if not varies:
        raise StudyError("give at least one --vary KEY=V1,V2,...")
    keys_seen = [v.key for v in varies]
    if len(set(keys_seen)) != len(keys_seen):
        raise StudyError(f"a key is varied twice: {keys_seen}")
    if np_ranks < 1:
        raise StudyError("--np must be >= 1")


def _take_declared(study: Study, results: Sequence[str] | None, log: Callable[[str], None]) -> None:
    """Key results, info columns and published references from the runs' summary.json."""
    declared = declared_outputs(study.runs)
    study.keys = list(results) if results else declared.key_results
    study.info = [k for k in declared.info_results if k not in study.keys]
    if not study.keys:
        log("study: warning: no key results (no summary.json declares key_results): pass --results k1,k2")
    published = {k: v for k, v in declared.references.items() if k in study.keys}
    if not published:
        return
    foreign = non_discretisation_keys(study.varies, study.sets)
    if foreign:
        study.paper_note = ("Published references (" + ", ".join(f"`{k}`" for k in published) + ") not "
                            "compared with: the study varies or sets " + ", ".join(f"`{k}`" for k in foreign)
                            + ", not only discretisation keys.")
        return
    study.paper = {k: v["value"] for k, v in published.items()}
    study.paper_sources = {k: v["source"] for k, v in published.items()}


def run_study(scene: str | Path, varies: Sequence[Vary], out: str | Path, sets: Iterable[str] = (),
              results: Sequence[str] | None = None, np_ranks: int = 1, timeout: float | None = None,
              reuse: bool = False, keep_outputs: bool = False, command: str | None = None,
              log: Callable[[str], None] = print, trust_mesh_script: bool = False,
              overwrite: bool = False) -> Study:
    """Run the study and write study.csv, study.md and study.png into ``out``. Raises StudyError
    (bad arguments: nothing run) when the scene or the fixed overrides are invalid.

    ``results``: the summary keys to compare (default: the runs' declared ``key_results``);
    ``trust_mesh_script``: each run gets ``--trust-mesh-script``.

    ``out`` follows the rules of ``run --out`` (:func:`~fenics_plast.output.check_out_dir`): a new or
    empty folder, or a study's results folder (its marker) of the same scene (another scene's, or a run's:
    ``overwrite``); a non-empty folder of the user's is refused, and so is a symbolic link where the
    study writes (study.csv/md/png, runs/, runs/<run>/, the marker): nothing is written through links."""
    from ..problem import SceneError, load_problem

    scene = Path(scene).resolve()
    sets = list(sets)
    _check(varies, np_ranks)
    try:
        base = load_problem(scene, sets)
    except SceneError as e:
        raise StudyError(str(e)) from None
    fixed = list(sets) if keep_outputs else ["output.xdmf=false", "output.plots=false", *sets]
    out = Path(out)
    combos = combinations(varies)
    names = [run_name(i, combo, varies) for i, combo in enumerate(combos)]
    try:                                     # one study (or run) per folder at a time
        lock = take_results_folder(out, base.name, "study",
                                   [*STUDY_FILES, *(f"runs/{n}/{f}" for n in names for f in
                                                    (MARKER, LOCK, "run.log", "study_run.json", "summary.json"))],
                                   overwrite=overwrite, log=log)
    except OutputDirError as e:
        raise StudyError(str(e)) from None
    try:
        try:
            mark_results_folder(out, base.name, kind="study")
            remove_listed(out)               # what a run wrote there (a run's folder taken with --overwrite)
            make_dir(out / "runs", root=out)
        except LinkRefused as e:
            raise StudyError(str(e)) from None
        study = Study(scene=scene, analysis=base.analysis.type, scene_name=base.name, varies=list(varies),
                      sets=sets, keys=[], info=[], out=out, np_ranks=np_ranks,
                      command=command or study_command(str(scene), varies, sets, str(out), np_ranks))
        for i, combo in enumerate(combos):
            run = Run(name=run_name(i, combo, varies), label=run_label(combo, varies), settings=combo)
            run_sets = fixed + [f"{k}={v}" for k, v in combo.items()]
            why = prevalidate(scene, run_sets)
            if why is not None:
                run.status, run.reason = "invalid", why
            else:
                log(f"study: run {i + 1}/{len(combos)} {run.label} ...")
                try:
                    execute(run, scene, run_sets, out / "runs" / run.name, np_ranks=np_ranks, timeout=timeout,
                            reuse=reuse, trust_mesh_script=trust_mesh_script, root=out)
                except (LinkRefused, OutputDirError) as e:
                    raise StudyError(str(e)) from None
            t = run.value("wall_time_s")
            log(f"study: run {i + 1}/{len(combos)} {run.label}: {run.status}"
                + (" (reused)" if run.reused else "")
                + (f", {t:.2f} s" if t is not None else "") + (f": {run.reason}" if run.reason else ""))
            study.runs.append(run)
        _take_declared(study, results, log)
        study.refs = references(study.runs, varies, study.keys)
        try:
            write_csv(study, out / "study.csv")
            write_plot(study, out / "study.png")
            write_markdown(study, out / "study.md", "study.png")
        except LinkRefused as e:
            raise StudyError(str(e)) from None
        log(f"study: {sum(r.ok for r in study.runs)}/{len(study.runs)} runs succeeded; "
            f"{out / 'study.csv'}, {out / 'study.md'}, {out / 'study.png'}")
    finally:
        lock.release()
    return study
