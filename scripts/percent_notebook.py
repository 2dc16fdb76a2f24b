#!/usr/bin/env python3
"""Convert between jupytext "percent" scripts and Jupyter notebooks (a small, strict subset).

    python3 scripts/percent_notebook.py demos/ufl_forms.py            # writes demos/ufl_forms.ipynb
    python3 scripts/percent_notebook.py --check demos/ufl_forms.py    # exit 1 if the .ipynb differs
    python3 scripts/percent_notebook.py --to-py demos/ufl_forms.ipynb # writes the .py back

The .py is the source of truth; the notebook is written without outputs. Supported syntax (what
jupytext writes for these files, so ``jupytext --sync`` works on them too):

* an optional YAML header between ``# ---`` lines, whose ``jupyter:`` mapping becomes the
  notebook metadata (kernelspec, jupytext);
* cells opened by a line ``# %%`` (code) or ``# %% [markdown]`` / ``# %% [md]`` (markdown, every
  line commented: ``# text`` or a bare ``#``); anything else after ``# %%`` is refused;
* text before the first marker is a code cell; blank lines around a cell are dropped and cells
  are written one blank line apart.

Needs only the standard library and PyYAML (Debian: python3-yaml).
"""
from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

import yaml

_MARKER = re.compile(r"^# %%(?P<rest>.*)$")
_KINDS = {"": "code", " [markdown]": "markdown", " [md]": "markdown"}


class PercentFormatError(ValueError):
    """The script is not in the supported percent subset (message names the line)."""


def _strip_blank(lines: list[str]) -> list[str]:
    while lines and not lines[0].strip():
        lines = lines[1:]
    while lines and not lines[-1].strip():
        lines = lines[:-1]
    return lines


def _header(lines: list[str], where: str) -> tuple[dict, list[str]]:
    """(notebook metadata, remaining lines) from an optional ``# ---`` YAML header."""
    if not lines or lines[0].rstrip() != "# ---":
        return {}, lines
    for end in range(1, len(lines)):
        if lines[end].rstrip() == "# ---":
            break
    else:
        raise PercentFormatError(f"{where}: line 1: header '# ---' is never closed")
    body = []
    for k, line in enumerate(lines[1:end], start=2):
        if not (line.startswith("# ") or line.rstrip() == "#"):
            raise PercentFormatError(f"{where}: line {k}: header lines must start with '# '")
        body.append(line[2:])
    data = yaml.safe_load("\n".join(body)) or {}
    if not isinstance(data, dict) or not isinstance(data.get("jupyter", {}), dict):
        raise PercentFormatError(f"{where}: the header must be a mapping with a 'jupyter:' mapping")
    return data.get("jupyter", {}), lines[end + 1:]


def py_to_notebook(text: str, where: str = "<script>") -> dict:
    """nbformat-4 notebook (a dict) from percent-script text; no outputs, deterministic ids."""
    lines = text.splitlines()
    offset = len(lines)
    metadata, lines = _header(lines, where)
    offset -= len(lines)
    cells: list[tuple[str, list[str]]] = []
    kind, body, start = "code", [], offset + 1
    for k, line in enumerate(lines, start=offset + 1):
        m = _MARKER.match(line)
        if m is None:
            body.append(line)
            continue
        rest = m.group("rest").rstrip()
        if rest not in _KINDS:
            raise PercentFormatError(f"{where}: line {k}: unsupported cell marker {line!r} "
                                     f"(use '# %%' or '# %% [markdown]')")
        cells.append((kind, body, start))
        kind, body, start = _KINDS[rest], [], k + 1
    cells.append((kind, body, start))
    nb_cells = []
    for kind, body, start in cells:
        body = _strip_blank(body)
        if not body and start == offset + 1:
            continue                          # nothing before the first marker
        if kind == "markdown":
            md = []
            for k, line in enumerate(body, start=start):
                if line.rstrip() == "#":
                    md.append("")
                elif line.startswith("# "):
                    md.append(line[2:])
                else:
                    raise PercentFormatError(f"{where}: line {k}: a markdown cell's lines must start with "
                                             f"'# ' (or be a bare '#'), got {line!r}")
            body = md
        nb_cells.append(_cell(kind, "\n".join(body), len(nb_cells)))
    return {"cells": nb_cells, "metadata": metadata, "nbformat": 4, "nbformat_minor": 5}


