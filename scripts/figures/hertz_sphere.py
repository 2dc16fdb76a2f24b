"""Hertz contact of an elastic hemisphere on an elastic cylinder (demos/hertz_sphere.toml, static, contact
between two bodies) at 10, 20 and 40 cells per mm near the contact -> docs/figures/hertz_sphere.png: the
nodal contact pressures of the ball against Hertz's p0 sqrt(1 - r^2 / a^2) for the force each run transmits,
and the table of the contact radius and peak pressure (fitted to the nodal pressures, as
tests/test_static_body_contact.py does) against Hertz's. In process, serial; about a minute.

    .venv/bin/python scripts/figures/hertz_sphere.py
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))
FIGURE = ROOT / "docs" / "figures" / "hertz_sphere.png"


def main():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from test_static_body_contact import hertz_errors, run_static
    fig, ax = plt.subplots(figsize=(7, 4.5))
    print("| cells per mm at the contact | cell size mm | dofs | contact force N | a mm (Hertz) | a error | "
          "p0 MPa (Hertz) | p0 error | Newton iterations | solve s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for nc, mark in ((10, "s"), (20, "^"), (40, "o")):
        t0 = time.perf_counter()
        b = run_static("hertz_sphere.toml", f"mesh.parameters.cells_contact={nc}")
        dt = time.perf_counter() - t0
        a, p0, a_h, p0_h = hertz_errors(b)
        x, p = b.pairs["hertz"].pressures()
        force = abs(b.pairs["hertz"].force()[1])
        keep = x[:, 0] < 1.5 * a_h
        ax.plot(x[keep, 0], p[keep], mark, ms=4, label=f"{nc} cells/mm ({1 / nc:.3g} mm)")
        s = b.solver
        print(f"| {nc} | {1 / nc:.3g} | {s.dofs} | {force:.0f} | {a:.4f} ({a_h:.4f}) | {100 * (a / a_h - 1):+.2f} % "
              f"| {p0:.0f} ({p0_h:.0f}) | {100 * (p0 / p0_h - 1):+.2f} % | {s.total_iterations} | {dt:.1f} |",
              flush=True)
    r = np.linspace(0.0, a_h, 200)
    ax.plot(r, p0_h * np.sqrt(1.0 - (r / a_h) ** 2), "k-", label=f"Hertz (F = {force:.0f} N)")
    ax.set_xlabel("r [mm]")
    ax.set_ylabel("contact pressure [MPa]")
    ax.set_title("Hertz: sphere R = 10 mm on a cylinder, both elastic: the ball's nodal pressures")
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(FIGURE, dpi=110)
    print(f"wrote {FIGURE}")


if __name__ == "__main__":
    main()
