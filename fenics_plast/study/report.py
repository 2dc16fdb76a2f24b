"""The study's report files, written from a :class:`~fenics_plast.study.table.Study`:

* ``study.csv`` (:func:`write_csv`): one row per run: the varied values, status and reason, wall
  time [s], cells, dofs, steps or increments, Newton iterations, the key results, the info
  columns, the reference of each key result (``ref_<key>``), the observed order of a Richardson
  extrapolation (``order_<key>``), the signed relative error ``err_<key>`` = (value - reference) /
  |reference| (a fraction, not %) and ``err_paper_<key>`` against a published value;
* ``study.md`` (:func:`write_markdown`): the same as a Markdown table, the references, the
  published references and their sources, the reasons of failed runs and the cheapest run within
  5 %, 1 % and 0.1 % of the reference for each key result;
* ``study.png`` (:func:`write_plot`): |relative error| against wall time, log-log, one colour per
  key result.
"""
from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any

from .plan import ordered_varies
from .references import relative_error
from .table import Study, cheapest_within

#: Tolerances of the "cheapest run within" lines of study.md (fractions).
TOLERANCES = (0.05, 0.01, 0.001)


def _csv_cell(v) -> Any:
    if v is None:
        return ""
    if isinstance(v, bool):
        return int(v)
    if isinstance(v, float):
        return repr(v)
    return v


