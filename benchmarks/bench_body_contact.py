"""Cost of a master surface of the body as it grows: per explicit step, moving and refitting the surface
(with its reduction over the ranks), the search of the slave nodes and the reactions, for two stacked blocks
whose facing faces have n x n and (n + 1) x (n + 1) non-matching hexahedral faces (4 n^2 triangles on the
master side: each quadrilateral four triangles about its centre), serially or under mpirun (rank 0 prints;
each rank searches its own slave nodes against the whole master surface, gathered on every rank).

    python benchmarks/bench_body_contact.py                    # n = 16, 32, 64, 128
    mpirun -n 2 python benchmarks/bench_body_contact.py 32 64 128

Prints per n: master triangles, slave nodes (all ranks, and the most on one rank), set-up [s], and per call
[ms]: move (gather and
refit), nearest (the slave nodes' search), reactions (spread and reduce), as medians of 20 calls at a
displaced state. The explicit solver calls each once per step and pair; compare with its force pass
(~0.5 us per cell and step in 2-D, ~2 us in 3-D, one core).

Measured (2-core machine, one invocation each; per call [ms]):

      n  triangles  slaves (one rank)   move    nearest  reactions      move   nearest  reactions
                                        ---- 1 rank ----------------    ---- 2 ranks -------------
     16      1,024      324   (324)     0.16     0.15     0.02
     32      4,096    1,156 (1,146)     0.58     0.61     0.07          0.60     0.61     0.08
     64     16,384    4,356 (4,356)     2.42     2.79     0.27          2.34     2.69     0.27
    128     65,536   16,900 (16,900)    9.94    12.72     1.07         10.59    12.59     1.22

Moving and refitting the gathered surface costs about 0.15 us per triangle on every rank whatever the
ranks (it is not divided among them), the search about 0.75 us per slave node of the busiest rank (here
the partition put the upper block, all slave nodes, on one rank: no gain from the second), the reactions'
reduction 0.06 us per vertex. At 65,536 master triangles (16,384 quadrilaterals) and 16,900 slave nodes a
step's contact costs ~24 ms, against some 130 ms for the force pass of the two blocks' 66,000 hexahedra
(estimated at 2 us each, not measured here): gathering the master whole suits interfaces up to some 10^5
quadrilaterals; beyond, or with many ranks, the surface would have to be split by rank (not built). With two
triangles a quadrilateral (before the faces were split about their centres) the same case cost ~25 ms.
"""
from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

GEO = """Geometry.AutoCoherence = 0;
Point(1) = {{0, 0, 0}}; Point(2) = {{1, 0, 0}}; Point(3) = {{1, 1, 0}}; Point(4) = {{0, 1, 0}};
Line(1) = {{1, 2}}; Line(2) = {{2, 3}}; Line(3) = {{3, 4}}; Line(4) = {{4, 1}};
Curve Loop(1) = {{1, 2, 3, 4}}; Plane Surface(1) = {{1}};
Transfinite Curve{{1, 2, 3, 4}} = {n1}; Transfinite Surface{{1}}; Recombine Surface{{1}};
low[] = Extrude {{0, 0, 0.2}} {{ Surface{{1}}; Layers{{2}}; Recombine; }};
Point(101) = {{0, 0, 0.2}}; Point(102) = {{1, 0, 0.2}}; Point(103) = {{1, 1, 0.2}}; Point(104) = {{0, 1, 0.2}};
Line(101) = {{101, 102}}; Line(102) = {{102, 103}}; Line(103) = {{103, 104}}; Line(104) = {{104, 101}};
Curve Loop(101) = {{101, 102, 103, 104}}; Plane Surface(101) = {{101}};
Transfinite Curve{{101, 102, 103, 104}} = {n2}; Transfinite Surface{{101}}; Recombine Surface{{101}};
up[] = Extrude {{0, 0, 0.2}} {{ Surface{{101}}; Layers{{2}}; Recombine; }};
Physical Volume("lower", 1) = {{low[1]}};
Physical Volume("upper", 2) = {{up[1]}};
Physical Surface("lower_top", 11) = {{low[0]}};
Physical Surface("upper_bottom", 12) = {{101}};
"""


