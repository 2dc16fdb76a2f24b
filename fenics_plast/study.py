"""Parameter studies: ``fenics-plast study SCENE.toml --vary KEY=V1,V2,... [--vary ...] [--out DIR]``.

Runs every combination of the ``--vary`` values (their Cartesian product, in the order given) as
its own process, ``python -m fenics_plast.cli run SCENE --set KEY=V ... --out DIR/runs/<name>``
(under ``mpirun -n N`` with ``--np N``), reads each run's summary.json and writes into DIR:

* ``study.csv``: one row per run: the varied values, status and reason, wall time [s], cells,
  dofs, steps or increments, Newton iterations (static kinds), the scene's key results, the
  reference each result is compared with (``ref_<key>``), the observed order where a Richardson
  extrapolation was made (``order_<key>``) and the signed relative error ``err_<key>`` =
  (value - reference) / |reference| (a fraction, not %);
* ``study.md``: the same as a Markdown table, the references, the reasons of failed runs and the
  cheapest run within 5 %, 1 % and 0.1 % of the reference for each key result;
* ``study.png``: |relative error| against wall time, log-log, one colour per key result.

Reference of a result. Keys whose value orders the runs from coarse to fine are listed in
:data:`ORDERED_KEYS` (``mesh.refine``: larger is finer; ``solver.dt_safety``: smaller is finer...);
every other varied key (``material.model``, ``contact.law``...) is categorical and splits the runs
into groups, each with its own reference: the group's finest run (finest in every ordered key).
When ``mesh.refine`` takes >= 3 values, the reference is instead the Richardson extrapolation from
the three finest refinement levels (mesh size h = 1/refine, the other ordered keys at their finest
value), with the observed order p; when the three values do not converge monotonically (or p falls
outside [0.3, 8]) the study says so and falls back to the finest run. With no ordered key varied
the reference is the first run that succeeded (a comparison of variants, not a convergence study).

A run that fails (exit status 1: summary.json has ``error``; 2: invalid combination; a crash, a
signal or ``--timeout``) becomes a row with its reason; the study goes on. Exit status of the study:
0 when at least one run succeeded, 1 when none did, 2 for bad arguments (nothing run).
"""
from __future__ import annotations

import argparse
import csv
import itertools
import json
import math
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence

#: Key results per scene kind: the quantities whose error the study reports.
KEY_RESULTS: dict[str, list[str]] = {
    "taylor_bar": ["final_radius_mm", "final_length_mm", "max_eqps"],
    "punch_stretching": ["final_punch_force_kN", "max_punch_force_kN", "pole_thickness_strain",
                         "min_thickness_strain"],
    "bar_tension": ["max_force_kN", "elongation_at_max_mm", "min_radius_mm"],
    "thick_cylinder": ["limit_pressure_MPa", "final_pressure_MPa"],
}

#: Further summary values shown in the tables (no error computed).
INFO_COLUMNS: dict[str, list[str]] = {
    "taylor_bar": ["energy_balance_error", "dt_s"],
    "punch_stretching": ["max_penetration_mm", "final_punch_displacement_mm"],
    "bar_tension": ["final_elongation_mm"],
    "thick_cylinder": ["final_inner_displacement_mm"],
}

#: Published reference values compared with as extra columns ``err_paper_<key>``.
PAPER_REFERENCE: dict[str, dict[str, float]] = {
    # seed paper, Taylor bar (Table 3): final radius 7.11 mm, final length 21.47 mm, max eqps 3.09
    "taylor_bar": {"final_radius_mm": 7.11, "final_length_mm": 21.47, "max_eqps": 3.09},
}
PAPER_LABEL = {"taylor_bar": "seed paper, Table 3 (R 7.11 mm, L 21.47 mm, max eqps 3.09)"}
#: Scene settings (dotted key: value as the runner sees it) under which the paper's values apply;
#: the paper columns are left out of a study whose base scene differs.
PAPER_CONDITIONS: dict[str, dict[str, Any]] = {
    "taylor_bar": {"loading.end_time_us": 80.0, "loading.velocity_m_s": 227.0, "mesh.radius": 3.2,
                   "mesh.length": 32.4, "material.E": 117e3, "material.hardening.yield_stress": 400.0},
}

