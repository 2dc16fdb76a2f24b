"""Platform benchmark: the default Taylor bar's step loop and the static punch, medians of N runs.

    python benchmarks/bench_platform.py [--runs 3] [--json FILE]

Runs ``fenics-plast run`` (this interpreter) on demos/taylor_bar.toml and demos/punch_stretching.toml
as shipped, each once untimed first (JIT and numba caches) and then --runs times, and prints the
platform (Debian release, dolfinx, PETSc, MUMPS's petsc4py, numba, numpy) with, per scene, the median
and range of: the explicit step loop (summary ``step_loop_time_s``), the run's wall time (summary
``wall_time_s``: mesh to results) and the process time (imports included), and the scene's key results.
Run it on Debian 12 and on Debian 13 one after the other on the same machine to compare the two
platforms (docs/PLATFORMS.md). A benchmark: it asserts nothing.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SCENES = ("taylor_bar", "punch_stretching")


def platform() -> dict:
    import dolfinx
    import numba
    import numpy
    import petsc4py
    release = "unknown"
    try:
        for line in Path("/etc/os-release").read_text().splitlines():
            if line.startswith("PRETTY_NAME="):
                release = line.split("=", 1)[1].strip('"')
    except OSError:
        pass
    return dict(release=release, python=sys.version.split()[0], dolfinx=dolfinx.__version__,
                petsc4py=petsc4py.__version__, numba=numba.__version__, numpy=numpy.__version__)


def run(scene: str, out: Path) -> tuple[dict, float]:
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "fenics_plast.cli", "run", str(ROOT / "demos" / f"{scene}.toml"),
                        "--out", str(out)], cwd=ROOT, capture_output=True, text=True,
                       env={**os.environ, "FENICS_PLAST_PROGRESS": "off"})
    process = time.perf_counter() - t0
    if p.returncode != 0:
        raise SystemExit(f"bench_platform: {scene} failed (exit {p.returncode}):\n{p.stderr[-2000:]}")
    return json.loads((out / "summary.json").read_text()), process


def spread(values) -> dict:
    return dict(median=statistics.median(values), min=min(values), max=max(values))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--json", default=None, help="write the figures to this file")
    a = ap.parse_args(argv)
    figures = dict(platform=platform(), runs=a.runs, scenes={})
    print("platform: " + ", ".join(f"{k} {v}" for k, v in figures["platform"].items()), flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        for scene in SCENES:
            run(scene, Path(tmp) / f"{scene}_warm")
            summaries, process = [], []
            for i in range(a.runs):
                s, t = run(scene, Path(tmp) / f"{scene}_{i}")
                summaries.append(s)
                process.append(t)
            last = summaries[-1]
            fig = dict(wall_time_s=spread([s["wall_time_s"] for s in summaries]), process_time_s=spread(process),
                       key_results={k: last.get(k) for k in last.get("key_results", [])})
            if "step_loop_time_s" in last:
                fig["step_loop_time_s"] = spread([s["step_loop_time_s"] for s in summaries])
            figures["scenes"][scene] = fig
            timed = [k for k in ("step_loop_time_s", "wall_time_s", "process_time_s") if k in fig]
            print(f"{scene}: " + "; ".join(
                f"{k} {fig[k]['median']:.3f} ({fig[k]['min']:.3f}-{fig[k]['max']:.3f})" for k in timed)
                + f" [median of {a.runs}]", flush=True)
            print("  " + ", ".join(f"{k} {v:.9g}" for k, v in fig["key_results"].items()
                                   if isinstance(v, (int, float))), flush=True)
    if a.json:
        Path(a.json).write_text(json.dumps(figures, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