def one(n, comm, folder):
    from dolfinx import fem

    from fenics_plast import dolfinx_compat as dc
    from fenics_plast.meshing import mesh_from_file
    from fenics_plast.solvers.body_surface import BodySurface
    geo = Path(folder) / f"blocks_{n}.geo"
    if comm.rank == 0:
        geo.write_text(GEO.format(n1=n + 1, n2=n + 2))
    comm.barrier()
    mesh, _, ft, groups = mesh_from_file(comm, geo, {}, 1, gdim=3)
    V = dc.vector_space(mesh)
    X = V.tabulate_dof_coordinates()[:, :3]
    t0 = time.perf_counter()
    surface = BodySurface(V, X, ft, groups["lower_top"][1])
    setup = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    # the slave nodes: the owned nodes of the upper block's face, pressed 1e-3 into the lower block
    n_own = V.dofmap.index_map.size_local
    blocks = fem.locate_dofs_topological(V, 2, ft.find(groups["upper_bottom"][1]))
    blocks = np.asarray(blocks[blocks < n_own], dtype=np.int64)
    rng = np.random.default_rng(comm.rank)
    u = np.zeros(V.dofmap.index_map.size_local * 3 + V.dofmap.index_map.num_ghosts * 3)
    u[2::3] = 1e-4 * rng.standard_normal(len(u) // 3)
    du = np.zeros(n_own * 3)
    x = X[blocks] + u.reshape(-1, 3)[blocks] - [0.0, 0.0, 1e-3]
    skip = np.full(len(blocks), -1, dtype=np.int64)
    m = len(blocks)
    g, N, facet, w = np.empty(m), np.empty((m, 3)), np.empty(m, np.int64), np.empty((m, 3))
    fcon = np.zeros(n_own * 3)
    times = {"move": [], "nearest": [], "reactions": []}
    for _ in range(21):
        comm.barrier()
        t0 = time.perf_counter()
        surface.move(u, du)
        t1 = time.perf_counter()
        surface.nearest(x, skip, g, N, facet, w)
        t2 = time.perf_counter()
        comm.barrier()                  # the reduction of the reactions waits for the slowest search: not its cost
        t2b = time.perf_counter()
        surface.add_reactions(facet, w, 1e-3 * N, fcon)
        t3 = time.perf_counter()
        for k, v in zip(times, (t1 - t0, t2 - t1, t3 - t2b)):
            times[k].append(v)
    touching = comm.allreduce(int((facet >= 0).sum()), op=MPI.SUM)
    slaves = comm.allreduce(m, op=MPI.SUM)
    most = comm.allreduce(m, op=MPI.MAX)
    med = {k: comm.allreduce(1e3 * float(np.median(v[1:])), op=MPI.MAX) for k, v in times.items()}
    if comm.rank == 0:
        print(f"{n:5d} {len(surface.surface.facets):9d} {slaves:8d} {most:9d} {touching:9d} {setup:8.2f} "
              f"{med['move']:9.3f} {med['nearest']:9.3f} {med['reactions']:10.3f}", flush=True)


def main():
    comm = MPI.COMM_WORLD
    sizes = [int(a) for a in sys.argv[1:]] or [16, 32, 64, 128]
    if comm.rank == 0:
        print(f"master surface of the body, {comm.size} rank(s); per call [ms], medians of 20 (the slowest rank)")
        print("    n triangles   slaves  one rank  in reach  setup s   move ms nearest ms reactions ms")
    with tempfile.TemporaryDirectory() as folder:
        folder = comm.bcast(folder, root=0)
        for n in sizes:
            one(n, comm, folder)


if __name__ == "__main__":
    main()
