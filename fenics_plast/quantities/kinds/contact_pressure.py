"""contact_pressure: the normal contact pressure of a contact pair now [MPa], its largest nodal value
(``statistic = "max"``: the penalty pressure eps <-g> at a node; with two passes the group's pressures
scaled to carry the interface's whole normal force) or its mean over the area in contact (``"mean"``:
the normal force over :mod:`contact_area`'s area)."""
from __future__ import annotations

from fenics_plast.scene_key import Key

from .contact_area import area_and_force
from .contact_force import check  # noqa: F401  (the pair must exist)

NAME, ORDER = "contact_pressure", 23
DOC = "contact_pressure: largest or mean normal pressure of a contact pair"
TAKES = ("contact",)
KEYS = {
    "statistic": Key("str", "max", "max: the largest nodal pressure; mean: the normal force over the area in "
                     "contact.", choices=("max", "mean")),
}


def columns(name, o):
    return [f"{name}_MPa"]


def value(name, o, q, time, row):
    from mpi4py import MPI
    if o.statistic == "mean":
        area, force = area_and_force(q, o.contact)
        return [force / area if area > 0.0 else 0.0]
    p = q.body.contact_nodes(o.contact).p
    return [q.body.comm.allreduce(float(p.max()) if p.size else 0.0, op=MPI.MAX)]
