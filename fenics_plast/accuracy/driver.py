"""One accuracy request from start to end: :func:`run_accuracy`.

1. The scene and the tolerances are checked (AccuracyError, exit 2, nothing written): every named
   result is an output of the scene, and the scene has a mesh axis (a .geo mesh).
2. The ladder runs (:mod:`.ladder`): three meshes, and one probe per other axis; a second probe of an
   axis whose first bounds a result's error by more than its share of the tolerance.
3. Each result's error is estimated (:mod:`.estimate`) and the final setting chosen (:mod:`.plan`).
   A result the ladder cannot vouch for (not in the asymptotic range, oscillating beyond its
   tolerance), a failed run, or a final run predicted beyond ``time_budget`` / ``memory_budget``:
   the request is refused with the table and what to do.
4. The final run, with the scene's outputs; the mesh part of each bar is re-estimated from the two
   finest ladder levels and the final run when the final refines the mesh alone, else predicted from
   the ladder. A bar still above its tolerance gets one more refinement (at most :data:`MAX_FINALS`
   final runs), within the budgets.
5. accuracy.json, accuracy.md (:mod:`.report`).

The runs stay in OUT/runs/<setting>/: asking again (a tighter tolerance, another result) reuses
each run whose scene, mesh file, overrides and ranks are unchanged (the fingerprint in accuracy.json).
"""
from __future__ import annotations

import hashlib
import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable, Sequence

from ..out_files import LinkRefused, make_dir
from ..output import OutputDirError, mark_results_folder
from ..run_lock import take_results_folder
from .axes import scene_axes
from .estimate import THEORETICAL_ORDER, MeshEstimate, ProbeEstimate, mesh_estimate, probe_estimate
from .ladder import Ladder, Setting, ladder_settings
from .plan import TARGET, bar_parts, final_factors, need, predicted_cost, predicted_memory, round_up
from .probes import EFFECTIVE, axes_to_measure, effective_factor, more_probes, nominal_factor, probe_advice
from .report import ACCURACY_FILES, Outcome, ResultReport, write_json, write_markdown
from .tolerance import AccuracyError, Tolerance, expand

#: final runs at most (the predicted one, and one more where a bar came out above its tolerance)
MAX_FINALS = 2


def _fingerprint(problem, sets: Sequence[str], np_ranks: int) -> str:
    """sha256 of what the runs depend on: the scene file, its mesh file, the overrides and the ranks."""
    h = hashlib.sha256()
    for p in (problem.path, problem.mesh_file):
        try:
            h.update(Path(p).read_bytes())
        except OSError:
            h.update(str(p).encode())
    h.update(json.dumps([list(sets), np_ranks]).encode())
    return h.hexdigest()


def _earlier_fingerprint(out: Path) -> str | None:
    try:
        return json.loads((out / "accuracy.json").read_text(encoding="utf-8")).get("fingerprint")
    except (OSError, ValueError, AttributeError):
        return None


@dataclass
class _State:
    """The request as it goes: the ladder's levels and probes, the results' estimates."""
    levels: list[Setting]
    probes: dict[str, Setting]
    order_cap: float
    mesh: dict[str, MeshEstimate] = field(default_factory=dict)
    probe: dict[str, dict[str, ProbeEstimate]] = field(default_factory=dict)


