"""erosion (automatic): element erosion in explicit runs that have it (``analysis.erosion_ratio`` > 0):
the eroded cells and their fraction of the body's volume; summary.json adds the ratio, their mass
fraction and the list of eroded cells (index in the mesh file, reference centre [mm]). Read on
``Body.erosion``: ``stats()`` (the solver's statistics, collective), ``ratio``, ``cells()``."""
from __future__ import annotations

NAME, ORDER = "erosion", 30
AUTOMATIC = True
DOC = "erosion: the eroded cells (explicit runs with element erosion)"
TAKES = ()
#: its summary keys in ``info_results``, and their place among the automatic kinds' there
INFO, INFO_ORDER = ("eroded_cells", "eroded_volume_fraction"), 20


def active(body):
    return body.erosion is not None


def columns(name, o):
    return ["eroded_cells", "eroded_volume_fraction"]


def value(name, o, q, time, row):
    e = q.body.erosion.stats()
    return [e["cells"], e["volume_fraction"]]


def summary(q):
    er = q.body.erosion
    e = er.stats()
    return dict(eroded_cells=e["cells"], eroded_volume_fraction=e["volume_fraction"], erosion_ratio=er.ratio,
                eroded_mass_fraction=e["mass_fraction"],
                eroded_cell_list=[dict(cell=c, reference_centre_mm=x) for c, x in er.cells()])


def failed(q):
    return dict(zip(columns(NAME, None), value(NAME, None, q, None, None)))
