"""contact_area: the area of a contact pair's group in contact now [mm^2]: the sum of the tributary reference
areas of its nodes pressed into the master surface (gap < 0; the nodal rule the contact forces use, so
that the normal force over this area is the mean pressure, contact_pressure). In axisymmetry the revolved
area (2 pi r included); in plane strain the area per mm of thickness."""
from __future__ import annotations

import numpy as np

from .contact_force import check  # noqa: F401  (the pair must exist)

NAME, ORDER = "contact_area", 22
DOC = "contact_area: area of a contact pair's group in contact"
TAKES = ("contact",)


def columns(name, o):
    return [f"{name}_mm2"]


def area_and_force(q, pair):
    """(area in contact [mm^2], normal force sum A p over it [N]) of ``pair``'s nodes, all ranks."""
    from mpi4py import MPI
    c = q.body.contact_nodes(pair)
    on = c.g < 0.0
    local = np.array([c.area[on].sum(), (c.area * c.p)[on].sum()], dtype=float)
    total = np.zeros(2)
    q.body.comm.Allreduce(local, total, op=MPI.SUM)
    return float(total[0]), float(total[1])


def value(name, o, q, time, row):
    return [area_and_force(q, o.contact)[0]]
