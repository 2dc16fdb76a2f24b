"""mass_scaling (automatic): what selective mass scaling added, in explicit runs that have it
(``analysis.mass_scaling_dt`` > 0): the added mass [kg; plane strain: per mm of depth] and its
fraction of the body's, the cells scaled, the kinetic energy of the added mass now and the kinetic
energy it brought in (a term of the energy balance) [J]; summary.json adds the target, the body's
mass and the largest density factor. Read on ``Body.mass_scaling``: ``stats()`` (the solver's
statistics in its units, tonne and N mm; collective) and ``target_us``."""
from __future__ import annotations

NAME, ORDER = "mass_scaling", 10
AUTOMATIC = True
DOC = "mass_scaling: the mass selective mass scaling added (explicit runs with mass scaling)"
TAKES = ()
#: its summary keys in ``info_results``, and their place among the automatic kinds' there
INFO, INFO_ORDER = ("added_mass_fraction", "mass_scaled_cells"), 10


def active(body):
    return body.mass_scaling is not None


def columns(name, o):
    return ["added_mass_kg", "added_mass_fraction", "mass_scaled_cells", "added_mass_kinetic_energy_J",
            "mass_scaling_energy_J"]


def value(name, o, q, time, row):
    m = q.body.mass_scaling.stats()
    return [m["added_mass"] * 1e3, m["fraction"], m["cells"], m["kinetic"] * 1e-3, m["energy"] * 1e-3]


def summary(q):
    m = q.body.mass_scaling.stats()
    return dict(mass_scaling_dt_us=q.body.mass_scaling.target_us, body_mass_kg=m["body_mass"] * 1e3,
                added_mass_kg=m["added_mass"] * 1e3, added_mass_fraction=m["fraction"],
                mass_scaled_cells=m["cells"], max_mass_scale_factor=m["max_factor"],
                added_mass_kinetic_energy_J=m["kinetic"] * 1e-3, mass_scaling_energy_J=m["energy"] * 1e-3)


def failed(q):
    """A run gone unstable: the masses (finite; the velocities, and the energies, may not be)."""
    m = q.body.mass_scaling.stats()
    return dict(added_mass_kg=m["added_mass"] * 1e3, added_mass_fraction=m["fraction"],
                mass_scaled_cells=m["cells"], max_mass_scale_factor=m["max_factor"])