#: Keys that order runs from coarse to fine: +1 = a larger value is finer, -1 = a smaller one.
ORDERED_KEYS: dict[str, int] = {
    "mesh.refine": +1,
    "mesh.cells_radial": +1,
    "mesh.cells_axial": +1,
    "mesh.cells_thickness": +1,
    "mesh.cells_circumferential": +1,
    "solver.dt_safety": -1,
    "solver.steps": +1,
    "solver.increments": +1,
    "solver.max_increment": -1,
    "solver.min_increment": -1,
    "solver.rtol": -1,
    "solver.atol": -1,
    "contact.penalty": +1,
    "contact.tangential_penalty": +1,
}

#: Keys along which a Richardson extrapolation is made, with the mesh size h(value).
RICHARDSON_KEYS: dict[str, Callable[[float], float]] = {"mesh.refine": lambda v: 1.0 / v}

#: Accepted range of the observed order; outside it the extrapolation is not trusted.
ORDER_RANGE = (0.3, 8.0)

#: Tolerances of the "cheapest run within" lines of study.md (fractions).
TOLERANCES = (0.05, 0.01, 0.001)

RUN_COLUMNS = ["wall_time_s", "process_time_s", "mpi_ranks", "cells", "dofs", "steps", "increments",
               "newton_iterations"]


class StudyError(ValueError):
    """Bad study arguments (exit status 2)."""


# ----------------------------------------------------------------------------------------------
# arguments


@dataclass
class Vary:
    """One ``--vary KEY=V1,V2,...``: the dotted scene key and its values as ``--set`` text."""
    key: str
    values: list[str]

    @property
    def short(self) -> str:
        return self.key.rsplit(".", 1)[-1]


def split_values(text: str) -> list[str]:
    """Split ``V1,V2,...`` on the commas outside brackets and quotes (TOML lists and strings)."""
    out, depth, quote, cur = [], 0, None, []
    for ch in text:
        if quote:
            cur.append(ch)
            if ch == quote:
                quote = None
            continue
        if ch in "\"'":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "," and depth == 0:
            out.append("".join(cur).strip())
            cur = []
            continue
        cur.append(ch)
    out.append("".join(cur).strip())
    return out


def parse_vary(text: str) -> Vary:
    """``"mesh.refine=1,2,4"`` -> ``Vary("mesh.refine", ["1", "2", "4"])``; StudyError if malformed."""
    if "=" not in text:
        raise StudyError(f"--vary {text!r} must have the form section.key=V1,V2,...")
    key, values = (s.strip() for s in text.split("=", 1))
    parts = key.split(".")
    if len(parts) < 2 or any(not p for p in parts):
        raise StudyError(f"--vary {text!r}: {key!r} must be a dotted key such as mesh.refine")
    vals = split_values(values)
    if any(v == "" for v in vals):
        raise StudyError(f"--vary {text!r}: empty value in the list")
    if len(set(vals)) != len(vals):
        raise StudyError(f"--vary {text!r}: a value is repeated")
    return Vary(key, vals)


