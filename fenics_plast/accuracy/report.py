"""What an accuracy request tells the user: :class:`Outcome` (the request, its runs, each result's
value and error bar, or why it was refused), written as accuracy.json and accuracy.md and printed as
:func:`lines`."""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..out_files import write_atomic
from .estimate import MeshEstimate
from .tolerance import Tolerance

#: what a request writes in its folder (``runs/<setting>/`` holds each run)
ACCURACY_FILES = ("accuracy.json", "accuracy.md", "runs")

#: the sources of an error bar, as the report names them
SOURCES = {"mesh": "mesh", "time": "time step", "contact": "contact penalty",
           "time_in_mesh": "time step (within the mesh's: dt follows h)"}


@dataclass
class ResultReport:
    """One result at the final run: ``value`` ± ``bar`` (absolute, the result's unit), ``parts``
    {source: part of the bar}, ``met``: bar <= the tolerance."""
    key: str
    value: float | None
    bar: float
    parts: dict[str, float]
    tolerance: Tolerance
    tolerance_abs: float
    met: bool
    order: float | None
    kind: str
    extrapolated: float | None
    mesh_note: str = ""
    mesh_estimate: MeshEstimate | None = None

    @property
    def relative_bar(self) -> float | None:
        return self.bar / abs(self.value) if isinstance(self.value, (int, float)) and self.value else None

    def as_dict(self) -> dict:
        return dict(value=self.value, error_bar=self.bar, relative_error_bar=self.relative_bar, parts=self.parts,
                    tolerance=self.tolerance.text, tolerance_abs=self.tolerance_abs, met=self.met,
                    observed_order=self.order, convergence=self.kind, extrapolated=self.extrapolated,
                    mesh_bar=self.mesh_note or "from the ladder's three meshes")


