"""Helper of tests/test_checkpoint.py: the checkpoint fingerprint of a few shipped meshes, serially or
on every rank of an ``mpirun`` (it must not depend on the partition).

    python tests/mpi_mesh_fingerprint.py OUT.npz

Writes (rank 0) OUT.npz with ``names`` and ``digests`` (fenics_plast.checkpoint.mesh_fingerprint of
meshes/round_bar.geo and meshes/ring.geo, 2-D, and meshes/round_bar_quarter.geo, 3-D hexahedra),
``same_on_all_ranks`` (1 when every rank got the same digests) and ``ranks``.
"""
import sys
from pathlib import Path

import numpy as np
from mpi4py import MPI

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from fenics_plast.checkpoint import mesh_fingerprint  # noqa: E402
from fenics_plast.meshing import mesh_from_file  # noqa: E402

CASES = [("round_bar", {"cells_radial": 3, "cells_axial": 7}, 2),
         ("ring", {"cells_radial": 4, "cells_circumferential": 9}, 2),
         ("round_bar_quarter", {}, 3)]


def main(path):
    comm = MPI.COMM_WORLD
    digests = []
    for name, params, gdim in CASES:
        mesh = mesh_from_file(comm, ROOT / "meshes" / f"{name}.geo", params, gdim=gdim)[0]
        digests.append(mesh_fingerprint(mesh))
    same = all(d == digests for d in comm.allgather(digests))
    if comm.rank == 0:
        np.savez(path, names=np.array([c[0] for c in CASES]), digests=np.array(digests),
                 same_on_all_ranks=int(same), ranks=comm.size)


if __name__ == "__main__":
    main(sys.argv[1])