def toml_value(text: str) -> Any:
    """The value ``--set`` would see: TOML, else the text itself."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def as_number(text: str) -> float | None:
    v = toml_value(text)
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    return float(v)


def combinations(varies: Sequence[Vary]) -> list[dict[str, str]]:
    """Cartesian product of the values, the first ``--vary`` varying slowest."""
    return [dict(zip([v.key for v in varies], combo)) for combo in
            itertools.product(*[v.values for v in varies])]


def run_label(combo: dict[str, str], varies: Sequence[Vary]) -> str:
    """Short human label, e.g. ``refine=2 dt_safety=0.5``."""
    shorts = [v.short for v in varies]
    dup = {s for s in shorts if shorts.count(s) > 1}
    return " ".join(f"{v.key if v.short in dup else v.short}={combo[v.key]}" for v in varies) or "base"


def run_name(index: int, combo: dict[str, str], varies: Sequence[Vary]) -> str:
    """Directory name of run ``index`` (0-based): ``01_refine-2_dt_safety-0.5``."""
    label = run_label(combo, varies).replace("=", "-").replace(" ", "_")
    label = re.sub(r"[^A-Za-z0-9_.+-]", "-", label)[:80]
    return f"{index + 1:02d}_{label}"


# ----------------------------------------------------------------------------------------------
# running


@dataclass
class Run:
    """One combination and what became of it."""
    name: str
    label: str
    settings: dict[str, str]
    status: str = "pending"              # ok | failed | invalid | timeout
    reason: str = ""
    summary: dict = field(default_factory=dict)
    process_time_s: float | None = None
    returncode: int | None = None
    reused: bool = False

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def value(self, key: str) -> Any:
        if key == "process_time_s":
            return self.process_time_s
        return self.summary.get(key)


def _tail(text: str, n: int = 400) -> str:
    text = " ".join(text.strip().split())
    return text if len(text) <= n else "..." + text[-n:]


def _error_line(output: str) -> str | None:
    lines = [ln.strip() for ln in output.splitlines() if ln.strip().startswith("error: ")]
    return lines[-1][len("error: "):] if lines else None


def run_command(scene: Path, sets: Sequence[str], out_dir: Path, np_ranks: int = 1,
                python: str = sys.executable) -> list[str]:
    """The command line of one run (a list for subprocess)."""
    cmd = [python, "-m", "fenics_plast.cli", "run", str(scene), "--out", str(out_dir)]
    for s in sets:
        cmd += ["--set", s]
    if np_ranks > 1:
        mpirun = shutil.which("mpirun") or "/usr/bin/mpirun"
        pre = [mpirun, "--allow-run-as-root", "-n", str(np_ranks)]
        if np_ranks > (os.cpu_count() or 1):
            pre.append("--oversubscribe")
        cmd = pre + cmd
    return cmd


def execute(run: Run, scene: Path, sets: list[str], run_dir: Path, np_ranks: int = 1,
            timeout: float | None = None, reuse: bool = False) -> Run:
    """Run one combination as a subprocess (or reuse a finished one) and fill ``run``."""
    record_path = run_dir / "study_run.json"
    cmd = run_command(scene, sets, run_dir, np_ranks)
    if reuse and record_path.is_file():
        try:
            rec = json.loads(record_path.read_text())
        except (OSError, json.JSONDecodeError):
            rec = None
        if rec and rec.get("sets") == sets and rec.get("np") == np_ranks and rec.get("status") in (
                "ok", "failed"):
            _fill(run, rec["returncode"], rec.get("output_tail", ""), rec.get("process_time_s"), run_dir)
            run.reused = True
            return run
    if run_dir.exists():
        shutil.rmtree(run_dir)
    run_dir.mkdir(parents=True)
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    t0 = time.perf_counter()
    with open(run_dir / "run.log", "w", encoding="utf-8") as log:
        proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=env, start_new_session=True)
        try:
            rc = proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            _kill(proc)
            rc = None
        except BaseException:            # Ctrl-C: do not leave the run behind
            _kill(proc)
            raise
    elapsed = time.perf_counter() - t0
    output = (run_dir / "run.log").read_text(encoding="utf-8", errors="replace")
    if rc is None:
        run.status, run.reason = "timeout", f"timed out after {timeout:g} s (--timeout)"
        run.process_time_s = elapsed
        if (run_dir / "summary.json").is_file():      # not expected: the run was killed
            (run_dir / "summary.json").unlink()
    else:
        _fill(run, rc, output, elapsed, run_dir)
    record = dict(sets=sets, np=np_ranks, command=cmd, returncode=rc, status=run.status, reason=run.reason,
                  process_time_s=elapsed, output_tail=output[-4000:])
    record_path.write_text(json.dumps(record, indent=1))
    return run


def _kill(proc: subprocess.Popen) -> None:
    """Stop the run's process group (its own session: only what this study started)."""
    for sig in (signal.SIGTERM, signal.SIGKILL):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            return
        try:
            proc.wait(timeout=10)
            return
        except subprocess.TimeoutExpired:
            continue


