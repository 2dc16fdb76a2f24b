"""The study as a table: its runs, references and the columns derived from them.

* :class:`Study`: the scene, the varied keys, the runs and their references, the key results
  (errors reported), the info columns (shown without error) and the published references;
  :meth:`Study.rows` gives one dict per run, the content of study.csv;
* :func:`declared_outputs`: the key results, info columns and published references that the runs
  declare in their summary.json (``key_results``, ``info_results``, ``references``): the study
  knows no scene by name;
* :func:`cheapest_within`: the cheapest run within a tolerance of its reference.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

from .execute import Run
from .plan import Vary
from .references import Reference, finite, relative_error

#: Bookkeeping columns of the table (those present in at least one run are shown).
RUN_COLUMNS = ["wall_time_s", "process_time_s", "mpi_ranks", "cells", "dofs", "steps", "increments",
               "newton_iterations"]


@dataclass
class Declared:
    """What the runs' summary.json declare (see :func:`declared_outputs`)."""
    key_results: list[str] = field(default_factory=list)
    info_results: list[str] = field(default_factory=list)
    references: dict[str, dict[str, Any]] = field(default_factory=dict)   # key -> {value, source}


def _str_list(v) -> list[str]:
    return [x for x in v if isinstance(x, str)] if isinstance(v, (list, tuple)) else []


def declared_outputs(runs: Sequence[Run]) -> Declared:
    """The union, in order of first appearance, of the runs' ``key_results`` and ``info_results``;
    the ``references`` (with a finite value) of the first run that has any, successful runs first."""
    out = Declared()
    for r in runs:
        for k in _str_list(r.summary.get("key_results")):
            if k not in out.key_results:
                out.key_results.append(k)
        for k in _str_list(r.summary.get("info_results")):
            if k not in out.info_results:
                out.info_results.append(k)
    for r in sorted(runs, key=lambda r: not r.ok):
        refs = r.summary.get("references")
        if not isinstance(refs, dict):
            continue
        good = {k: {"value": float(v["value"]), "source": str(v.get("source", ""))}
                for k, v in refs.items() if isinstance(v, dict) and finite(v.get("value"))}
        if good:
            out.references = good
            break
    return out


@dataclass
class Study:
    """A study: its settings, runs and references (the runs and refs are filled as it goes)."""
    scene: Path
    scene_name: str
    varies: list[Vary]
    sets: list[str]
    keys: list[str]
    info: list[str]
    out: Path
    analysis: str = ""                                      # static | explicit (title only)
    np_ranks: int = 1
    paper: dict[str, float] = field(default_factory=dict)   # key -> published value compared with
    paper_sources: dict[str, str] = field(default_factory=dict)
    paper_note: str = ""                                    # why published references are not compared
    runs: list[Run] = field(default_factory=list)
    refs: list[Reference] = field(default_factory=list)
    command: str = ""

    def ref_of(self, run: Run) -> Reference:
        for ref in self.refs:
            if run in ref.runs:
                return ref
        raise KeyError(run.name)

    def run_columns(self) -> list[str]:
        """Bookkeeping columns present in at least one run."""
        return [c for c in RUN_COLUMNS if any(r.value(c) is not None for r in self.runs)]

    def rows(self) -> tuple[list[str], list[dict[str, Any]]]:
        """(header, one dict per run): the columns of study.csv."""
        paper = self.paper
        header = (["run"] + [v.key for v in self.varies] + ["status", "reason"] + self.run_columns()
                  + self.keys + self.info + [f"ref_{k}" for k in self.keys] + [f"order_{k}" for k in self.keys]
                  + [f"err_{k}" for k in self.keys] + [f"err_paper_{k}" for k in self.keys if k in paper])
        rows = []
        for r in self.runs:
            ref = self.ref_of(r)
            row = {"run": r.name, **r.settings, "status": r.status, "reason": r.reason}
            for c in self.run_columns() + self.keys + self.info:
                row[c] = r.value(c)
            for k in self.keys:
                row[f"ref_{k}"] = ref.values.get(k)
                row[f"order_{k}"] = ref.orders.get(k)
                row[f"err_{k}"] = relative_error(r.value(k), ref.values.get(k)) if r.ok else None
                if k in paper:
                    row[f"err_paper_{k}"] = relative_error(r.value(k), paper[k]) if r.ok else None
            rows.append(row)
        return header, rows


def cheapest_within(study: Study, key: str, tol: float, ref: Reference | None = None) -> Run | None:
    """The successful run (of ``ref``'s group, or of any group) with the smallest wall time whose
    |err_key| <= tol against its group's reference; the reference run itself is left out."""
    best = None
    for r in (ref.runs if ref is not None else study.runs):
        ref_r = study.ref_of(r)
        if not r.ok or (r is ref_r.run and ref_r.orders.get(key) is None):
            continue
        e = relative_error(r.value(key), ref_r.values.get(key))
        t = r.value("wall_time_s")
        if e is None or abs(e) > tol or t is None:
            continue
        if best is None or t < best.value("wall_time_s"):
            best = r
    return best
