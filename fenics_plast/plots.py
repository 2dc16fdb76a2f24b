"""The PNG figures a scene declares in ``[plots]``, drawn from the CSV files of a results folder.

The runner (after the run) and ``fenics-plast plot DIR`` both call :func:`draw_declared`, so both
draw the same figures; :func:`declared_figures` turns the scene's ``[plots]`` tables into:

* :class:`Lines`: curves ``y`` against ``x`` from a CSV of the folder (history.csv by default),
  optionally one curve per value of a ``group`` column (a profile at each step end), and
  horizontal lines at the published references of the plotted outputs.
* :class:`Cells`: the deformed mesh (one quadrilateral per CSV row: columns x1..y4 in mm, cyclic
  order) coloured by a cell value; written by the runner with :func:`cells_table`.

A figure whose CSV is absent (e.g. no final_shape.csv) is left out; a missing column of a CSV that
is present is an error (:class:`PlotError`). Drawn with matplotlib's Agg backend (no display).
"""
from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from fenics_plast.state_variables import by_output

__all__ = ["Lines", "Cells", "PlotError", "draw_declared", "declared_figures", "read_csv", "cells_table"]


class PlotError(ValueError):
    """A results folder that cannot be plotted (missing files or columns, no scene settings)."""


@dataclass(frozen=True)
class Lines:
    """``name``.png: curves ``ys`` (label -> column) against column ``x`` of ``source``."""
    name: str
    x: str
    ys: Mapping[str, str]
    xlabel: str
    ylabel: str
    title: str
    source: str = "history.csv"
    group: str | None = None          # one curve per distinct value of this column
    group_label: str = "{:g}"         # legend label of a group value
    hlines: Mapping[str, float] = field(default_factory=dict)   # label -> value (references)


@dataclass(frozen=True)
class Cells:
    """``name``.png: polygons (x1, y1, ..., x4, y4) of ``source`` coloured by column ``value``."""
    name: str
    value: str
    label: str
    title: str
    source: str
    mirror: bool = False              # also draw x -> -x (axisymmetric section about the axis)
    xlabel: str = "r [mm]"
    ylabel: str = "z [mm]"


# ----------------------------------------------------------------------------------------------
# reading


