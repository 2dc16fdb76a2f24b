"""Declarations gathered from a package's modules, so that adding one is adding a module (no list to edit):
the hardening laws (:mod:`fenics_plast.hardening_laws`) and the tool shapes (:mod:`fenics_plast.tool_shapes`).
Standard library only (the schema reads both registries)."""
from __future__ import annotations

import importlib
import pkgutil

__all__ = ["gathered"]


def gathered(package: str, path, attribute: str, kind: type, what: str) -> tuple:
    """The ``attribute`` of every module of ``package`` (its ``__name__`` and ``__path__``) that holds a
    ``kind`` there, sorted by their ``code``; RuntimeError if two share a code (``what``: their plural,
    for the message)."""
    found = []
    for info in pkgutil.iter_modules(path):
        value = getattr(importlib.import_module(f"{package}.{info.name}"), attribute, None)
        if isinstance(value, kind):
            found.append(value)
    found.sort(key=lambda d: d.code)
    for a, b in zip(found, found[1:]):
        if a.code == b.code:
            raise RuntimeError(f"{what} {a.name!r} and {b.name!r} share the code {a.code}")
    return tuple(found)
