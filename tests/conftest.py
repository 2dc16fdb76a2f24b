"""Suite-wide check: no output of the test suite holds a NaN or an infinity.

After every test that passed, the text outputs written under pytest's temporary directory (every
``tmp_path`` and ``tmp_path_factory`` directory of the session) since the previous check are read:

* ``*.csv`` and Markdown tables (``*.md`` lines starting with ``|``): a cell that parses as a
  float but is not finite (``nan``, ``inf``, ``-Infinity``, ... in any case) fails the test;
  text cells (error messages) and empty cells are not numbers and pass;
* ``*.json``: the tokens ``NaN``, ``Infinity`` and ``-Infinity`` (Python's json writes them unless
  told not to) fail the test;
* ``summary.json`` also fails on a ``null`` outside ``scene_settings`` (optional scene keys are
  null there): :func:`fenics_plast.output.to_jsonable` writes a non-finite float as ``null``, so a
  null result is a NaN that was hidden.

Binary files (``.h5``, ``.npz``, ``.png``) are not read. The repository's own ``results/`` is not a
test output. A test that writes a non-finite value on purpose says so with
``@pytest.mark.allow_nonfinite("reason")``. Files written by a module- or session-scoped fixture
are checked after the first test that ends once they exist; the files of a test that fails on its
own are not checked (nor blamed on the next test).
"""
from __future__ import annotations

import json
import math
import os
from pathlib import Path

import pytest

_seen: dict[str, tuple[int, int]] = {}      # path -> (mtime_ns, size) at its last check
_TEXT_SUFFIXES = (".csv", ".json", ".md")


def pytest_configure(config):
    config.addinivalue_line("markers", "allow_nonfinite(reason): the test writes NaN/inf on purpose; "
                                       "its outputs are not checked")


def _nonfinite_cell(cell: str) -> bool:
    s = cell.strip()
    if not s:
        return False
    try:
        return not math.isfinite(float(s))
    except ValueError:
        return False


def _csv_problems(path: Path) -> list[str]:
    import csv
    out = []
    with open(path, newline="", encoding="utf-8", errors="replace") as f:
        rows = csv.reader(f)
        header = None
        for i, row in enumerate(rows, start=1):
            if header is None:
                header = row
            for j, cell in enumerate(row):
                if _nonfinite_cell(cell):
                    col = header[j] if header is not None and j < len(header) else f"column {j + 1}"
                    out.append(f"line {i}, {col}: {cell!r}")
    return out


def _markdown_problems(path: Path) -> list[str]:
    out = []
    for i, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), start=1):
        if line.lstrip().startswith("|"):
            out += [f"line {i}: {c.strip()!r}" for c in line.split("|") if _nonfinite_cell(c)]
    return out


def _nulls(obj, where="") -> list[str]:
    if obj is None:
        return [where or "(top level)"]
    out = []
    if isinstance(obj, dict):
        for k, v in obj.items():
            if where == "" and k == "scene_settings":
                continue
            out += _nulls(v, f"{where}.{k}" if where else str(k))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            out += _nulls(v, f"{where}[{i}]")
    return out


def _json_problems(path: Path) -> list[str]:
    bad = []

    def constant(token):
        bad.append(f"token {token}")
        return float(token.replace("Infinity", "inf"))

    text = path.read_text(encoding="utf-8", errors="replace")
    try:
        data = json.loads(text, parse_constant=constant)
    except ValueError:
        return []           # not ours to judge (a half-written file is another test's business)
    if path.name == "summary.json":
        bad += [f"null at {w} (a non-finite float written as null?)" for w in _nulls(data)]
    return bad


def nonfinite_problems(path: Path) -> list[str]:
    """The non-finite entries of one output file, as readable strings (empty: clean)."""
    if path.suffix == ".csv":
        return _csv_problems(path)
    if path.suffix == ".json":
        return _json_problems(path)
    if path.suffix == ".md":
        return _markdown_problems(path)
    return []


def _new_outputs(base: Path):
    """Text outputs under base that are new or changed since they were last checked."""
    for root, _dirs, files in os.walk(base):
        for name in files:
            if not name.endswith(_TEXT_SUFFIXES):
                continue
            p = os.path.join(root, name)
            try:
                st = os.stat(p)
            except OSError:
                continue
            key = (st.st_mtime_ns, st.st_size)
            if _seen.get(p) != key:
                _seen[p] = key
                yield Path(p)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_call(item):
    outcome = yield
    factory = getattr(item.config, "_tmp_path_factory", None)
    if factory is None:
        return
    base = factory.getbasetemp()
    new = list(_new_outputs(base))        # consumed in every case: never blamed on a later test
    if outcome.excinfo is not None or item.get_closest_marker("allow_nonfinite") is not None:
        return                            # failed, skipped or xfailed on its own; or allowed
    report = []
    for p in new:
        probs = nonfinite_problems(p)
        if probs:
            shown = "; ".join(probs[:5]) + (f"; ... ({len(probs)} in all)" if len(probs) > 5 else "")
            report.append(f"{p.relative_to(base)}: {shown}")
    if report:
        raise AssertionError("non-finite values in the test's outputs (NaN/inf must never reach a "
                             "file):\n  " + "\n  ".join(report))