def run_accuracy(scene: str | Path, tolerances: Sequence[Tolerance], out: str | Path, sets: Iterable[str] = (),
                 np_ranks: int = 1, time_budget: float | None = None, memory_budget: float | None = None,
                 trust_mesh_script: bool = False, overwrite: bool = False,
                 log: Callable[[str], None] = print) -> Outcome:
    """Meet ``tolerances`` on the scene's results at the least cost the ladder predicts (see the module
    docstring). ``time_budget``: seconds the final run may take; ``memory_budget``: MB it may use."""
    from ..problem import SceneError, load_problem
    from ..quantities.registry import study_keys

    t_start = time.perf_counter()
    scene, sets = Path(scene).resolve(), list(sets)
    try:
        problem = load_problem(scene, sets)
    except SceneError as e:
        raise AccuracyError(str(e)) from None
    declared = study_keys(problem.outputs)
    tol = expand(list(tolerances), declared["key_results"] + declared["info_results"], declared["key_results"])
    axes = scene_axes(problem)
    if "mesh" not in axes:
        raise AccuracyError(f"{scene}: mesh: run --accuracy refines the mesh through mesh.refine, which "
                            f"multiplies the cell counts of [mesh.parameters] of a .geo file: this scene has none "
                            f"(a .msh file, or a .geo sized by lengths alone)")
    if np_ranks < 1:
        raise AccuracyError("--np must be >= 1")
    out = Path(out)
    try:
        lock = take_results_folder(out, problem.name, "accuracy", ACCURACY_FILES, overwrite=overwrite, log=log)
    except OutputDirError as e:
        raise AccuracyError(str(e)) from None
    try:
        fingerprint = _fingerprint(problem, sets, np_ranks)
        reuse = _earlier_fingerprint(out) == fingerprint
        try:
            mark_results_folder(out, problem.name, kind="accuracy")
            make_dir(out / "runs", root=out)
        except LinkRefused as e:
            raise AccuracyError(str(e)) from None
        ladder = Ladder(scene=scene, axes=axes, out=out, sets=sets, np_ranks=np_ranks, reuse=reuse,
                        trust_mesh_script=trust_mesh_script, log=log)
        outcome = Outcome(scene=str(scene), scene_name=problem.name, analysis=problem.analysis.type,
                          tolerances=tol, axes={a: {k: v for k, (_, v) in ax.settings.items()}
                                                for a, ax in axes.items()},
                          fingerprint=fingerprint, np_ranks=np_ranks, sets=sets)
        try:
            _request(problem, tol, ladder, outcome, time_budget, memory_budget)
        except (LinkRefused, OutputDirError) as e:
            raise AccuracyError(str(e)) from None
        outcome.runs = ladder.runs
        outcome.final_names = ladder.final_names
        outcome.total_s = time.perf_counter() - t_start
        try:
            write_json(outcome, out / "accuracy.json")
            write_markdown(outcome, out / "accuracy.md")
        except LinkRefused as e:
            raise AccuracyError(str(e)) from None
    finally:
        lock.release()
    return outcome


def _request(problem, tol: dict[str, Tolerance], ladder: Ladder, outcome: Outcome,
             time_budget: float | None, memory_budget: float | None) -> None:
    """The ladder, the estimates, the final run(s): fills ``outcome``."""
    explicit = problem.explicit
    levels, probes = ladder_settings(ladder.axes)
    st = _State(levels, probes, order_cap=theoretical_order(problem))
    if not _estimate(tol, ladder, st, outcome, explicit):
        return
    walls = tuple(float(ladder.runs[s.name].value("wall_time_s") or 0.0) for s in levels[-2:])
    k = predicted_cost(walls, tuple(s.factor("mesh") for s in levels[-2:]), 1.0, 1.0)[1]
    needs = {key: need(tol[key].absolute(_reference(st.mesh[key])), st.mesh[key], st.probe[key], explicit,
                       cost_exponent=k) for key in tol}
    outcome.estimates = {k: _estimate_dict(st.mesh[k], st.probe[k]) for k in tol}
    refused = {k: n for k, n in needs.items() if n.refusal}
    if refused:
        for k, n in refused.items():
            outcome.refuse(f"{k}: {n.refusal}", _advice(st.mesh[k]) if n.axis == "mesh" else probe_advice(n.axis))
        return
    exact = ladder.axes["mesh"].exact
    factors = final_factors(list(needs.values()), finest=levels[-1].factor("mesh"), exact=exact)
    for axis in EFFECTIVE:                  # the measured refinement each result needs -> the setting's
        if factors.get(axis, 1.0) > 1.0:
            factors[axis] = round_up(nominal_factor(axis, factors[axis], ladder, levels[0].name, explicit))
    dim = 3 if problem.mesh.geometry == "3d" else 2
    for attempt in range(MAX_FINALS):
        setting = Setting.of(**factors)
        outcome.predicted = _predict(ladder, levels, setting, explicit, dim)
        over = _over_budget(outcome.predicted, time_budget, memory_budget)
        if over:
            outcome.refuse(f"the run that meets the tolerances ({setting.name}) is predicted to take {over}",
                           "raise the budget (--time-budget, --memory-budget), loosen the tolerance, or accept "
                           "the finest ladder run: its results and error bars are in the table")
            _report(outcome, tol, ladder, st, levels[-1], levels[-1].name, explicit, predicted_bar=False)
            return
        final_name = levels[-1].name
        if setting != levels[-1]:
            run = ladder.run(setting, final=True)
            if not run.ok:
                outcome.refuse(f"the final run {run.name} {run.status}: {run.reason}",
                               "its run.log is in runs/" + run.name + "/")
                _report(outcome, tol, ladder, st, levels[-1], levels[-1].name, explicit, predicted_bar=False)
                return
            final_name = run.name
        outcome.final = final_name
        outcome.final_setting = dict(setting.factors)
        outcome.final_overrides = setting.overrides(ladder.axes)
        _report(outcome, tol, ladder, st, setting, final_name, explicit,
                predicted_bar=setting != levels[-1] and not setting.others_at_one())
        grow = _growth(outcome.results)
        if grow is None or attempt == MAX_FINALS - 1:
            return
        factors = dict(factors, mesh=exact(factors["mesh"] * grow, up=True))
        outcome.notes.append(f"the final run's bars exceeded a tolerance: one more refinement, mesh factor "
                             f"{factors['mesh']:g}")