def _fill(run: Run, rc: int, output: str, elapsed: float | None, run_dir: Path) -> None:
    run.returncode, run.process_time_s = rc, elapsed
    summary_path = run_dir / "summary.json"
    if summary_path.is_file():
        try:
            run.summary = json.loads(summary_path.read_text())
        except (OSError, json.JSONDecodeError) as e:
            run.summary = {}
            run.status, run.reason = "failed", f"unreadable summary.json: {e}"
            return
    if rc == 0 and run.summary:
        run.status, run.reason = "ok", ""
        if not run.summary.get("converged", True):
            run.status, run.reason = "failed", "summary.json says converged: false"
    elif rc == 2:
        run.status = "invalid"
        run.reason = _error_line(output) or f"exit status 2: {_tail(output)}"
    else:
        run.status = "failed"
        if run.summary.get("error"):
            run.reason = str(run.summary["error"])
        elif rc is not None and rc < 0:
            run.reason = f"killed by signal {signal.Signals(-rc).name}: {_tail(output, 200)}"
        else:
            run.reason = _error_line(output) or f"exit status {rc}: {_tail(output)}"
            if rc == 0:
                run.reason = "exit status 0 but no summary.json"


def prevalidate(scene: Path, sets: list[str]) -> str | None:
    """The SceneError message of a combination, or None when it is a valid scene (no MPI, fast)."""
    from .scene import SceneError, load_scene
    try:
        load_scene(scene, sets)
    except SceneError as e:
        return str(e)
    return None


# ----------------------------------------------------------------------------------------------
# references and errors


@dataclass
class Richardson:
    """Result of a three-level extrapolation f(h) = f_ext + C h^p."""
    value: float | None
    order: float | None
    note: str = ""

    @property
    def ok(self) -> bool:
        return self.value is not None


def richardson(h: Sequence[float], f: Sequence[float], order_range=ORDER_RANGE) -> Richardson:
    """Extrapolate to h = 0 from three levels h[0] > h[1] > h[2] (coarse to fine) of f.

    Solves (h0^p - h1^p) / (h1^p - h2^p) = (f0 - f1) / (f1 - f2) for the observed order p
    (closed form ln(ratio)/ln(r) for a constant refinement ratio r, bisection otherwise), then
    f_ext = f2 - (f1 - f2) h2^p / (h1^p - h2^p). Returns value None with a note when the levels
    do not converge monotonically or p is outside ``order_range``.
    """
    h = [float(x) for x in h]
    f = [float(x) for x in f]
    if len(h) != 3 or len(f) != 3:
        raise ValueError("richardson needs three levels")
    if not (h[0] > h[1] > h[2] > 0):
        raise ValueError(f"richardson: mesh sizes must decrease, got {h}")
    if not all(math.isfinite(x) for x in f):
        return Richardson(None, None, "a value is not finite")
    d1, d2 = f[0] - f[1], f[1] - f[2]
    scale = max(abs(x) for x in f) or 1.0
    if abs(d2) <= 1e-14 * scale:
        return Richardson(None, None, "the two finest levels agree to round-off")
    if abs(d1) <= 1e-14 * scale or d1 / d2 <= 0:
        return Richardson(None, None, f"not monotone (differences {d1:+.3g}, {d2:+.3g})")
    ratio = d1 / d2
    r1, r2 = h[0] / h[1], h[1] / h[2]

    def g(p):
        return (h[0] ** p - h[1] ** p) / (h[1] ** p - h[2] ** p)

    if abs(r1 - r2) <= 1e-12 * r1:
        p = math.log(ratio) / math.log(r1)
    else:
        lo, hi = 1e-6, 60.0
        if not g(lo) < ratio < g(hi):
            return Richardson(None, None, f"the differences ({d1:+.3g}, {d2:+.3g}) shrink too slowly (or too "
                                          f"fast) for an order p in ({lo:g}, {hi:g})")
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if g(mid) < ratio else (lo, mid)
        p = 0.5 * (lo + hi)
    if not order_range[0] <= p <= order_range[1]:
        return Richardson(None, p, f"observed order {p:.3g} outside [{order_range[0]:g}, {order_range[1]:g}]")
    value = f[2] - d2 * h[2] ** p / (h[1] ** p - h[2] ** p)
    return Richardson(value, p)