def read_csv(path: str | Path) -> dict[str, np.ndarray]:
    """CSV with a header row -> {column: float array}; empty cells -> NaN."""
    path = Path(path)
    try:
        with open(path, newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
    except (OSError, UnicodeDecodeError) as e:
        raise PlotError(f"{path}: cannot be read: {getattr(e, 'strerror', None) or e}") from None
    if not rows:
        raise PlotError(f"{path}: empty file (no header)")
    header, body = rows[0], [r for r in rows[1:] if r]
    cols = {}
    for j, name in enumerate(header):
        vals = []
        for i, r in enumerate(body):
            s = r[j].strip() if j < len(r) else ""
            try:
                vals.append(float(s) if s else math.nan)
            except ValueError:
                raise PlotError(f"{path}: row {i + 2}, column {name!r}: not a number: {s!r}") from None
        cols[name] = np.asarray(vals, dtype=float)
    return cols


def _read_summary(out_dir: Path) -> dict:
    path = out_dir / "summary.json"
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except FileNotFoundError:
        raise PlotError(f"{out_dir}: no summary.json (not a results folder of `fenics-plast run`)") from None
    except json.JSONDecodeError as e:
        raise PlotError(f"{path}: not valid JSON: {e}") from None


# ----------------------------------------------------------------------------------------------
# drawing


def _draw_figures(out_dir: Path, figures, title, render, processes=1) -> list[Path]:
    """Draw each figure whose CSV is in ``out_dir`` (a missing column is a PlotError); ``processes`` > 1
    draws them in that many forked processes at most (only from a process that may fork: the plot worker)."""
    tables: dict[str, dict[str, np.ndarray]] = {}
    paths, jobs = [], []
    for fig in figures:
        src = out_dir / fig.source
        if not src.exists():
            continue
        if fig.source not in tables:
            tables[fig.source] = read_csv(src)
        data = tables[fig.source]
        need = ([fig.x, *fig.ys.values()] + ([fig.group] if fig.group else [])
                if isinstance(fig, Lines) else [fig.value] + _poly_columns())
        missing = [c for c in need if c not in data]
        if missing:
            raise PlotError(f"{src}: no column(s) {', '.join(missing)} for {fig.name}.png "
                            f"(columns: {', '.join(data)})")
        path = out_dir / f"{fig.name}.png"
        from .out_files import link_at
        if link_at(out_dir, [path.name]) is not None:
            raise PlotError(f"{path}: is a symbolic link (or not a regular file): fenics-plast does not write "
                            f"through links, out of the folder: remove it; no figure was drawn")
        full_title = fig.title + (f"\n{title}" if title else "")
        jobs.append((_draw_lines if isinstance(fig, Lines) else _draw_cells, path, fig, data, full_title))
        paths.append(path)
    if not render:
        return paths
    if processes > 1 and len(jobs) > 1:
        _draw_forked(jobs, processes)
    else:
        for draw, *args in jobs:
            draw(*args)
    return paths


def _draw_forked(jobs, processes: int) -> None:
    """Draw ``jobs`` in at most ``processes`` forked children, all forked before any thread exists (no pool,
    whose helper threads would make later forks unsafe); a child's failure is raised here as a PlotError
    naming it."""
    import multiprocessing
    ctx = multiprocessing.get_context("fork")
    children = []
    for k in range(min(processes, len(jobs))):
        receive, send = ctx.Pipe(duplex=False)
        child = ctx.Process(target=_draw_child, args=(jobs[k::processes], send))
        child.start()
        send.close()
        children.append((child, receive))
    failures = []
    for child, receive in children:
        try:
            message = receive.recv()
        except EOFError:
            message = "a plotting process ended without an answer"
        child.join()
        if message:
            failures.append(message)
    if failures:
        raise PlotError("; ".join(failures))


def _draw_child(jobs, send) -> None:
    """The body of a forked plotting process: draw ``jobs``, send None, or the error as text."""
    try:
        for draw, *args in jobs:
            draw(*args)
        send.send(None)
    except Exception as e:  # noqa: BLE001 - reported to the parent
        send.send(f"{type(e).__name__}: {e}")
    finally:
        send.close()


def preload() -> None:
    """Import the parts of matplotlib the figures use and draw one figure of each kind into memory, so that
    fonts, glyphs and colour maps are loaded (what :class:`~fenics_plast.plot_worker.PlotWorker` does while
    the run computes; the children it forks to draw inherit them: the Taylor bar's figures 0.43 -> 0.35 s)."""
    import io
    lines = Lines(name="warm", x="x", ys={"y": "y"}, xlabel="x", ylabel="y", title="", hlines={"h": 0.5})
    cells = Cells(name="warm", value="v", label="v", title="", source="")
    for draw, spec, data in ((_draw_lines, lines, {"x": np.array([0.0, 1.0]), "y": np.array([0.0, 1.0])}),
                             (_draw_cells, cells, {**{c: np.array([0.0, 1.0]) for c in _poly_columns()},
                                                   "v": np.array([1.0, 2.0])})):
        draw(io.BytesIO(), spec, data, "warm-up")


def _figure(size=(6.0, 4.2)):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    fig = Figure(figsize=size)
    FigureCanvasAgg(fig)
    return fig


def _draw_lines(path: Path, spec: Lines, data, title) -> None:
    fig = _figure()
    ax = fig.add_subplot()
    x = data[spec.x]
    style = "o-" if len(x) < 3 else "-"
    n = 0
    if spec.group:
        g = data[spec.group]
        for v in [v for v in dict.fromkeys(g.tolist()) if math.isfinite(v)]:
            sel = g == v
            for label, col in spec.ys.items():
                lab = spec.group_label.format(v) + (f": {label}" if label else "")
                ax.plot(x[sel], data[col][sel], style, label=lab)
                n += 1
    else:
        for label, col in spec.ys.items():
            ax.plot(x, data[col], style, label=label)
            n += 1
    for label, v in spec.hlines.items():
        if isinstance(v, (int, float)) and math.isfinite(v):
            ax.axhline(v, color="k", ls="--", lw=1.0, label=f"{label} ({v:.4g})")
            n += 1
    ax.set_xlabel(spec.xlabel)
    ax.set_ylabel(spec.ylabel)
    ax.set_title(title, fontsize=10)
    ax.grid(True, alpha=0.3)
    if n > 1:
        ax.legend(fontsize=8)
    fig.tight_layout()
    _save(fig, path)


def _save(fig, path) -> None:
    """``fig`` as a PNG at ``path`` (a file name: written without following links, out_files) or into a
    file object."""
    if isinstance(path, (str, Path)):
        from .out_files import open_write
        with open_write(path, mode="wb") as f:
            fig.savefig(f, dpi=120, format="png")
    else:
        fig.savefig(path, dpi=120, format="png")


def _poly_columns() -> list[str]:
    return [f"{c}{k}" for k in range(1, 5) for c in "xy"]


def _draw_cells(path: Path, spec: Cells, data, title) -> None:
    from matplotlib.collections import PolyCollection
    xy = np.stack([np.column_stack([data[f"x{k}"], data[f"y{k}"]]) for k in range(1, 5)], axis=1)
    val = data[spec.value]
    polys, vals = [xy], [val]
    if spec.mirror:
        m = xy.copy()
        m[:, :, 0] *= -1.0
        polys.append(m)
        vals.append(val)
    xy, val = np.concatenate(polys), np.concatenate(vals)
    span = np.ptp(xy[:, :, 1]) if xy.size else 1.0
    width = np.ptp(xy[:, :, 0]) if xy.size else 1.0
    h = 6.0
    fig = _figure(size=(min(max(2.5 + h * width / max(span, 1e-300), 4.0), 10.0), h))
    ax = fig.add_subplot()
    pc = PolyCollection(xy, array=val, cmap="viridis", edgecolors="k", linewidths=0.2)
    ax.add_collection(pc)
    ax.autoscale_view()
    ax.set_aspect("equal")
    fig.colorbar(pc, ax=ax, label=spec.label)
    ax.set_xlabel(spec.xlabel)
    ax.set_ylabel(spec.ylabel)
    vmax = np.nanmax(val) if val.size else math.nan
    ax.set_title(f"{title}, max {spec.value} {vmax:.3g}", fontsize=10)
    fig.tight_layout()
    _save(fig, path)


# ----------------------------------------------------------------------------------------------
# the data of a Cells figure


def cells_table(V, positions, cell_values, value_name: str) -> dict[str, np.ndarray]:
    """Columns x1, y1, ..., x4, y4 [mm] (cyclic vertex order) and ``value_name`` of every cell,
    gathered on rank 0 (other ranks get empty columns) in the mesh file's cell order (the same rows
    whatever the number of ranks), for ``RunOutput.write_csv``.

    V : the P1 vector FunctionSpace of the nodes (dolfinx; its dofmap: cell -> node block).
    positions : (n_local_nodes, 2) current node positions, indexed like V's dof blocks.
    cell_values : DG0 Function (one value per cell). Collective over V's communicator.
    """
    from fenics_plast import dolfinx_compat as dc     # dolfinx only here: `fenics-plast plot` needs none
    from fenics_plast.solvers.quad_step import QUAD_CYCLE
    mesh = V.mesh
    tdim = mesh.topology.dim
    n_own = mesh.topology.index_map(tdim).size_local
    nodes = np.asarray(dc.cell_dofs(V))[:n_own][:, QUAD_CYCLE]
    xy = np.asarray(positions)[nodes, :2].reshape(n_own, 8)
    dg = np.asarray(dc.cell_dofs(cell_values.function_space)).reshape(-1)[:n_own]
    val = np.asarray(cell_values.x.array)[dg]
    local = np.column_stack([xy, val])
    original = np.asarray(mesh.topology.original_cell_index, dtype=np.int64)[:n_own]
    parts = mesh.comm.gather((original, local), root=0)
    names = [f"{c}{k}" for k in range(1, 5) for c in "xy"] + [value_name]
    if parts is None:
        table = np.zeros((0, len(names)))
    else:
        order = np.argsort(np.concatenate([p[0] for p in parts]), kind="stable")
        table = np.vstack([p[1] for p in parts])[order]
    return {n: table[:, j] for j, n in enumerate(names)}


# ----------------------------------------------------------------------------------------------
# figures declared by a scene ([plots.<name>])


def declared_figures(settings: Mapping[str, Any], references: Mapping[str, Any] | None = None) -> list:
    """The figures of a scene's ``[plots]`` tables. ``settings``: the scene as a dict (summary.json's
    ``scene_settings``; plots and mesh.geometry are read); ``references``: summary.json's
    ``references`` ({column: {value, source}}), drawn as horizontal lines on the plots of their
    columns (the column itself or its max_/min_ summary)."""
    figs = []
    references = references or {}
    axisym = (settings.get("mesh") or {}).get("geometry") == "axisymmetric"
    for name, p in (settings.get("plots") or {}).items():
        title = p.get("title") or name.replace("_", " ")
        if p["type"] == "history":
            hlines = {}
            for c in p["y"]:
                for key in (c, f"max_{c}", f"min_{c}"):
                    ref = references.get(key)
                    if isinstance(ref, Mapping) and ref.get("value") is not None:
                        hlines[f"{ref.get('source') or 'reference'}"[:80]] = float(ref["value"])
            figs.append(Lines(name, p["x"], {c: c for c in p["y"]}, xlabel=p["x"],
                              ylabel=", ".join(p["y"]) if len(p["y"]) == 1 else "", title=title, hlines=hlines))
        elif p["type"] == "profile":
            out = p["output"]
            figs.append(Lines(name, "s0_mm", {"": "value"}, xlabel="reference position along the group [mm]",
                              ylabel=f"{out} = ln(t/t0)", title=title, source=f"{out}.csv", group="time",
                              group_label="t = {:g}"))
        else:
            field = p.get("field") or "eqps"
            label = by_output(field).label()
            figs.append(Cells(name, field, label, title, "final_shape.csv", mirror=axisym,
                              xlabel="r [mm]" if axisym else "x [mm]", ylabel="z [mm]" if axisym else "y [mm]"))
    return figs


def _check_names(out_dir: Path, settings: Mapping[str, Any]) -> None:
    """PlotError unless every plot name (-> <name>.png) and profile output (<output>.csv) is a plain
    file name in ``out_dir``: settings read from a results folder's summary.json are not trusted."""
    from .output import file_name_problem, reserved_name_problem
    plots = settings.get("plots") or {}
    if not isinstance(plots, Mapping):
        raise PlotError(f"{out_dir}/summary.json: scene_settings.plots is not a table")
    for name, p in plots.items():
        why = file_name_problem(name) or reserved_name_problem(name)
        if why:
            raise PlotError(f"{out_dir}/summary.json: plots.{name!r}: the plot's name {why} (it names {name!r}.png "
                            f"in the folder): refused")
        if not isinstance(p, Mapping) or "type" not in p:
            raise PlotError(f"{out_dir}/summary.json: plots.{name}: not a plot table (no type)")
        out = p.get("output")
        if p["type"] == "profile" and (file_name_problem(out) or reserved_name_problem(out)):
            raise PlotError(f"{out_dir}/summary.json: plots.{name}.output = {out!r}: "
                            f"{file_name_problem(out) or reserved_name_problem(out)} "
                            f"(it names the profile's CSV file in the folder): refused")


def draw_declared(out_dir: str | Path, settings: Mapping[str, Any] | None = None, title: str | None = None,
                  references: Mapping[str, Any] | None = None, render: bool = True,
                  processes: int = 1) -> list[Path]:
    """Draw the scene's declared figures into ``out_dir`` from its CSV files; ``settings=None``
    reads the settings, title and references from the folder's summary.json (``fenics-plast plot DIR``).
    ``processes`` > 1: the figures are drawn in that many forked processes at most (the plot worker does;
    a process with MPI or PETSc running must not fork). Returns the PNG paths; raises :class:`PlotError`
    for a folder that cannot be plotted."""
    out_dir = Path(out_dir)
    if not out_dir.is_dir():
        raise PlotError(f"{out_dir}: no such directory")
    if settings is None:
        summary = _read_summary(out_dir)
        settings = summary.get("scene_settings")
        if not isinstance(settings, dict) or "analysis" not in settings:
            raise PlotError(f"{out_dir}/summary.json has no scene settings of a scene file (written by an "
                            f"older fenics-plast?)")
        title = title if title is not None else summary.get("scene")
        references = references if references is not None else summary.get("references")
    title = title if title is not None else (settings.get("scene") or {}).get("name")
    _check_names(out_dir, settings)
    if not (out_dir / "history.csv").exists():
        raise PlotError(f"{out_dir}: no history.csv (not a results folder of `fenics-plast run`)")
    return _draw_figures(out_dir, declared_figures(settings, references), title, render, processes)
