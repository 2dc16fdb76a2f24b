"""contact_pressure: the normal contact pressure of a contact pair now [MPa], its largest nodal value
(``statistic = "max"``: the penalty pressure eps <-g> at a node; with two passes the group's pressures
scaled to carry the interface's whole normal force) or its mean over the area in contact (``"mean"``:
the normal force over :mod:`contact_area`'s area)."""
from __future__ import annotations

from .contact_area import area_and_force
from .contact_force import check as check_pair

NAME, ORDER = "contact_pressure", 23
DOC = "contact_pressure: largest or mean normal pressure of a contact pair"
TAKES = ("contact", "statistic")


def check(d, o, ctx, fail):
    check_pair(d, o, ctx, fail)
    if o.statistic == "min":
        fail(f"{d}.statistic = 'min': contact_pressure takes max (the largest nodal pressure) or mean (the normal "
             f"force over the area in contact)")


def columns(name, o):
    return [f"{name}_MPa"]


def value(name, o, q, time, row):
    from mpi4py import MPI
    if o.statistic == "mean":
        area, force = area_and_force(q, o.contact)
        return [force / area if area > 0.0 else 0.0]
    p = q.body.contact_nodes(o.contact).p
    return [q.body.comm.allreduce(float(p.max()) if p.size else 0.0, op=MPI.MAX)]
