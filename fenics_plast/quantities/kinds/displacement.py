"""displacement: of the node nearest a reference point, one component [mm]. With ``group`` (a facet group) or
``regions`` (cell regions) the node is the nearest among theirs: where two bodies touch, their nodes
coincide, and the body is named by its group or region."""
from __future__ import annotations

NAME, ORDER = "displacement", 40
DOC = "displacement: of the node nearest `point` (of `group` or `regions` if given)"
TAKES = ("component", "point", "scale", "group", "regions")


def columns(name, o):
    return [f"{name}_mm"]


def check_mesh(d, o, ctx, fail):
    ctx["vector"](f"{d}.point", o.point)


def setup(name, o, q):
    import numpy as np
    b = q.body
    among = None
    if o.group is not None:
        among = b.group_nodes(q.facet_tags, q.groups[o.group][1])
    if o.regions is not None:
        cells = np.concatenate([b.cell_regions[r] for r in o.regions]).astype(np.int32)
        dofs = np.unique(np.concatenate([b.V.dofmap.cell_dofs(c) for c in cells])) if len(cells) else \
            np.zeros(0, dtype=np.int64)
        dofs = dofs[dofs < b.n_owned_nodes]
        among = dofs if among is None else np.intersect1d(among, dofs)
    q.nodes[name] = q.nearest_node(np.asarray(o.point), among)


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
