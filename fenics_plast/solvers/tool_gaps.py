"""The tool shapes' gap formulas compiled for the explicit contact kernel.

Each shape of :mod:`fenics_plast.tool_shapes` writes its gap once, ``gap(prm, x, d) -> (g, N)``, with the
operations of :mod:`fenics_plast.tool_shapes.ops`. Here those operations get their compiled meaning
(``numba.extending.overload``), every function of the shape modules becomes callable from compiled code
(``register_jitable``: it stays plain Python for UFL and numpy), and :func:`gap_2d` / :func:`gap_3d`
dispatch on the shape's code over every registered shape of that dimension (a chain of compiled links, as
:mod:`fenics_plast.material.hardening` does for the hardening laws). x and d are tuples of floats [mm],
prm the shape's parameter vector (a float array, as long as the longest shape's in the kernel; a shape
reads only its own entries). Units mm.
"""
from __future__ import annotations

import importlib
import inspect
import math
import pkgutil

import numba
import numpy as np
from numba.core import types
from numba.extending import overload, register_jitable

from fenics_plast import tool_shapes
from fenics_plast.tool_shapes import ops, shapes

#: the flags of the contact kernel (:mod:`fenics_plast.solvers.contact_kernels`), so that a formula
#: compiles to the same instructions inside the kernel as it did written out there
FLAGS = dict(nogil=True, fastmath={"contract", "arcp", "nsz"})
_njit = numba.njit(cache=True, **FLAGS)


@overload(ops.sqrt, jit_options=FLAGS)
def _sqrt(a):
    return lambda a: np.sqrt(a)


@overload(ops.lt, jit_options=FLAGS)
def _lt(a, b):
    return lambda a, b: a < b


@overload(ops.ge, jit_options=FLAGS)
def _ge(a, b):
    return lambda a, b: a >= b


@overload(ops.maximum, jit_options=FLAGS)
def _maximum(a, b):
    return lambda a, b: a if a >= b else b


@overload(ops.minimum, jit_options=FLAGS)
def _minimum(a, b):
    return lambda a, b: a if a <= b else b


@overload(ops.sign, jit_options=FLAGS)
def _sign(a):
    return lambda a: 1.0 if a >= 0.0 else -1.0


@overload(ops.where, jit_options=FLAGS)
def _where(c, a, b):
    return lambda c, a, b: a if c else b


@overload(ops.dot, jit_options=FLAGS)
def _dot(a, b):
    if isinstance(a, types.BaseTuple) and len(a) == 3:
        return lambda a, b: a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    return lambda a, b: a[0] * b[0] + a[1] * b[1]


def _compile_shape_modules():
    """Every function defined in a module of :mod:`fenics_plast.tool_shapes` but ``ops`` callable from
    compiled code."""
    for info in pkgutil.iter_modules(tool_shapes.__path__):
        module = importlib.import_module(f"{tool_shapes.__name__}.{info.name}")
        if module is not ops:
            for _, f in inspect.getmembers(module, inspect.isfunction):
                if f.__module__ == module.__name__:
                    register_jitable(**FLAGS)(f)


_compile_shape_modules()


@_njit
def _no_shape_2d(kind, prm, x, d):
    return math.nan, (math.nan, math.nan)


@_njit
def _no_shape_3d(kind, prm, x, d):
    return math.nan, (math.nan, math.nan, math.nan)


def _link(code, gap, rest):
    """A compiled dispatcher: ``gap(prm, x, d)`` for the shape ``code``, else ``rest(kind, prm, x, d)``
    (numba caches a closure by the contents of its cells: one cache entry per link)."""
    @_njit
    def dispatch(kind, prm, x, d):
        if kind == code:
            return gap(prm, x, d)
        return rest(kind, prm, x, d)
    return dispatch


def _chain(dim, last):
    """The dispatcher over the shapes of dimension ``dim``, first code tested first."""
    chain = last
    for s in reversed([s for s in shapes().values() if dim in s.dims]):
        chain = _link(s.code, _njit(s.gap), chain)
    return chain


#: (kind, prm, x (2,), d (2,)) -> (g [mm], (N_0, N_1)); NaN for a code no 2-D shape has
gap_2d = _chain(2, _no_shape_2d)
#: (kind, prm, x (3,), d (3,)) -> (g [mm], (N_0, N_1, N_2)); NaN for a code no 3-D shape has
gap_3d = _chain(3, _no_shape_3d)
