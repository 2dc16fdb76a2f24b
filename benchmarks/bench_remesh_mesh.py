"""Remeshing benchmark, the mesh part (issue 35): outline + new Gmsh mesh of a deformed round bar.

    python benchmarks/bench_remesh_mesh.py [--cells 1000 10000] [--runs 3] [--curves lines]
    mpirun -n 2 python benchmarks/bench_remesh_mesh.py

meshes/round_bar.geo (R 6.413, L 26.667 mm) is meshed with about N structured cells (1 : 4 radial to
axial), bent smoothly (r (1 + 0.3 sin(pi z / L)), z + 0.1 r^2 / R) and remeshed at the size that gives
about N cells again. Printed per N: the median over --runs of the quality check
(:func:`fenics_plast.remeshing.quality.mesh_quality`), the outline
(:func:`fenics_plast.remeshing.outline.outline`, gather included), Gmsh (geometry, meshing,
``model_to_mesh`` not included) and the distribution (``model_to_mesh``), and the new mesh's cells and
minimum scaled Jacobian. A benchmark: it asserts nothing.
"""
from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path

import gmsh
import numpy as np
from dolfinx.io import gmshio
from mpi4py import MPI

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from fenics_plast.gmsh_session import gmsh_session  # noqa: E402
from fenics_plast.remeshing.new_mesh import mesh_outline  # noqa: E402
from fenics_plast.remeshing.outline import outline  # noqa: E402
from fenics_plast.remeshing.quality import mesh_quality  # noqa: E402

R, L = 6.413, 26.667


def bar(comm, cells):
    """The round bar with about ``cells`` cells (nr x 4 nr), and its groups."""
    nr = max(2, round(math.sqrt(cells / 4)))
    with gmsh_session():
        groups = {}
        if comm.rank == 0:
            for k, v in {"cells_radial": nr, "cells_axial": 4 * nr}.items():
                gmsh.onelab.setNumber(f"Parameters/{k}", [float(v)])
            gmsh.open(str(ROOT / "meshes" / "round_bar.geo"))
            gmsh.model.geo.synchronize()
            gmsh.model.mesh.generate(2)
            groups = {gmsh.model.getPhysicalName(d, t): (d, t) for d, t in gmsh.model.getPhysicalGroups()}
        else:
            gmsh.model.add("bar")
        groups = comm.bcast(groups, root=0)
        mesh, ct, ft = gmshio.model_to_mesh(gmsh.model, comm, 0, gdim=2)
    return mesh, ct, ft, groups


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells", type=int, nargs="+", default=[1000, 10000])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--curves", choices=("lines", "splines"), default="lines")
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    if comm.rank == 0:
        print(f"bench_remesh_mesh: {comm.size} rank(s), curves = {args.curves}, median of {args.runs} runs [s]")
        print(f"{'old cells':>10} {'new cells':>10} {'h [mm]':>8} {'quality':>8} {'outline':>8} {'gmsh':>8} "
              f"{'distrib.':>8} {'total':>8} {'min SJ':>7}")
    for n in args.cells:
        mesh, ct, ft, groups = bar(comm, n)
        X = mesh.geometry.x
        x = X.copy()
        x[:, 0] = X[:, 0] * (1 + 0.3 * np.sin(np.pi * X[:, 1] / L))
        x[:, 1] = X[:, 1] + 0.1 * X[:, 0] ** 2 / R
        old_cells = comm.allreduce(mesh.topology.index_map(2).size_local)
        h = math.sqrt(1.15 * R * L / old_cells)           # (the bulged bar is ~15 % larger)
        times = {k: [] for k in ("quality", "outline", "gmsh", "distribute")}
        for _ in range(args.runs):
            comm.Barrier()
            t0 = time.perf_counter()
            mesh_quality(mesh, x)
            t1 = time.perf_counter()
            out = outline(mesh, ct, ft, groups, x=x)
            t2 = time.perf_counter()
            new = mesh_outline(comm, out, h, curves=args.curves)
            times["quality"].append(t1 - t0)
            times["outline"].append(t2 - t1)
            times["gmsh"].append(new.info["gmsh_s"])
            times["distribute"].append(new.info["distribute_s"])
        med = {k: statistics.median(v) for k, v in times.items()}
        sj = mesh_quality(new[0]).min_scaled_jacobian
        if comm.rank == 0:
            total = med["outline"] + med["gmsh"] + med["distribute"]
            print(f"{old_cells:>10d} {new.info['cells']:>10d} {h:>8.3f} {med['quality']:>8.4f} {med['outline']:>8.4f} "
                  f"{med['gmsh']:>8.3f} {med['distribute']:>8.3f} {total:>8.3f} {sj:>7.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