def _estimate(tol: dict[str, Tolerance], ladder: Ladder, st: _State, outcome: Outcome, explicit: bool) -> bool:
    """Run the ladder (its meshes, one probe per other axis, more probes where one matters) and
    estimate each result's error (``st.mesh``, ``st.probe``); False, with the refusal in ``outcome``,
    when a run fails or an axis's probes do not converge."""
    levels, probes = st.levels, st.probes
    outcome.ladder_names = [s.name for s in [*levels, *probes.values()]]
    for s in [*levels, *probes.values()]:
        run = ladder.run(s)
        if not run.ok:
            outcome.refuse(f"the ladder's run {run.name} {run.status}: {run.reason}",
                           "fix what stopped it (its run.log is in runs/" + run.name + "/), or start the ladder "
                           "from another mesh with --set mesh.refine=...")
            return False
    for key in tol:
        values = [ladder.runs[s.name].value(key) for s in levels]
        st.mesh[key] = mesh_estimate([1.0 / s.factor("mesh") for s in levels],
                                     [v if isinstance(v, (int, float)) else float("nan") for v in values],
                                     order_cap=st.order_cap)
        st.probe[key] = {a: probe_estimate(a, [1.0, effective_factor(a, p.name, ladder, levels[0].name, explicit)],
                                           [values[0], ladder.runs[p.name].value(key)])
                         for a, p in probes.items()}
    absolute = {k: t.absolute(_reference(st.mesh[k])) for k, t in tol.items()}
    for axis in axes_to_measure(st.probe, absolute, explicit):
        found, why = more_probes(axis, list(tol), ladder, [levels[0].name, probes[axis].name], explicit,
                                 outcome.ladder_names)
        if why:
            outcome.refuse(*why)
            return False
        for key, estimate in found.items():
            st.probe[key][axis] = estimate
    return True


def _growth(results: list[ResultReport]) -> float | None:
    """The further mesh factor that brings every monotone bar above its tolerance to TARGET of it;
    None when every bar is met (or none that is not can be shrunk by the mesh)."""
    grow = None
    for r in results:
        est = r.mesh_estimate
        if r.met or est is None or est.kind != "monotone" or r.tolerance_abs <= 0:
            continue
        g = (r.bar / (TARGET * r.tolerance_abs)) ** (1.0 / est.used_order)
        grow = g if grow is None else max(grow, g)
    return grow


def theoretical_order(problem) -> float:
    """The order the scene's results can be expected to converge at (:data:`THEORETICAL_ORDER`):
    first with plasticity or contact, second for a smooth (elastic, contactless) problem."""
    rough = {"plasticity", "contact"} & set(problem.active_physics)
    return THEORETICAL_ORDER["plastic or contact" if rough else "smooth"]


def _reference(est: MeshEstimate) -> float:
    """The value a relative tolerance is taken of: the finest level's."""
    return est.values[-1]


def _estimate_dict(est: MeshEstimate, probes: dict[str, ProbeEstimate]) -> dict:
    return dict(kind=est.kind, sizes=list(est.h), values=list(est.values), order=est.order,
                extrapolated=est.value, note=est.note,
                probes={a: dict(ratio=p.ratio, difference=p.difference, bound=p.bound, order=p.order,
                                measured=None if p.ladder is None else dict(kind=p.ladder.kind, order=p.ladder.order,
                                                                            note=p.ladder.note))
                        for a, p in probes.items()})


def _advice(est: MeshEstimate) -> str:
    """What to do about a result the mesh ladder cannot vouch for."""
    if est.kind == "oscillating":
        rel = est.bar / abs(est.values[-1]) if est.values[-1] else float("inf")
        return (f"this result does not converge monotonically with the mesh (a quantity past a bifurcation or a "
                f"neck, or one that jumps from node to node): choose a result that does, or a tolerance above "
                f"{rel * 100:.3g} % (3 x the range of the ladder's values), which the data support")
    if est.kind == "refused" and est.order is not None:
        change = abs(est.values[-1] - est.values[-2]) / abs(est.values[-1]) if est.values[-1] else float("inf")
        return (f"the result changes by {change * 100:.3g} % between the two finest meshes and its differences "
                f"shrink too slowly (order {est.order:.2f}): either the scene's mesh is too coarse for the "
                f"asymptotic range, or the result does not converge with the mesh (a localised quantity past a "
                f"neck or a shear band). Start the ladder finer (--set mesh.refine=2) and ask again; if the "
                f"order stays low, the result depends on the mesh: choose another")
    return ("the result does not converge with the mesh on the ladder (its differences do not shrink): start "
            "the ladder finer (--set mesh.refine=2) and ask again, or choose another result")


