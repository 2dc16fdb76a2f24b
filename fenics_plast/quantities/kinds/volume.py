"""volume: the current volume of the body or of some cell regions [mm^3].

Axisymmetric: the volume of revolution, 2 pi r dA over the current (r, z) section (the whole 360°
body); plane strain: the current area of the section, the volume per mm of thickness; 3-D: the
volume. Measured on the current nodal positions of the linear cells, exactly: triangles and
tetrahedra by one point, quadrilaterals and hexahedra by 2 x 2 (x 2) Gauss points (the integrands,
r det J and det J, are of degree 2 at most in each reference coordinate). Shows how well a model
keeps the volume in plastic flow (isochoric) and how much it changes elastically.
"""
from __future__ import annotations

import numpy as np

NAME, ORDER = "volume", 95
DOC = ("volume: the current volume [mm³] of the body or of its `regions` (axisymmetric: of the whole 360° "
       "body; plane strain: per mm of thickness, the section's area)")
TAKES = ("regions", "scale")

_G = 0.5 / np.sqrt(3.0)
_GAUSS = (0.5 - _G, 0.5 + _G)


def columns(name, o):
    return [f"{name}_mm3"]


def _tensor_gradients(dim: int):
    """(points, dN/dxi (points, nodes, dim), weights) of the tensor-product linear cell of ``dim``,
    nodes in dolfinx's lexicographic order (x fastest), Gauss 2 per direction."""
    pts = np.array(np.meshgrid(*([_GAUSS] * dim), indexing="ij")).reshape(dim, -1).T
    corners = np.array(np.meshgrid(*([(0.0, 1.0)] * dim), indexing="ij")).reshape(dim, -1).T[:, ::-1]
    grads = np.empty((len(pts), len(corners), dim))
    for a, c in enumerate(corners):
        for k in range(dim):
            g = np.ones(len(pts))
            for j in range(dim):
                f = pts[:, j] if c[j] == 1.0 else 1.0 - pts[:, j]
                g = g * (np.where(c[j] == 1.0, 1.0, -1.0) if j == k else f)
            grads[:, a, k] = g
    shapes = np.empty((len(pts), len(corners)))
    for a, c in enumerate(corners):
        shapes[:, a] = np.prod([pts[:, j] if c[j] == 1.0 else 1.0 - pts[:, j] for j in range(dim)], axis=0)
    return shapes, grads, np.full(len(pts), 1.0 / len(pts))


def setup(name, o, q):
    from fenics_plast import dolfinx_compat as dc
    b = q.body
    n_cells = b.V.mesh.topology.index_map(b.V.mesh.topology.dim).size_local
    dofs = dc.cell_dofs(b.V)[:n_cells]
    if o.regions is not None:
        dofs = dofs[np.concatenate([b.cell_regions[r] for r in o.regions])]
    q.nodes[name] = dofs


def cell_volumes(x: np.ndarray, axisymmetric: bool) -> np.ndarray:
    """Volumes [mm^3] (2-D: areas [mm^2], or 2 pi r dA in axisymmetry) of cells of linear vertex
    coordinates ``x`` (cells, vertices, gdim)."""
    nv, gdim = x.shape[1], x.shape[2]
    if nv == gdim + 1:                       # simplex: det J / gdim!, r at the centroid
        J = (x[:, 1:] - x[:, :1]).transpose(0, 2, 1)
        v = np.abs(np.linalg.det(J)) / (2.0 if gdim == 2 else 6.0)
        return 2.0 * np.pi * x[:, :, 0].mean(axis=1) * v if axisymmetric else v
    shapes, grads, w = _tensor_gradients(gdim)
    J = np.einsum("cad,pak->cpdk", x, grads)          # (cells, points, gdim, gdim)
    f = np.abs(np.linalg.det(J)) * w
    if axisymmetric:
        f = 2.0 * np.pi * np.einsum("ca,pa->cp", x[:, :, 0], shapes) * f
    return f.sum(axis=1)


def value(name, o, q, time, row):
    from mpi4py import MPI
    b = q.body
    x = b.positions()[q.nodes[name]]
    v = float(cell_volumes(x, b.geometry == "axisymmetric").sum()) if len(x) else 0.0
    return [o.scale * b.comm.allreduce(v, op=MPI.SUM)]
