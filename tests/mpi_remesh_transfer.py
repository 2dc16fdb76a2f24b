"""Helper of tests/test_remesh_transfer.py: the meshes and fields of the transfer tests, and a driver
that transfers them serially or on every rank of an ``mpirun`` (the result must not depend on the
partition of either mesh).

    python tests/mpi_remesh_transfer.py OUT.npz [N]

Old mesh: :func:`structured` (2N x N cells on the W x H rectangle, interior nodes moved smoothly);
new mesh: :func:`unstructured` (Gmsh, Blossom full-quad, size H / N). Writes (rank 0) OUT.npz with
the transferred state (``eqps``, ``binv``, ``temperature``), a P0 field (``cells``) and a CG1
vector field (``nodal``), each ordered by its partition-independent key (quadrature point, cell,
node: fenics_plast.checkpoint's keys), and ``ranks``.
"""
from __future__ import annotations

import sys
from pathlib import Path

import gmsh
import numpy as np
from mpi4py import MPI

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from fenics_plast import checkpoint as ck  # noqa: E402
from fenics_plast import dolfinx_compat as dc  # noqa: E402
from fenics_plast.gmsh_session import gmsh_session  # noqa: E402
from fenics_plast.remeshing import transfer as tr  # noqa: E402

W, H = 2.0, 1.0        # the rectangle [mm]


def structured(comm, n, distortion=0.3):
    """2n x n quadrilaterals on [0, W] x [0, H], interior nodes moved by up to ``distortion`` cells
    (smooth sine bumps; the boundary stays straight): non-affine cells."""
    import dolfinx.mesh as dmesh
    mesh = dmesh.create_rectangle(comm, [np.array([0.0, 0.0]), np.array([W, H])], [2 * n, n],
                                  cell_type=dmesh.CellType.quadrilateral)
    x = mesh.geometry.x
    bump = np.sin(np.pi * x[:, 0] / W) * np.sin(np.pi * x[:, 1] / H)
    x[:, 0] += distortion * (W / (2 * n)) * bump
    x[:, 1] += distortion * (H / n) * np.sin(2 * np.pi * x[:, 0] / W) * np.sin(np.pi * x[:, 1] / H)
    return mesh


def unstructured(comm, h, width=W, height=H):
    """Gmsh quadrilaterals of size h on [0, width] x [0, height] (Frontal-Delaunay + Blossom full-quad:
    Gmsh 4.8's Frontal-Delaunay for quads segfaults)."""
    from dolfinx.io import gmshio
    with gmsh_session():
        if comm.rank == 0:
            gmsh.model.add("rectangle")
            gmsh.model.occ.addRectangle(0, 0, 0, width, height)
            gmsh.model.occ.synchronize()
            gmsh.model.addPhysicalGroup(2, [1], 1)
            for option, value in (("Mesh.MeshSizeMax", h), ("Mesh.MeshSizeMin", h), ("Mesh.Algorithm", 6),
                                  ("Mesh.RecombineAll", 1), ("Mesh.RecombinationAlgorithm", 3)):
                gmsh.option.setNumber(option, value)
            gmsh.model.mesh.generate(2)
        return gmshio.model_to_mesh(gmsh.model, comm, 0, gdim=2)[0]


# -- analytic fields ---------------------------------------------------------------------------------------
def eqps(x, y):
    """A smooth positive field (dimensionless)."""
    return 0.3 + 0.2 * np.sin(1.3 * x) * np.cos(2.1 * y) + 0.05 * x * y


def log_binv(x, y):
    """A smooth symmetric (n, 3, 3) field, the logarithm of b_e^-1 (plane: no xz, yz)."""
    L = np.zeros((len(x), 3, 3))
    L[:, 0, 0] = 0.02 * np.sin(x + y)
    L[:, 1, 1] = -0.015 * np.cos(1.5 * x) + 0.01 * y
    L[:, 2, 2] = -(L[:, 0, 0] + L[:, 1, 1]) + 0.003 * np.sin(2 * y)
    L[:, 0, 1] = L[:, 1, 0] = 0.01 * np.sin(2 * x) * np.cos(y)
    return L


def temperature(x, y):
    """A smooth temperature [K]."""
    return 293.15 + 40.0 * np.exp(-((x - 1.0) ** 2 + (y - 0.5) ** 2))


def state_at(points):
    """The analytic state at points (n, 2): {name: (n,) + shape}."""
    x, y = points[:, 0], points[:, 1]
    return {"binv": tr.spd_exp(log_binv(x, y)), "eqps": eqps(x, y), "temperature": temperature(x, y)}


def velocity(x, y):
    """A smooth vector field (n, 2) [mm/s]."""
    return np.stack([np.sin(x) * y, np.cos(y) + x * x], axis=1)


# -- the driver ---------------------------------------------------------------------------------------
def _by_key(comm, keys, rows):
    """rows of every rank, ordered by key (rank 0; None elsewhere)."""
    parts = comm.gather((np.asarray(keys), np.asarray(rows)), root=0)
    if comm.rank:
        return None
    k = np.concatenate([p[0] for p in parts])
    order = np.argsort(k, kind="stable")
    assert len(np.unique(k)) == len(k)
    return np.concatenate([p[1] for p in parts])[order]


def main(path, n=8):
    comm = MPI.COMM_WORLD
    old, new = structured(comm, n), unstructured(comm, H / n)
    transfer = tr.StateTransfer(old, degree=2)
    state, report = transfer.quadrature_state(state_at(tr.quadrature_points(old, 2)), new)
    n_new = new.topology.index_map(2).size_local
    keys = ck.qp_keys(new, n_new, transfer.nq)
    out = {name: _by_key(comm, keys, values) for name, values in state.items()}

    n_old = old.topology.index_map(2).size_local
    centres = tr.cell_corners(old).mean(axis=1)
    cells = transfer.cell_values(eqps(centres[:, 0], centres[:, 1]), new)
    out["cells"] = _by_key(comm, ck.cell_keys(new)[:n_new], cells)

    V_old, V_new = dc.vector_space(old), dc.vector_space(new)
    import dolfinx.fem as fem
    v_old, v_new = fem.Function(V_old), fem.Function(V_new)
    x = V_old.tabulate_dof_coordinates()
    v_old.x.array[:] = velocity(x[:, 0], x[:, 1]).reshape(-1)
    transfer.nodal_function(v_old, v_new)
    owned = V_new.dofmap.index_map.size_local * 2
    out["nodal"] = _by_key(comm, ck.dof_keys(V_new)[:owned], v_new.x.array[:owned])
    assert n_old > 0 or comm.size > 1
    if comm.rank == 0:
        np.savez(path, ranks=comm.size, outside=report.outside, **out)


if __name__ == "__main__":
    main(sys.argv[1], *(int(a) for a in sys.argv[2:]))
