"""The registry of rigid tool shapes: one module per shape in this package, each declaring
``SHAPE = ToolShape(...)``: its name (the scene's ``tools.<name>.shape``), its integer code, the
dimensions it exists in, its scene keys (``tools.<name>.*``, with unit, range and meaning), the keys each
dimension requires, how the keys pack into the float parameter vector ``prm``, and its gap.

The gap is written once, ``gap(prm, x, d) -> (g, N)``: x the current position (a tuple of ``dim``
components [mm]), d the tool's translation (``dim`` components [mm]), g the signed gap [mm] (> 0
separated, < 0 penetrating) and N (``dim`` components) the unit normal pointing from the tool into the
body. It uses only what :mod:`fenics_plast.tool_shapes.ops` lists, so that one formula is the UFL
expression of the static solver (and its ``ufl.derivative``), the numpy one of the reports and the
compiled one of the explicit solver (:mod:`fenics_plast.solvers.tool_gaps`). Where N is undefined (a
centre, an axis, a corner) it is guarded with :data:`~fenics_plast.tool_shapes.ops.TINY`: a finite
vector, not 0/0.

A shape module imports only the standard library, numpy, :mod:`fenics_plast.scene_key` and
:mod:`fenics_plast.tool_shapes.ops`: the schema reads the declarations. Its module docstring gives the
layout of ``prm``. The gap formulas are compiled into the contact kernel, so this package is part of the
kernel source digest (:func:`fenics_plast.kernel_source_digest`).

Adding a shape is one new module here (plus its test): the schema's ``tools`` table and its ``shape``
choices, validation, :class:`fenics_plast.tools.Tool`, both solvers and the compiled contact follow.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Callable

from fenics_plast.declarations import gathered
from fenics_plast.scene_key import Key

__all__ = ["ToolShape", "shapes", "vector"]


@dataclass(frozen=True)
class ToolShape:
    """One tool shape's declaration.

    name : the scene's ``shape`` value. code : the integer the compiled contact dispatches on (unique, >= 0).
    dims : the dimensions (2, 3) it exists in. doc : what it is, one sentence (the schema shows it).
    params : {scene key: :class:`~fenics_plast.scene_key.Key`} without ``when`` (the schema adds it); a key
        several shapes declare must be declared alike by each but for its doc.
    gap : (prm, x, d) -> (g, N), see the package docstring.
    pack : ({key: value} (absent keys None), dim) -> the parameter vector prm (a list of floats); raises
        ValueError for a value no formula can take (a zero normal, a profile whose pieces do not join).
    required : {dim: keys} the keys a dimension requires beyond those declared REQUIRED.
    check : optional (dotted, values, dim, fail) -> None: further scene rules of this shape (messages
        through ``fail``).
    """
    name: str
    code: int
    dims: tuple[int, ...]
    doc: str
    params: dict[str, Key]
    gap: Callable
    pack: Callable[[dict, int], list]
    required: dict[int, tuple[str, ...]] = field(default_factory=dict)
    check: Callable | None = None

    def dim_of(self, values: dict) -> int:
        """2 or 3: the space of a tool of this shape with the key values ``values`` (absent keys None):
        its only dimension, else the length of its first vector given (a 2-D profile has none)."""
        if len(self.dims) == 1:
            return self.dims[0]
        for name, key in self.params.items():
            if key.type == "vector" and values.get(name) is not None:
                return len(values[name])
        return 2


def vector(values: dict, key: str, dim: int, shape: str) -> list[float]:
    """The value of ``key`` as ``dim`` floats (for a shape's ``pack``); ValueError unless it is a finite
    ``dim``-vector."""
    v = values[key]
    try:
        out = [float(c) for c in v]
    except (TypeError, ValueError):
        out = []
    if len(out) != dim or not all(math.isfinite(c) for c in out):
        raise ValueError(f"{shape} {key} must be a finite {dim}-vector, got {v}")
    return out


@functools.lru_cache(maxsize=None)
def _registry() -> tuple[ToolShape, ...]:
    return gathered(__name__, __path__, "SHAPE", ToolShape, "tool shapes")


def shapes() -> dict[str, ToolShape]:
    """{name: shape} of every shape module in this package, in the order of their codes."""
    return {s.name: s for s in _registry()}