@dataclass
class Outcome:
    """An accuracy request and what became of it (filled as it goes)."""
    scene: str
    scene_name: str
    analysis: str
    tolerances: dict[str, Tolerance]
    axes: dict[str, dict[str, Any]]
    fingerprint: str
    np_ranks: int = 1
    sets: list[str] = field(default_factory=list)
    runs: dict = field(default_factory=dict)
    ladder_names: list[str] = field(default_factory=list)
    final_names: list[str] = field(default_factory=list)
    final: str | None = None
    final_setting: dict[str, float] = field(default_factory=dict)
    final_overrides: list[str] = field(default_factory=list)
    predicted: dict = field(default_factory=dict)
    estimates: dict[str, dict] = field(default_factory=dict)
    results: list[ResultReport] = field(default_factory=list)
    refusals: list[tuple[str, str]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    total_s: float = 0.0

    def refuse(self, why: str, advice: str) -> None:
        self.refusals.append((why, advice))

    @property
    def status(self) -> str:
        """"met" (every tolerance), "not met" (a bar above its tolerance) or "refused"."""
        if self.refusals:
            return "refused"
        return "met" if self.results and all(r.met for r in self.results) else "not met"

    def _seconds(self, names) -> float:
        return sum(self.runs[n].process_time_s or 0.0 for n in names if n in self.runs)

    @property
    def ladder_s(self) -> float:
        return self._seconds(self.ladder_names)

    @property
    def final_s(self) -> float | None:
        """Process seconds of the final run (a ladder run when the ladder's finest mesh is final)."""
        return self._seconds([self.final]) if self.final else None

    @property
    def cost_ratio(self) -> float | None:
        """(ladder + final runs) / the final run alone."""
        f = self.final_s
        return (self.ladder_s + self._seconds(self.final_names)) / f if f else None


def _num(x, digits: int = 5) -> str:
    if not isinstance(x, (int, float)) or isinstance(x, bool):
        return "–"
    return f"{x:.{digits}g}" if math.isfinite(x) else str(x)


def lines(o: Outcome) -> list[str]:
    """The request's outcome in a few lines (printed at the end of ``run --accuracy``)."""
    out = []
    for r in o.results:
        rel = r.relative_bar
        out.append(f"  {r.key} = {_num(r.value, 6)} ± {_num(r.bar, 2)}" + (f" ({rel * 100:.2g} %)" if rel else "")
                   + f"; tolerance {r.tolerance.text}: {'met' if r.met else 'NOT met'}")
    if o.final:
        where = " (the ladder's finest mesh)" if o.final in o.ladder_names else ""
        out.append(f"  settings: {' '.join(o.final_overrides) or 'the scene as written'}{where}; run {o.final}")
        out.append(f"  time: ladder {o.ladder_s:.3g} s ({len(o.ladder_names)} runs), final run "
                   f"{_num(o.final_s, 3)} s; (ladder + final) / final = {_num(o.cost_ratio, 3)}")
    for why, advice in o.refusals:
        out.append(f"  refused: {why}\n    what to do: {advice}")
    out.extend(f"  note: {n}" for n in o.notes)
    if o.refusals and o.runs:
        out.append("  the runs: " + "; ".join(
            f"{n}: " + ", ".join(f"{k} {_num(r.value(k), 6)}" for k in o.tolerances) for n, r in o.runs.items()))
    return out


def as_dict(o: Outcome) -> dict:
    return dict(
        scene=o.scene, scene_name=o.scene_name, analysis=o.analysis, status=o.status, fingerprint=o.fingerprint,
        np_ranks=o.np_ranks, sets=o.sets, tolerances={k: t.text for k, t in o.tolerances.items()},
        axes=o.axes, final_run=o.final, final_setting=o.final_setting, final_overrides=o.final_overrides,
        predicted=o.predicted, results={r.key: r.as_dict() for r in o.results}, estimates=o.estimates,
        refusals=[dict(why=w, advice=a) for w, a in o.refusals], notes=o.notes,
        ladder_runs=o.ladder_names, final_runs=o.final_names, ladder_s=o.ladder_s, final_s=o.final_s,
        cost_ratio=o.cost_ratio, total_s=o.total_s,
        runs={n: dict(status=r.status, reason=r.reason, reused=r.reused, process_time_s=r.process_time_s,
                      wall_time_s=r.value("wall_time_s"), cells=r.value("cells"),
                      results={k: r.value(k) for k in o.tolerances}) for n, r in o.runs.items()})


def write_json(o: Outcome, path: Path) -> None:
    write_atomic(path, json.dumps(as_dict(o), indent=1, default=str) + "\n", root=path.parent, fsync=False)


def write_markdown(o: Outcome, path: Path) -> None:
    """accuracy.md: the results with their error bars, the settings, the ladder and any refusal."""
    md = [f"# Accuracy on demand: {o.scene_name}", "",
          f"Scene `{o.scene}` ({o.analysis}); status: **{o.status}**.", ""]
    if o.results:
        md += ["| result | value ± error bar | relative | tolerance | met | convergence | observed order | "
               "extrapolated |", "|---|---|---|---|---|---|---|---|"]
        for r in o.results:
            rel = r.relative_bar
            md.append(f"| `{r.key}` | {_num(r.value, 6)} ± {_num(r.bar, 2)} | "
                      f"{f'{rel * 100:.2g} %' if rel else '–'} | {r.tolerance.text} | {'yes' if r.met else 'no'} | "
                      f"{r.kind} | {_num(r.order, 3)} | {_num(r.extrapolated, 6)} |")
        sources = list(dict.fromkeys(s for r in o.results for s in r.parts))
        md += ["", "Where each error bar comes from (absolute, the result's unit):", "",
               "| result | " + " | ".join(SOURCES[s] for s in sources) + " | the mesh part |",
               "|---|" + "---|" * (len(sources) + 1)]
        for r in o.results:
            md.append(f"| `{r.key}` | " + " | ".join(_num(r.parts.get(s), 2) for s in sources)
                      + f" | {r.mesh_note or 'from the ladder'} |")
        md.append("")
    if o.final:
        md += [f"Final run: `runs/{o.final}/`, overrides: `{' '.join(o.final_overrides) or 'none'}`.",
               f"Time (process seconds): ladder {o.ladder_s:.3g} s ({len(o.ladder_names)} runs), final run "
               f"{_num(o.final_s, 3)} s, (ladder + final) / final = {_num(o.cost_ratio, 3)}; the whole request "
               f"{o.total_s:.3g} s (reused runs count what they took when they ran).", ""]
    for why, advice in o.refusals:
        md += [f"**Refused**: {why}", "", f"What to do: {advice}", ""]
    md += [f"Note: {n}" for n in o.notes]
    md += ["", "## The runs", "",
           "| run | status | cells | wall_time_s | process_time_s | " + " | ".join(f"`{k}`" for k in o.tolerances)
           + " |", "|---|---|---|---|---|" + "---|" * len(o.tolerances)]
    for n, r in o.runs.items():
        md.append(f"| {n} | {r.status}{' (reused)' if r.reused else ''} | {_num(r.value('cells'))} | "
                  f"{_num(r.value('wall_time_s'), 3)} | {_num(r.process_time_s, 3)} | "
                  + " | ".join(_num(r.value(k), 6) for k in o.tolerances) + " |")
    md += ["", "Axis settings of the scene (a factor refines them: larger counts, smaller sizes and steps): "
           + "; ".join(f"{a}: " + ", ".join(f"`{k}` = {v:g}" for k, v in s.items()) for a, s in o.axes.items()), ""]
    write_atomic(path, "\n".join(md) + "\n", root=path.parent, fsync=False)