def _predict(ladder: Ladder, levels: list[Setting], setting: Setting, explicit: bool, dim: int) -> dict:
    """Predicted wall time (s) and peak memory (MB) of ``setting`` from the two finest ladder levels."""
    r1, r2 = (ladder.runs[s.name] for s in levels[-2:])
    f1, f2 = (s.factor("mesh") for s in levels[-2:])
    time_factor = 1.0 if explicit else setting.factor("time")
    wall, k = predicted_cost((float(r1.value("wall_time_s") or 0), float(r2.value("wall_time_s") or 0)),
                             (f1, f2), setting.factor("mesh"), time_factor)
    c1, c2 = float(r1.value("cells") or 1), float(r2.value("cells") or 1)
    cells = c2 * (setting.factor("mesh") / f2) ** dim
    mem = None
    m1, m2 = r1.value("peak_memory_mb"), r2.value("peak_memory_mb")
    if isinstance(m1, (int, float)) and isinstance(m2, (int, float)):
        mem = predicted_memory((m1, m2), (c1, c2), cells)
    return dict(wall_time_s=wall, cost_exponent=k, cells=cells, peak_memory_mb=mem)


def _over_budget(predicted: dict, time_budget: float | None, memory_budget: float | None) -> str | None:
    if time_budget is not None and predicted["wall_time_s"] > time_budget:
        return f"about {predicted['wall_time_s']:.3g} s, more than --time-budget {time_budget:g} s"
    mem = predicted.get("peak_memory_mb")
    if memory_budget is not None and mem is not None and mem > memory_budget:
        return f"about {mem:.4g} MB, more than --memory-budget {memory_budget:g} MB"
    return None


def _report(outcome: Outcome, tol: dict[str, Tolerance], ladder: Ladder, st: _State, setting: Setting,
            final_name: str, explicit: bool, predicted_bar: bool) -> None:
    """Each result's value and error bar at the final run ``final_name`` (``setting``). The mesh part:
    when the final refines the mesh alone, re-estimated from every mesh run (the ladder's and the
    finals'), else ``predicted_bar`` from the ladder's three meshes at the final's size."""
    outcome.results = []
    size = {n: 1.0 / ladder.setting_of[n].factor("mesh") for n in ladder.runs}     # relative mesh sizes
    h = size[final_name]
    meshes = [n for n in (*[s.name for s in st.levels], *ladder.final_names)
              if ladder.runs[n].ok and ladder.setting_of[n].others_at_one()]
    meshes = sorted(dict.fromkeys(meshes), key=lambda n: -size[n])
    for key, t in tol.items():
        value = ladder.runs[final_name].value(key)
        est = st.mesh[key]
        mesh_bar, mesh_note = est.bar_at(h), "predicted from the ladder's meshes" if predicted_bar else ""
        if not predicted_bar and len(meshes) > len(st.levels):
            again = mesh_estimate([size[n] for n in meshes], [ladder.runs[n].value(key) for n in meshes],
                                  order_cap=st.order_cap)
            if again.ok:
                est, mesh_bar = again, again.bar_at(h)
                mesh_note = f"from {len(meshes)} meshes, the final run's included"
            else:
                mesh_note = f"the final run does not confirm the ladder ({again.note}): the ladder's prediction"
        measured = {a: effective_factor(a, final_name, ladder, st.levels[0].name, explicit) if a in EFFECTIVE else f
                    for a, f in setting.factors}
        bar, parts = bar_parts(mesh_bar, st.probe[key], measured, explicit, h)
        t_abs = t.absolute(value if isinstance(value, (int, float)) and value else _reference(st.mesh[key]))
        outcome.results.append(ResultReport(
            key=key, value=value, bar=bar, parts=parts, tolerance=t, tolerance_abs=t_abs,
            met=bool(isinstance(value, (int, float)) and bar <= t_abs), order=est.order, kind=est.kind,
            extrapolated=est.value, mesh_note=mesh_note, mesh_estimate=est))
