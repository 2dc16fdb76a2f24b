"""The registry of output quantity kinds: every module of :mod:`fenics_plast.quantities.kinds`, found
by :mod:`pkgutil` (no list to edit), keyed by its ``NAME``.

A kind module declares (standard library and numpy at import time; heavy imports inside functions):

* ``NAME`` (the ``quantity`` value), ``ORDER`` (its place in the schema's list of choices), ``DOC``
  (its sentence in the ``quantity`` key's doc);
* ``TAKES``: the shared keys of the ``outputs`` table it takes (group, component, tool, point, which,
  regions, unit, scale; declared once in :mod:`fenics_plast.schema`), ``KEYS``: its own keys
  ({name: :class:`fenics_plast.scene_key.Key`}, without ``when``: the registry adds it);
* ``columns(name, o)`` -> its history.csv column names (none for a profile);
* validation rules, each optional, called by :mod:`fenics_plast.validation` with ``(d, o, ctx, fail)``
  (``d``: ``"outputs.<name>"``, ``o``: the output's table, ``ctx``: a dict of what that stage knows,
  ``fail(message)``): ``check`` (scene level: tools, explicit, symbols, end), ``check_mesh``
  (geometry, three_d, where, vector), ``check_boundary`` (explicit, components, holder, symmetric);
* ``setup(name, o, q)`` (optional, once on the :class:`~fenics_plast.quantities.evaluate.Quantities`
  ``q``) and ``value(name, o, q, time, row)`` -> its column values;
* optional flags: ``RADIAL`` (takes ``component = "radial"``), ``DERIVED`` (computed from other
  outputs: only the expressions declared after it may name it);
* a profile kind (``PROFILE = True``) gives ``profile(name, q)`` -> (s, values), ``summary(name, o, q,
  time_label)`` -> dict and ``summary_keys(name, o)`` -> its summary.json keys (the others' summaries
  are the history columns' final / max / min, written by ``Quantities.summary``).

An automatic kind (``AUTOMATIC = True``: in :data:`AUTOMATIC`, not in :data:`KINDS`, so no ``quantity``
a scene declares) is measured in every run whose body has it (``active(body)``: what the solver does,
e.g. mass scaling, walls, erosion): ``columns(name, o)`` and ``value(name, o, q, time, row)`` as above
(``o`` None; the values written as they come: counts stay integers), ``summary(q)`` -> its
summary.json entries at the end (measured then), ``failed(q)`` -> those of a run gone unstable (what
stays finite), ``INFO`` its summary keys listed in ``info_results`` (at ``INFO_ORDER`` among the
automatic kinds').
"""
from __future__ import annotations

import dataclasses
import importlib
import pkgutil
from types import ModuleType

from . import kinds as kinds_package

__all__ = ["KINDS", "AUTOMATIC", "kind", "taking", "quantity_doc", "kind_keys", "column_names", "summary_keys",
           "study_keys"]


def _discover() -> dict[str, ModuleType]:
    mods = [importlib.import_module(f"{kinds_package.__name__}.{m.name}")
            for m in pkgutil.iter_modules(kinds_package.__path__) if not m.name.startswith("_")]
    return {m.NAME: m for m in sorted(mods, key=lambda m: (m.ORDER, m.NAME))}


_ALL = _discover()

#: {quantity name: its kind module}, in the schema's order (the quantities a scene declares)
KINDS: dict[str, ModuleType] = {n: m for n, m in _ALL.items() if not getattr(m, "AUTOMATIC", False)}

#: {name: kind module} of the automatic quantities, in their order (history columns, summary)
AUTOMATIC: dict[str, ModuleType] = {n: m for n, m in _ALL.items() if getattr(m, "AUTOMATIC", False)}


def kind(quantity: str) -> ModuleType:
    """The kind module of ``quantity`` (KeyError naming the known ones)."""
    try:
        return KINDS[quantity]
    except KeyError:
        raise KeyError(f"no output quantity {quantity!r}: quantities are {', '.join(KINDS)}") from None


def taking(key: str) -> tuple[str, ...]:
    """The quantities that take the shared key ``key`` (the schema's ``when`` list)."""
    return tuple(n for n, m in KINDS.items() if key in m.TAKES)


def quantity_doc() -> str:
    """The ``quantity`` key's doc: each kind's sentence."""
    return "; ".join(m.DOC for m in KINDS.values()) + "."


def kind_keys() -> dict:
    """The kinds' own keys, each restricted to its kind (``when``); ValueError if two declare one name."""
    out = {}
    for n, m in KINDS.items():
        for k, key in getattr(m, "KEYS", {}).items():
            if k in out:
                raise ValueError(f"outputs key {k!r} is declared by two quantity kinds (share it in the schema)")
            out[k] = dataclasses.replace(key, when={"quantity": (n,)})
    return out


def column_names(name: str, spec) -> list[str]:
    """The history.csv column(s) of output ``name``."""
    return KINDS[spec.quantity].columns(name, spec)


def summary_keys(name: str, o, outputs: dict) -> list[str]:
    """The summary.json keys of output ``name`` (``o``), in the order its ``summary`` lists them."""
    m = KINDS[o.quantity]
    if getattr(m, "PROFILE", False):
        return m.summary_keys(name, o)
    cols = [c if w == "final" else f"{w}_{c}" for c in column_names(name, o) for w in o.summary]
    if o.at_max_of is not None:
        cols.append(f"{column_names(name, o)[0]}_at_max_"
                    f"{column_names(o.at_max_of, outputs[o.at_max_of])[0]}")
    return cols


def study_keys(outputs: dict) -> dict:
    """key_results / info_results (summary.json keys of the declared outputs, key ones first listed
    in ``key_results``) and references ({summary key: {value, source}}) of ``outputs``."""
    key, info, refs = [], [], {}
    for name, o in outputs.items():
        cols = summary_keys(name, o, outputs)
        (key if o.key else info).extend(cols)
        if o.reference is not None and cols:
            refs[cols[0]] = dict(value=o.reference, source=o.reference_source)
    return dict(key_results=key, info_results=info, references=refs)
