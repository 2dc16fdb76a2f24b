"""group_mean: the mean over a facet group of one component of its nodes' displacement or current position
[mm], weighted by each node's tributary reference area on the group (2 pi R included in axisymmetry): a
face's mean displacement (the billet's top face, a punch's imprint) where one node would be arbitrary.
Exact for a displacement linear along the group (the weights are the integrals of the shape functions)."""
from __future__ import annotations

import numpy as np

from fenics_plast.scene_key import Key

NAME, ORDER = "group_mean", 45
DOC = "group_mean: mean displacement or position of a group's nodes, area-weighted"
TAKES = ("group", "component", "scale")
KEYS = {
    "of": Key("str", "displacement", "What is averaged: displacement (times scale) or position (the current "
              "coordinate).", choices=("displacement", "position")),
}


def columns(name, o):
    return [f"{name}_mm"]


def check(d, o, ctx, fail):
    if o.group is None:
        fail(f"{d}.group is missing: required for a group mean")


def setup(name, o, q):
    import ufl
    from dolfinx import fem

    from fenics_plast.solvers.body_surface import tributary_areas
    b = q.body
    mesh = b.V.mesh
    weight = 2.0 * np.pi * ufl.SpatialCoordinate(mesh)[0] if b.geometry == "axisymmetric" else \
        fem.Constant(mesh, 1.0)
    tag = q.groups[o.group][1]
    bs = b.V.dofmap.index_map_bs
    nodes = b.group_nodes(q.facet_tags, tag)
    q.nodes[name] = nodes
    q.nodes[name + "/weights"] = tributary_areas(b.V, weight, q.facet_tags, tag)[nodes * bs]


def value(name, o, q, time, row):
    from mpi4py import MPI
    b = q.body
    nodes, w = q.nodes[name], q.nodes[name + "/weights"]
    c = b.component(o.component)
    x = b.positions()[nodes, c]
    if o.of == "displacement":
        x = o.scale * (x - b.X[nodes, c])
    local = np.array([float(np.dot(w, x)), float(w.sum())])
    total = np.zeros(2)
    b.comm.Allreduce(local, total, op=MPI.SUM)
    return [total[0] / total[1]]
