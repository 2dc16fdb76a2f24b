"""wall_energy (automatic): the energy the rigid walls' stops took [J] (boundary type ``wall``, explicit
runs), a term of the energy balance. Read on ``Body.wall_energy`` [N mm] (collective)."""
from __future__ import annotations

NAME, ORDER = "wall_energy", 20
AUTOMATIC = True
DOC = "wall_energy: the energy the rigid walls took (explicit runs with walls)"
TAKES = ()
#: its summary keys in ``info_results``, and their place among the automatic kinds' there
INFO, INFO_ORDER = ("wall_energy_J",), 30


def active(body):
    return body.wall_energy is not None


def columns(name, o):
    return ["wall_energy_J"]


def value(name, o, q, time, row):
    return [q.body.wall_energy() * 1e-3]


def summary(q):
    return dict(zip(columns(NAME, None), value(NAME, None, q, None, None)))


failed = summary