def write_csv(study: Study, path: Path) -> Path:
    from ..out_files import open_write
    header, rows = study.rows()
    with open_write(path, newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(header)
        for row in rows:
            w.writerow([_csv_cell(row.get(c)) for c in header])
    return path


def _fmt(v, digits=4) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return str(v).lower()
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            return str(v)
        if v != 0 and (abs(v) >= 1e5 or abs(v) < 1e-3):
            return f"{v:.{digits - 1}e}"
        return f"{v:.{digits}g}"
    return str(v)


def _pct(e) -> str:
    if e is None:
        return ""
    if e == 0:
        return "0"
    a = abs(e) * 100
    return f"{e * 100:+.2f} %" if a >= 0.1 else f"{e * 100:+.2g} %"


def _display_path(p: Path) -> str:
    try:
        return str(p.relative_to(Path.cwd()))
    except ValueError:
        return str(p)


def _md_escape(s: str) -> str:
    return s.replace("|", "\\|").replace("\n", " ")


def _runs_table(study: Study, rows: list[dict]) -> list[str]:
    """The Markdown table of the runs and the numbered reasons of those that failed."""
    cols = study.run_columns()
    taken = set(cols + study.keys + study.info + ["run", "status"])
    head = (["run"] + [v.key if v.short in taken else v.short for v in study.varies] + ["status"] + cols
            + study.keys + study.info)
    L = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    notes = []
    for r, row in zip(study.runs, rows):
        status = r.status
        if r.reason:
            notes.append((r.name, r.reason))
            status += f" [{len(notes)}]"
        cells = [r.name] + [r.settings[v.key] for v in study.varies] + [status]
        cells += [_fmt(row.get(c), 3 if c.endswith("_s") else 4) for c in cols]
        for k in study.keys:
            v = row.get(k)
            e = row.get(f"err_{k}")
            cells.append(_fmt(v, 5) + (f" ({_pct(e)})" if e is not None else ""))
        cells += [_fmt(row.get(c), 3) for c in study.info]
        L.append("| " + " | ".join(_md_escape(c) for c in cells) + " |")
    L.append("")
    if notes:
        L += [f"[{i + 1}] {name}: {_md_escape(why)}" + "  " for i, (name, why) in enumerate(notes)]
        L.append("")
    return L


def _references(study: Study) -> list[str]:
    L = ["## References", ""]
    if not study.keys:
        L += ["No key results: the runs' summary.json declare none (`key_results`); pass "
              "`--results k1,k2` to compare summary values.", ""]
        return L
    for ref in study.refs:
        g = ", ".join(f"{k} = {v}" for k, v in ref.group) or "all runs"
        L.append(f"* **{g}**:")
        for k in study.keys:
            L.append(f"  * `{k}`: {_fmt(ref.values.get(k), 6) or 'none'} ({ref.kind.get(k, '')})")
        for n in ref.notes:
            L.append(f"  * {n}")
    L.append("")
    return L


def _published(study: Study, rows: list[dict]) -> list[str]:
    if study.paper_note:
        return [study.paper_note, ""]
    paper = study.paper
    if not paper:
        return []
    pk = [k for k in study.keys if k in paper]
    L = ["## Against the published references", ""]
    L += [f"* `{k}` = {_fmt(paper[k], 6)}" + (f": {_md_escape(study.paper_sources[k])}"
                                             if study.paper_sources.get(k) else "") for k in pk]
    L += ["", "| run | " + " | ".join(pk) + " |", "|---|" + "---|" * len(pk)]
    for r, row in zip(study.runs, rows):
        if r.ok:
            L.append(f"| {r.name} | " + " | ".join(
                f"{_fmt(row.get(k), 5)} ({_pct(row.get(f'err_paper_{k}'))})" for k in pk) + " |")
    L.append("")
    return L


def _cheapest(study: Study) -> list[str]:
    if not ordered_varies(study.varies) or not study.keys:
        return []
    L = ["## Cheapest run within a tolerance of the reference", ""]
    for ref in study.refs:
        g = ", ".join(f"{k} = {v}" for k, v in ref.group)
        if len(study.refs) > 1:
            L.append(f"* **{g}**:")
        for k in study.keys:
            parts = []
            for tol in TOLERANCES:
                r = cheapest_within(study, k, tol, ref)
                tol_s = f"{tol * 100:g} %"
                parts.append(f"{tol_s}: {r.label} ({r.value('wall_time_s'):.3g} s)" if r is not None
                             else f"{tol_s}: none of the runs")
            L.append(("  " if len(study.refs) > 1 else "") + f"* `{k}`: " + "; ".join(parts))
    L += ["", "(The reference run itself is left out when the reference is a run, not an extrapolation.)", ""]
    return L


def write_markdown(study: Study, path: Path, plot_name: str | None = "study.png") -> Path:
    _, rows = study.rows()
    analysis = f" ({study.analysis})" if study.analysis else ""
    L = [f"# Study of `{study.scene_name}`{analysis}", ""]
    L += ["```bash", study.command, "```", ""]
    L += [f"Scene file `{_display_path(study.scene)}`; {len(study.runs)} runs on {study.np_ranks} MPI rank(s); "
          f"{sum(r.ok for r in study.runs)} succeeded."]
    if study.sets:
        L += [f"Fixed overrides: {', '.join(f'`{s}`' for s in study.sets)}."]
    L += ["Wall time: the run's `wall_time_s` (scene loaded to summary written; process start-up, imports "
          "and the numba cache load are in `process_time_s`). Errors are signed, relative to the reference "
          "of the run's group (below).", ""]
    L += _runs_table(study, rows)
    L += _references(study)
    L += _published(study, rows)
    L += _cheapest(study)
    if plot_name:
        L += [f"![relative error against wall time]({plot_name})", ""]
    from ..out_files import write_atomic
    write_atomic(path, "\n".join(L), fsync=False)
    return path


def write_plot(study: Study, path: Path) -> Path | None:
    """|relative error| against wall time (log-log); points with zero error cannot be drawn."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 5.0))
    markers = "osD^v<>phX*"
    drawn = 0
    labelled = set()
    group_marker = {ref.group: markers[i % len(markers)] for i, ref in enumerate(study.refs)}
    for j, k in enumerate(study.keys):
        color = f"C{j}"
        for ref in study.refs:
            pts = []
            for r in ref.runs:
                e = relative_error(r.value(k), ref.values.get(k)) if r.ok else None
                t = r.value("wall_time_s")
                if e is not None and e != 0 and t:
                    pts.append((t, abs(e), r))
            pts.sort(key=lambda p: p[0])
            if not pts:
                continue
            glabel = ", ".join(f"{kk.rsplit('.', 1)[-1]}={vv}" for kk, vv in ref.group)
            ax.loglog([p[0] for p in pts], [p[1] for p in pts], marker=group_marker[ref.group], color=color,
                      linestyle="-", label=k + (f" ({glabel})" if glabel else ""))
            for t, e, r in pts:
                if r.name not in labelled:
                    labelled.add(r.name)
                    ax.annotate(r.label, (t, e), textcoords="offset points", xytext=(4, 4), fontsize=7)
            drawn += len(pts)
    ax.set_xlabel("wall time [s]")
    ax.set_ylabel("|relative error| against the reference")
    ax.set_title(f"{study.scene_name}: " + ", ".join(v.key for v in study.varies), fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    if drawn:
        ax.legend(fontsize=7)
    else:
        ax.text(0.5, 0.5, "no nonzero error to draw", transform=ax.transAxes, ha="center")
    fig.tight_layout()
    from ..out_files import open_write
    try:
        with open_write(path, mode="wb") as f:
            fig.savefig(f, dpi=110, format="png")
    finally:
        plt.close(fig)
    return path