def _cell(kind: str, source: str, index: int) -> dict:
    cell = {"cell_type": kind, "id": f"cell-{index}", "metadata": {}, "source": source}
    if kind == "code":
        cell.update(execution_count=None, outputs=[])
    return cell


def _source(cell: dict) -> str:
    src = cell.get("source", "")
    return "".join(src) if isinstance(src, list) else src


def notebook_to_py(nb: dict) -> str:
    """Percent-script text from a notebook dict (outputs are dropped)."""
    parts = []
    meta = {k: nb.get("metadata", {})[k] for k in ("jupytext", "kernelspec") if k in nb.get("metadata", {})}
    if meta:
        head = yaml.safe_dump({"jupyter": meta}, default_flow_style=False, sort_keys=True).splitlines()
        parts.append("\n".join(["# ---", *("# " + h for h in head), "# ---"]))
    for cell in nb.get("cells", []):
        src = _source(cell)
        if cell["cell_type"] == "markdown":
            body = "\n".join("# " + ln if ln else "#" for ln in src.split("\n"))
            parts.append("# %% [markdown]\n" + body if src else "# %% [markdown]")
        elif cell["cell_type"] == "code":
            parts.append("# %%\n" + src if src else "# %%")
        else:
            raise PercentFormatError(f"cell type {cell['cell_type']!r} is not supported")
    return "\n\n".join(parts) + "\n"


def dumps(nb: dict) -> str:
    """Notebook JSON as Jupyter writes it (sources as line lists, indent 1, sorted keys)."""
    out = json.loads(json.dumps(nb))
    for cell in out["cells"]:
        src = _source(cell)
        cell["source"] = src.splitlines(keepends=True)
    return json.dumps(out, sort_keys=True, indent=1, ensure_ascii=False) + "\n"


def cells_of(nb: dict) -> list[tuple[str, str]]:
    """(cell type, source) pairs: what 'in sync' compares."""
    return [(c["cell_type"], _source(c)) for c in nb.get("cells", [])]


def differences(py_path: Path, ipynb_path: Path) -> list[str]:
    """Human-readable differences between a percent script and its notebook (empty: in sync)."""
    want = py_to_notebook(py_path.read_text(encoding="utf-8"), str(py_path))
    have = json.loads(ipynb_path.read_text(encoding="utf-8"))
    out = []
    a, b = cells_of(want), cells_of(have)
    if len(a) != len(b):
        out.append(f"{py_path} has {len(a)} cells, {ipynb_path} has {len(b)}")
    for k, (x, y) in enumerate(zip(a, b)):
        if x != y:
            out.append(f"cell {k}: {x[0]} {x[1][:60]!r}... differs from {y[0]} {y[1][:60]!r}...")
            break
    for key in ("kernelspec", "jupytext"):
        if want["metadata"].get(key) != have.get("metadata", {}).get(key):
            out.append(f"notebook metadata {key!r} differs")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("path", type=Path, help="the .py (or, with --to-py, the .ipynb)")
    ap.add_argument("--check", action="store_true", help="exit 1 if the paired .ipynb is out of sync")
    ap.add_argument("--to-py", action="store_true", help="write the .py from the .ipynb")
    a = ap.parse_args(argv)
    try:
        if a.to_py:
            nb = json.loads(a.path.read_text(encoding="utf-8"))
            a.path.with_suffix(".py").write_text(notebook_to_py(nb), encoding="utf-8")
            return 0
        ipynb = a.path.with_suffix(".ipynb")
        if a.check:
            diff = differences(a.path, ipynb) if ipynb.exists() else [f"{ipynb} does not exist"]
            for d in diff:
                print(f"out of sync: {d}", file=sys.stderr)
            return 1 if diff else 0
        nb = py_to_notebook(a.path.read_text(encoding="utf-8"), str(a.path))
        ipynb.write_text(dumps(nb), encoding="utf-8")
        return 0
    except (PercentFormatError, OSError, json.JSONDecodeError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
