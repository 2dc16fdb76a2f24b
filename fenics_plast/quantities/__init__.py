"""The quantities a scene declares in ``[outputs.<name>]``, measured on a running solver.

Each output becomes history.csv column(s) (``<name>_<unit>``, ``<name>`` for dimensionless ones) and
its final value goes into summary.json, with ``max_``/``min_`` entries when its ``summary`` asks for
them; a profile output (thickness) is written to ``<name>.csv`` instead. Units: mm, N (or kN), MPa, J.

One module per quantity kind in :mod:`fenics_plast.quantities.kinds` declares everything about it
(its keys, validation rule, columns, evaluation, summary); :mod:`.registry` finds them (so adding a
quantity is one file). :mod:`.body` holds :class:`Body`, what the quantities read of a solver, and
:mod:`.evaluate` the :class:`Quantities` that measure the declared outputs. Importing this package
(or the registry) stays light, for the schema: no dolfinx, mpi4py or numba until :class:`Body` or
:class:`Quantities` is asked for.
"""
from __future__ import annotations

from .registry import KINDS, column_names, kind, study_keys

__all__ = ["KINDS", "kind", "column_names", "study_keys", "Body", "Quantities", "ENERGIES", "ENERGY_COLUMNS",
           "N_MM_TO_J"]


def __getattr__(name):
    """The heavy names, imported on first use (PEP 562)."""
    if name == "Body":
        from .body import Body
        return Body
    if name == "Quantities":
        from .evaluate import Quantities
        return Quantities
    if name in ("ENERGIES", "ENERGY_COLUMNS", "N_MM_TO_J"):
        return getattr(KINDS["energy"], name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
