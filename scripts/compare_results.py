#!/usr/bin/env python3
"""Compare two trees of results folders scene by scene: key results side by side, relative differences.

    python3 scripts/compare_results.py A B [--labels "Debian 12" "Debian 13"] [--out FILE.md]

A and B each hold results folders (``<A>/<scene>/summary.json``, what ``make demo`` or
``scripts/platform_runs.sh`` leave); every scene found in both is compared. Printed per scene (a
markdown table): each key and info result of the scene's outputs, and the increments or steps and Newton
iterations, in A and in B, with the relative difference |B - A| / |A| (absolute where A is 0), and
the wall times. Standard library only. Exit 2 if a folder holds no results.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

COUNTS = ("increments", "steps", "newton_iterations", "cutbacks")


def summaries(tree: Path) -> dict[str, dict]:
    out = {}
    for f in sorted(tree.glob("*/summary.json")):
        try:
            out[f.parent.name] = json.loads(f.read_text())
        except (OSError, ValueError) as e:
            print(f"compare_results: skipping {f}: {e}", file=sys.stderr)
    return out


def number(v):
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    return float(v)


def difference(a: float, b: float) -> str:
    if not (math.isfinite(a) and math.isfinite(b)):
        return "n/a"
    if a == b:
        return "0"
    d = abs(b - a) / abs(a) if a != 0.0 else abs(b - a)
    return f"{d:.1e}" + ("" if a != 0.0 else " (abs)")


def compare(name: str, a: dict, b: dict, labels) -> list[str]:
    keys = list(dict.fromkeys([*a.get("key_results", []), *a.get("info_results", [])]))
    keys += [k for k in COUNTS if k in a or k in b]
    lines = [f"### {name}", "", f"| quantity | {labels[0]} | {labels[1]} | rel. difference |", "|---|---|---|---|"]
    for k in keys:
        va, vb = number(a.get(k)), number(b.get(k))
        if va is None or vb is None:
            if a.get(k) != b.get(k):
                lines.append(f"| {k} | {a.get(k)} | {b.get(k)} | differs |")
            continue
        fmt = "{:.0f}" if va.is_integer() and vb.is_integer() and abs(va) < 1e9 else "{:.9g}"
        lines.append(f"| {k} | {fmt.format(va)} | {fmt.format(vb)} | {difference(va, vb)} |")
    for k in ("converged", "wall_time_s", "step_loop_time_s"):
        if k in a or k in b:
            va, vb = a.get(k), b.get(k)
            if isinstance(va, float) and isinstance(vb, float):
                va, vb = f"{va:.2f}", f"{vb:.2f}"
            lines.append(f"| {k} | {va} | {vb} | |")
    return lines + [""]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("a", type=Path)
    ap.add_argument("b", type=Path)
    ap.add_argument("--labels", nargs=2, default=None, metavar=("LABEL_A", "LABEL_B"))
    ap.add_argument("--out", type=Path, default=None, help="also write the tables to this markdown file")
    args = ap.parse_args(argv)
    labels = args.labels or [str(args.a), str(args.b)]
    sa, sb = summaries(args.a), summaries(args.b)
    for tree, s in ((args.a, sa), (args.b, sb)):
        if not s:
            print(f"compare_results: {tree} holds no results folders (<scene>/summary.json)", file=sys.stderr)
            return 2
    lines = []
    for name in sorted(set(sa) & set(sb)):
        lines += compare(name, sa[name], sb[name], labels)
    only = sorted(set(sa) ^ set(sb))
    if only:
        lines.append("Only in one tree: " + ", ".join(only))
    text = "\n".join(lines)
    print(text)
    if args.out:
        args.out.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
