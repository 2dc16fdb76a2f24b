"""The few operations a tool shape's gap formula may use, for its three readers.

A shape's ``gap(prm, x, d)`` (:mod:`fenics_plast.tool_shapes`) is written once, with Python arithmetic,
``abs``, ``range`` loops over ``prm`` and ``if`` on the values of ``prm``, plus the functions here:

* UFL (the static solver's residual and its ``ufl.derivative``): x and d hold UFL scalars, prm floats;
* numpy (reports, tests): x and d hold arrays (n,) of positions, prm floats;
* numba (the explicit solver's contact kernel): x and d are tuples of floats, prm a float array;
  :mod:`fenics_plast.solvers.tool_gaps` gives each function here its compiled meaning
  (``numba.extending.overload``).

One rule for UFL: FFCx cannot factor the Jacobian of a conditional (``where``) that picks between a
constant and an expression of the position; pick between expressions, or weight expressions by 0/1 flags
(``box.py``). ``tests/test_tool_shapes.py`` compiles every shape's Jacobian.

Each function tells UFL from numpy by the argument (a UFL expression has ``ufl_shape``). Standard library
and numpy only: the schema reads the shapes' declarations without importing UFL or numba.
"""
from __future__ import annotations

import numpy as np

#: sqrt(d.d + TINY): a point exactly on a corner, a centre or an axis gives N = 0, not 0/0
TINY = 1e-300


def _is_ufl(*a) -> bool:
    return any(hasattr(v, "ufl_shape") for v in a)


def sqrt(a):
    """Square root."""
    if _is_ufl(a):
        import ufl
        return ufl.sqrt(a)
    return np.sqrt(a)


def lt(a, b):
    """The condition a < b."""
    if _is_ufl(a, b):
        import ufl
        return ufl.lt(a, b)
    return a < b


def ge(a, b):
    """The condition a >= b."""
    if _is_ufl(a, b):
        import ufl
        return ufl.ge(a, b)
    return a >= b


def maximum(a, b):
    """The larger of a and b."""
    if _is_ufl(a, b):
        import ufl
        return ufl.max_value(a, b)
    return np.maximum(a, b)


def minimum(a, b):
    """The smaller of a and b."""
    if _is_ufl(a, b):
        import ufl
        return ufl.min_value(a, b)
    return np.minimum(a, b)


def sign(a):
    """+1 where a >= 0, -1 elsewhere."""
    if _is_ufl(a):
        import ufl
        return ufl.conditional(ufl.ge(a, 0.0), 1.0, -1.0)
    return np.where(a >= 0, 1.0, -1.0)


def where(c, a, b):
    """a where the condition c holds, else b; a and b tuples of the same length (e.g. (g, N_0, N_1)), their
    entries expressions or constants. UFL: one vector conditional (index it); numpy: an array (len(a), n)."""
    if hasattr(c, "ufl_shape") or _is_ufl(*a, *b):
        import ufl
        return ufl.conditional(c, ufl.as_vector(a), ufl.as_vector(b))
    n = len(a)
    entries = np.broadcast_arrays(*a, *b, c)             # constants as arrays of the points' shape
    return np.where(c, np.asarray(entries[:n]), np.asarray(entries[n:2 * n]))


def dot(a, b):
    """a . b of two tuples of the same length: a_0 b_0 + a_1 b_1 (+ a_2 b_2)."""
    s = a[0] * b[0] + a[1] * b[1]
    if len(a) == 3:
        s = s + a[2] * b[2]
    return s
