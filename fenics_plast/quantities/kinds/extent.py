"""extent: the largest or smallest current coordinate of a facet group (or the body) [mm]."""
from __future__ import annotations

import numpy as np

NAME, ORDER = "extent", 60
DOC = "extent: largest or smallest current coordinate of a group (or the body)"
TAKES = ("group", "component", "which")
RADIAL = True          # takes component = "radial" (distance from the z axis)


def columns(name, o):
    return [f"{name}_mm"]


def setup(name, o, q):
    if o.group is not None:
        q.nodes[name] = q.body.group_nodes(q.facet_tags, q.groups[o.group][1])


def value(name, o, q, time, row):
    from mpi4py import MPI
    b, comm = q.body, q.body.comm
    x = b.positions()[: b.n_owned_nodes]
    nodes = q.nodes.get(name)
    x = x if nodes is None else x[nodes]
    # radial: distance from the z axis (3-D), r itself in axisymmetry
    vals = (np.hypot(x[:, 0], x[:, 1]) if o.component == "radial" and x.shape[1] == 3 else
            x[:, 0] if o.component == "radial" else x[:, b.component(o.component)])
    if o.which == "max":
        return [comm.allreduce(float(vals.max()) if vals.size else -np.inf, op=MPI.MAX)]
    return [comm.allreduce(float(vals.min()) if vals.size else np.inf, op=MPI.MIN)]
