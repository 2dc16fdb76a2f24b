"""displacement: of the node nearest a reference point, one component [mm]."""
from __future__ import annotations

NAME, ORDER = "displacement", 40
DOC = "displacement: of the node nearest `point`"
TAKES = ("component", "point", "scale")


def columns(name, o):
    return [f"{name}_mm"]


def check_mesh(d, o, ctx, fail):
    ctx["vector"](f"{d}.point", o.point)


def setup(name, o, q):
    import numpy as np
    q.nodes[name] = q.nearest_node(np.asarray(o.point))


def value(name, o, q, time, row):
    return node_value(name, o, q, displacement=True)


def node_value(name, o, q, displacement):
    """The node's current coordinate (``displacement``: minus its reference one, times ``scale``)."""
    from mpi4py import MPI
    b, comm = q.body, q.body.comm
    nodes = q.nodes[name]
    c = b.component(o.component)
    x = b.positions()[nodes, c]
    if displacement:
        x = o.scale * (x - b.X[nodes, c])
    return [comm.allreduce(float(x[0]) if len(x) else 0.0, op=MPI.SUM)]
