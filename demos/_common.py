"""Small helpers shared by the demos (not a demo itself): options, rank-0 output, plots.

Every demo accepts ``--coarse`` (or the environment variable ``FENICS_PLAST_DEMO_COARSE=1``) for a
run of a few seconds, and ``--out DIR`` (default ``results/demo_<name>/``, relative to the current
directory). Under ``mpirun`` only rank 0 prints and writes the PNG and JSON files; the XDMF file is
written collectively.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:          # lets a plain `python3 demos/<name>.py` find fenics_plast
    sys.path.insert(1, str(ROOT))

import numpy as np                      # noqa: E402
from mpi4py import MPI                  # noqa: E402

COMM = MPI.COMM_WORLD
COARSE_ENV = "FENICS_PLAST_DEMO_COARSE"


def options(name: str, doc: str, argv=None, extra=()):
    """Parse --coarse / --out (unknown arguments, e.g. a Jupyter kernel's, are ignored).

    ``extra``: (flags, keyword arguments) pairs of further ``add_argument`` calls.

    Returns the namespace with ``coarse`` (bool) and ``out`` (Path, created on rank 0).
    """
    ap = argparse.ArgumentParser(prog=f"demos/{name}.py", description=doc)
    ap.add_argument("--coarse", action="store_true",
                    help=f"coarse mesh and short loading: a few seconds (also: {COARSE_ENV}=1)")
    ap.add_argument("--out", type=Path, default=Path("results") / f"demo_{name}",
                    help=f"output folder (default results/demo_{name})")
    for flags, kw in extra:
        ap.add_argument(*flags, **kw)
    args, _ = ap.parse_known_args(argv)
    args.coarse = args.coarse or os.environ.get(COARSE_ENV, "") not in ("", "0")
    if COMM.rank == 0:
        args.out.mkdir(parents=True, exist_ok=True)
    COMM.barrier()
    return args


def say(*args, **kw):
    """print() on rank 0 only."""
    if COMM.rank == 0:
        print(*args, **kw, flush=True)


def write_summary(out: Path, results: dict):
    """summary.json (rank 0) with the demo's key numbers; every rank returns the dict."""
    results = dict(results, mpi_ranks=COMM.size)
    if COMM.rank == 0:
        (out / "summary.json").write_text(json.dumps(results, indent=2) + "\n")
    return results


def gather_cells(V, u_values, cell_values):
    """Deformed quadrilaterals of the owned cells, gathered on rank 0.

    V: the CG1 vector space (2 components); u_values: its dof array (owned + ghost, (n*2,));
    cell_values: one value per owned cell. Returns (polygons (m,4,2), values (m,)) on rank 0 and
    (None, None) elsewhere.
    """
    n_cells = V.mesh.topology.index_map(2).size_local
    x = V.tabulate_dof_coordinates()[:, :2] + np.asarray(u_values).reshape(-1, 2)
    from fenics_plast import dolfinx_compat as dc
    from fenics_plast.solvers.quad_step import QUAD_CYCLE      # basix's vertices in cyclic order
    cells = dc.cell_dofs(V)[:n_cells][:, QUAD_CYCLE]
    parts = COMM.gather((x[cells], np.asarray(cell_values)[:n_cells]), root=0)
    if COMM.rank != 0:
        return None, None
    return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


def figure(ncols=1, width=5.0, height=4.2):
    """A matplotlib Figure (Agg, no display needed) and its axes."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width * ncols, height))
    FigureCanvasAgg(fig)
    axes = [fig.add_subplot(1, ncols, k + 1) for k in range(ncols)]
    return fig, axes


def draw_cells(ax, polygons, values, label, mirror=True, cmap="viridis"):
    """Filled quads coloured by ``values``; ``mirror`` adds the r < 0 half (axisymmetric section)."""
    from matplotlib.collections import PolyCollection

    polys, vals = polygons, values
    if mirror:
        flipped = polygons * np.array([-1.0, 1.0])
        polys, vals = np.concatenate([polygons, flipped]), np.concatenate([values, values])
    pc = PolyCollection(polys, array=vals, cmap=cmap, edgecolors="k", linewidths=0.2)
    ax.add_collection(pc)
    ax.autoscale_view()
    ax.set_aspect("equal")
    ax.figure.colorbar(pc, ax=ax, label=label, shrink=0.8)
    return pc