@dataclass
class Reference:
    """What the runs of one group are compared with, per key result."""
    group: tuple
    runs: list[Run]
    values: dict[str, float | None] = field(default_factory=dict)
    orders: dict[str, float | None] = field(default_factory=dict)
    kind: dict[str, str] = field(default_factory=dict)          # per key: "finest run X" / "Richardson ..."
    notes: list[str] = field(default_factory=list)
    run: Run | None = None                                       # the reference run (None: none succeeded)


def _finite(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _fineness(run: Run, ordered: list[Vary]) -> tuple:
    """Sort key: rank of the run's value in each ordered key, coarse (0) to fine."""
    ranks = []
    for v in ordered:
        nums = sorted(v.values, key=lambda s: ORDERED_KEYS[v.key] * (as_number(s) or 0.0))
        ranks.append(nums.index(run.settings[v.key]))
    return tuple(ranks)


def ordered_varies(varies: Sequence[Vary]) -> list[Vary]:
    """The varied keys that order runs from coarse to fine (numeric values only)."""
    return [v for v in varies if v.key in ORDERED_KEYS and all(as_number(x) is not None for x in v.values)]


def references(runs: list[Run], varies: Sequence[Vary], keys: list[str]) -> list[Reference]:
    """One :class:`Reference` per group of categorical values (see the module docstring)."""
    ordered = ordered_varies(varies)
    okeys = {v.key for v in ordered}
    categorical = [v for v in varies if v.key not in okeys]
    if not ordered:
        ref = Reference(group=(), runs=list(runs))
        first = next((r for r in runs if r.ok), None)
        ref.run = first
        for k in keys:
            ref.values[k] = first.summary.get(k) if first is not None and _finite(first.summary.get(k)) else None
            ref.orders[k] = None
            ref.kind[k] = f"first run {first.name}" if first is not None else "none (no run succeeded)"
        if first is not None:
            ref.notes.append(f"no refinement key varied: every run is compared with the first run that "
                             f"succeeded, {first.name} ({first.label})")
        return [ref]
    groups: dict[tuple, list[Run]] = {}
    for r in runs:
        groups.setdefault(tuple(r.settings[v.key] for v in categorical), []).append(r)
    out = []
    for gkey, members in groups.items():
        ref = Reference(group=tuple(zip([v.key for v in categorical], gkey)), runs=members)
        ok = [r for r in members if r.ok]
        finest_combo = max(members, key=lambda r: sum(_fineness(r, ordered)))
        best = max(ok, key=lambda r: (sum(_fineness(r, ordered)), members.index(r)), default=None)
        ref.run = best
        if best is None:
            ref.notes.append("no run of this group succeeded")
        elif best is not finest_combo:
            ref.notes.append(f"the finest run {finest_combo.name} failed; reference is {best.name}")
        rich = _richardson_levels(members, ordered)
        if rich is not None and len(rich[1]) < 3:
            ref.notes.append(f"{rich[0]}: fewer than three successful levels, no Richardson extrapolation")
            rich = None
        for k in keys:
            ref.orders[k] = None
            ref.values[k] = best.summary.get(k) if best is not None and _finite(best.summary.get(k)) else None
            ref.kind[k] = f"finest run {best.name}" if best is not None else "none"
            if rich is None:
                continue
            rkey, levels = rich
            vals = [r.summary.get(k) for r in levels]
            if not all(_finite(x) for x in vals):
                ref.notes.append(f"{k}: a level has no value; error against the finest run")
                continue
            h = [RICHARDSON_KEYS[rkey](as_number(r.settings[rkey])) for r in levels]
            res = richardson(h, vals)
            names = ", ".join(r.name for r in levels)
            if res.ok:
                ref.values[k], ref.orders[k] = res.value, res.order
                ref.kind[k] = f"Richardson from {names} (p = {res.order:.2f})"
            else:
                ref.notes.append(f"{k}: no Richardson extrapolation from {names}: {res.note}; "
                                 f"error against the finest run")
        out.append(ref)
    return out


def _richardson_levels(members: list[Run], ordered: list[Vary]):
    """(key, the three finest successful levels of a Richardson key, coarse to fine), with the
    other ordered keys at their finest value; None when no Richardson key has >= 3 values."""
    for v in ordered:
        if v.key not in RICHARDSON_KEYS or len(v.values) < 3:
            continue
        others = [o for o in ordered if o is not v]
        finest_other = {o.key: max(o.values, key=lambda s: ORDERED_KEYS[o.key] * as_number(s)) for o in others}
        cand = [r for r in members if r.ok and all(r.settings[o] == val for o, val in finest_other.items())]
        cand.sort(key=lambda r: ORDERED_KEYS[v.key] * as_number(r.settings[v.key]))
        return v.key, cand[-3:]
    return None


def relative_error(value, ref) -> float | None:
    """(value - ref) / |ref| (fraction); None when either is missing; absolute error when ref is 0."""
    if not (_finite(value) and _finite(ref)):
        return None
    return (value - ref) / abs(ref) if ref != 0 else value - ref


# ----------------------------------------------------------------------------------------------
# the study


@dataclass
class Study:
    scene: Path
    kind: str
    scene_name: str
    varies: list[Vary]
    sets: list[str]
    keys: list[str]
    info: list[str]
    out: Path
    np_ranks: int = 1
    paper: dict[str, float] = field(default_factory=dict)
    runs: list[Run] = field(default_factory=list)
    refs: list[Reference] = field(default_factory=list)
    command: str = ""

    def ref_of(self, run: Run) -> Reference:
        for ref in self.refs:
            if run in ref.runs:
                return ref
        raise KeyError(run.name)

    # -- table rows ----------------------------------------------------------------------------
    def run_columns(self) -> list[str]:
        """Bookkeeping columns present in at least one run."""
        return [c for c in RUN_COLUMNS if any(r.value(c) is not None for r in self.runs)]

    def rows(self) -> tuple[list[str], list[dict[str, Any]]]:
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


def _csv_cell(v) -> Any:
    if v is None:
        return ""
    if isinstance(v, bool):
        return int(v)
    if isinstance(v, float):
        return repr(v)
    return v


def write_csv(study: Study, path: Path) -> Path:
    header, rows = study.rows()
    with open(path, "w", newline="", encoding="utf-8") as f:
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


def write_markdown(study: Study, path: Path, plot_name: str | None = "study.png") -> Path:
    header, rows = study.rows()
    cols = study.run_columns()
    L = [f"# Study of `{study.scene_name}` ({study.kind})", ""]
    L += ["```bash", study.command, "```", ""]
    L += [f"Scene file `{_display_path(study.scene)}`; {len(study.runs)} runs on {study.np_ranks} MPI rank(s); "
          f"{sum(r.ok for r in study.runs)} succeeded."]
    if study.sets:
        L += [f"Fixed overrides: {', '.join(f'`{s}`' for s in study.sets)}."]
    L += ["Wall time: the run's `wall_time_s` (scene loaded to summary written; process start-up, imports "
          "and the numba cache load are in `process_time_s`). Errors are signed, relative to the reference "
          "of the run's group (below).", ""]
    taken = set(cols + study.keys + study.info + ["run", "status"])
    head = (["run"] + [v.key if v.short in taken else v.short for v in study.varies] + ["status"] + cols
            + study.keys + study.info)
    L.append("| " + " | ".join(head) + " |")
    L.append("|" + "---|" * len(head))
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
    L += ["## References", ""]
    for ref in study.refs:
        g = ", ".join(f"{k} = {v}" for k, v in ref.group) or "all runs"
        L.append(f"* **{g}**:")
        for k in study.keys:
            L.append(f"  * `{k}`: {_fmt(ref.values.get(k), 6) or 'none'} ({ref.kind.get(k, '')})")
        for n in ref.notes:
            L.append(f"  * {n}")
    L.append("")
    paper = study.paper
    if paper:
        L += [f"## Against the {PAPER_LABEL.get(study.kind, 'published reference')}", ""]
        pk = [k for k in study.keys if k in paper]
        L.append("| run | " + " | ".join(pk) + " |")
        L.append("|---|" + "---|" * len(pk))
        for r, row in zip(study.runs, rows):
            if r.ok:
                L.append(f"| {r.name} | " + " | ".join(
                    f"{_fmt(row.get(k), 5)} ({_pct(row.get(f'err_paper_{k}'))})" for k in pk) + " |")
        L.append("")
    variants_only = not ordered_varies(study.varies)
    if not variants_only:
        L += ["## Cheapest run within a tolerance of the reference", ""]
    for ref in ([] if variants_only else study.refs):
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
    if not variants_only:
        L += ["", "(The reference run itself is left out when the reference is a run, not an extrapolation.)", ""]
    if plot_name:
        L += [f"![relative error against wall time]({plot_name})", ""]
    path.write_text("\n".join(L), encoding="utf-8")
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
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def study_command(scene: str, varies: Sequence[Vary], sets: Sequence[str], out: str | None, np_ranks: int,
                  results: str | None = None) -> str:
    parts = ["fenics-plast", "study", scene]
    for v in varies:
        parts += ["--vary", f"{v.key}={','.join(v.values)}"]
    for s in sets:
        parts += ["--set", s]
    if results:
        parts += ["--results", results]
    if np_ranks > 1:
        parts += ["--np", str(np_ranks)]
    if out:
        parts += ["--out", out]
    return " ".join(shlex.quote(p) for p in parts)


def scene_value(scene, dotted: str) -> Any:
    """Value of a dotted key in a validated scene (None when absent)."""
    obj = scene
    for part in dotted.split("."):
        try:
            obj = obj.get(part) if hasattr(obj, "get") and not hasattr(obj, "sections") else getattr(obj, part)
        except (AttributeError, KeyError):
            return None
        if obj is None:
            return None
    return obj


def _close(a, b) -> bool:
    return _finite(a) and math.isclose(float(a), float(b), rel_tol=1e-9)


def run_study(scene: str | Path, varies: Sequence[Vary], out: str | Path, sets: Iterable[str] = (),
              results: Sequence[str] | None = None, np_ranks: int = 1, timeout: float | None = None,
              reuse: bool = False, keep_outputs: bool = False, command: str | None = None,
              log: Callable[[str], None] = print) -> Study:
    """Run the study and write study.csv, study.md and study.png into ``out``. Raises StudyError
    (bad arguments: nothing run) when the scene or the fixed overrides are invalid."""
    from .scene import SceneError, load_scene

    scene = Path(scene).resolve()
    sets = list(sets)
    if not varies:
        raise StudyError("give at least one --vary KEY=V1,V2,...")
    keys_seen = [v.key for v in varies]
    if len(set(keys_seen)) != len(keys_seen):
        raise StudyError(f"a key is varied twice: {keys_seen}")
    if np_ranks < 1:
        raise StudyError("--np must be >= 1")
    try:
        base = load_scene(scene, sets)
    except SceneError as e:
        raise StudyError(str(e)) from None
    kind = base.kind
    if results:
        keys = list(results)
    elif kind in KEY_RESULTS:
        keys = list(KEY_RESULTS[kind])
    else:
        raise StudyError(f"no key results known for scene kind {kind!r}: pass --results k1,k2")
    info = [c for c in INFO_COLUMNS.get(kind, []) if c not in keys]
    paper = {}
    if kind in PAPER_REFERENCE and all(_close(scene_value(base, k), v)
                                       for k, v in PAPER_CONDITIONS.get(kind, {}).items()):
        paper = {k: v for k, v in PAPER_REFERENCE[kind].items() if k in keys}
    fixed = list(sets) if keep_outputs else ["output.xdmf=false", "output.plots=false", *sets]
    out = Path(out)
    (out / "runs").mkdir(parents=True, exist_ok=True)
    study = Study(scene=scene, kind=kind, scene_name=base.name, varies=list(varies), sets=sets, keys=keys,
                  info=info, out=out, np_ranks=np_ranks, paper=paper,
                  command=command or study_command(str(scene), varies, sets, str(out), np_ranks))
    combos = combinations(varies)
    for i, combo in enumerate(combos):
        run = Run(name=run_name(i, combo, varies), label=run_label(combo, varies), settings=combo)
        run_sets = fixed + [f"{k}={v}" for k, v in combo.items()]
        why = prevalidate(scene, run_sets)
        if why is not None:
            run.status, run.reason = "invalid", why
        else:
            log(f"study: run {i + 1}/{len(combos)} {run.label} ...")
            execute(run, scene, run_sets, out / "runs" / run.name, np_ranks=np_ranks, timeout=timeout,
                    reuse=reuse)
        t = run.value("wall_time_s")
        log(f"study: run {i + 1}/{len(combos)} {run.label}: {run.status}"
            + (" (reused)" if run.reused else "")
            + (f", {t:.2f} s" if t is not None else "") + (f": {run.reason}" if run.reason else ""))
        study.runs.append(run)
    study.refs = references(study.runs, varies, keys)
    write_csv(study, out / "study.csv")
    write_plot(study, out / "study.png")
    write_markdown(study, out / "study.md", "study.png")
    log(f"study: {sum(r.ok for r in study.runs)}/{len(study.runs)} runs succeeded; "
        f"{out / 'study.csv'}, {out / 'study.md'}, {out / 'study.png'}")
    return study


# ----------------------------------------------------------------------------------------------
# command line


def add_study_arguments(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """The ``study`` arguments (shared by ``fenics-plast study`` and ``python -m fenics_plast.study``)."""
    p.add_argument("scene", help="scene file (TOML)")
    p.add_argument("--vary", action="append", required=True, metavar="KEY=V1,V2,...",
                   help="a scene key and its values (repeatable: the study runs every combination), "
                        "e.g. --vary mesh.refine=1,2,4 --vary material.model=seed,isochoric")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="an override applied to every run (repeatable)")
    p.add_argument("--out", help="output directory (default results/study_<scene name>)")
    p.add_argument("--results", help="comma-separated summary.json keys to compare (default: the scene "
                                     "kind's key results)")
    p.add_argument("--np", type=int, default=1, help="MPI ranks per run (mpirun -n NP); default 1")
    p.add_argument("--timeout", type=float, help="wall-clock limit per run [s]; a run past it is a failed row")
    p.add_argument("--reuse", action="store_true",
                   help="reuse runs already in OUT/runs with the same overrides (resume a study)")
    p.add_argument("--keep-outputs", action="store_true",
                   help="keep each run's fields.xdmf and plots (off by default: output.xdmf=false, "
                        "output.plots=false)")
    return p


def study_from_args(args) -> int:
    """Run a study from parsed arguments; returns the exit status (0, 1 or 2)."""
    try:
        varies = [parse_vary(t) for t in args.vary]
        if args.out:
            out = args.out
        else:
            from .scene import SceneError, load_scene
            try:
                name = load_scene(args.scene, args.set).name
            except SceneError as e:
                raise StudyError(str(e)) from None
            out = str(Path("results") / f"study_{name}")
        results = [s.strip() for s in args.results.split(",") if s.strip()] if args.results else None
        cmd = study_command(args.scene, varies, args.set, out, args.np, args.results)
        study = run_study(args.scene, varies, out, args.set, results=results, np_ranks=args.np,
                          timeout=args.timeout, reuse=args.reuse, keep_outputs=args.keep_outputs, command=cmd)
    except StudyError as e:
        print(f"error: {e}", file=sys.stderr, flush=True)
        return 2
    return 0 if any(r.ok for r in study.runs) else 1


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m fenics_plast.study",
                                description="Run combinations of scene-key overrides and tabulate cost and error.")
    add_study_arguments(p)
    return study_from_args(p.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
