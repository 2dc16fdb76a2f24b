"""Benchmark: hemispherical punch stretching, mu = 0 to 40 mm on the default mesh (target <= 10 s).

Prints wall time, increments and Newton iterations next to the seed's numbers (CONVEX C-1):
mu = 0 to 40 mm: 57 increments, 136 iterations; mu = 0.15: 130 / 214; mu = 0.3 to 58 mm: 260 / 365.
`--all` also runs mu = 0.15 and 0.3. The JIT cache is warmed by a first (untimed) short run.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SEED = {0.0: (57, 136, "40 mm"), 0.15: (130, 214, "40 mm"), 0.3: (260, 365, "58 mm")}


def run(mu, out, travel=None):
    cmd = [sys.executable, "-m", "fenics_plast.cli", "run", str(ROOT / "demos/punch_stretching.toml"),
           "--out", str(out), "--set", f"contact.punch.friction={mu}", "--set", f"contact.die.friction={mu}",
           "--set", "output.xdmf=false", "--set", "output.plots=false"]
    if travel:                          # the punch rises linearly to `travel` mm over the load factor 0 -> 1
        cmd += ["--set", f"tools.punch.path.y=[0.0, {travel}]"]
    subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, env=dict(os.environ))
    return json.loads((Path(out) / "summary.json").read_text())


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--all", action="store_true")
    a = ap.parse_args()
    mus = (0.0, 0.15, 0.3) if a.all else (0.0,)
    with tempfile.TemporaryDirectory() as tmp:
        run(0.15, Path(tmp) / "warm", travel=2.0)      # JIT warm-up
        print(f"{'mu':>5} {'travel':>7} {'incr':>5} {'newton':>7} {'wall [s]':>9} {'F_max [kN]':>11}"
              f"   seed: incr / newton")
        worst = 0.0
        for mu in mus:
            s = run(mu, Path(tmp) / f"mu{mu}")
            si, sn, st = SEED[mu]
            print(f"{mu:5.2f} {s['punch_displacement_mm']:7.2f} {s['increments']:5d} "
                  f"{s['newton_iterations']:7d} {s['wall_time_s']:9.2f} {s['max_punch_force_kN']:11.3f}"
                  f"   {si} / {sn} (to {st})", flush=True)
            if mu == 0.0:
                worst = s["wall_time_s"]
        print(f"mu = 0 to 40 mm: {worst:.2f} s (target <= 10 s): {'OK' if worst <= 10 else 'SLOW'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
