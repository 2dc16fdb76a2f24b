"""Safe values for scene files: constants, piecewise-linear tables and expressions of x, y, z, t.

A scene file is data: reading one must never run code. ``eval`` would run any Python the file
holds (``__import__('os').system(...)``), and numexpr 2.8.4 had a code-execution flaw of its own,
so neither is used. An expression is parsed with :mod:`ast` and checked against a whitelist, then
evaluated by walking our own small tree (never compiled), in numpy (float64) or in UFL.

Accepted in an expression (at most 500 characters, nesting depth at most 40: each bracket, function
call, unary sign and operator of higher precedence opens a level; a chain of ``+ -`` or of ``* /`` is one
level however many terms it has):

* numbers (every literal becomes a float, never a huge-integer computation); ``True``, strings,
  complex refused. A part without symbols is computed when the expression is read (``2*pi*x`` keeps
  one number ``6.28...``); one that is not finite (``9**9**9``, ``10**400``, ``log(0)``, ``1/0``,
  ``1e308*10``) refuses the expression, naming that part;
* the symbols (default ``x, y, z, t``) and the constants ``pi`` and ``e``;
* unary ``+ -`` and binary ``+ - * / **``;
* calls of ``sin cos tan asin acos atan atan2 sinh cosh tanh sqrt exp log abs min max`` with
  positional arguments only (``atan2``, ``min``, ``max`` take two, the others one).

Anything else (attributes, indexing, lambdas, comparisons, ``and``/``or``, ``a if c else b``,
comprehensions, keyword arguments, f-strings, dunder names, ...) raises :class:`ExpressionError`
naming the scene key, the construct and where it is.

:func:`parse_value` turns a TOML value (a number, an expression string, or an inline table
``{ t = [...], value = [...] }``) into a :class:`Value` with one interface for all three forms.
"""
from __future__ import annotations

import ast
import math
import operator

import numpy as np
import ufl

from fenics_plast import dolfinx_compat as dc

MAX_LENGTH = 500
MAX_DEPTH = 40
SPACE = ("x", "y", "z")
CONSTANTS = {"pi": math.pi, "e": math.e}
#: name -> (number of arguments, numpy function, UFL function)
FUNCTIONS = {
    "sin": (1, np.sin, ufl.sin), "cos": (1, np.cos, ufl.cos), "tan": (1, np.tan, ufl.tan),
    "asin": (1, np.arcsin, ufl.asin), "acos": (1, np.arccos, ufl.acos),
    "atan": (1, np.arctan, ufl.atan), "atan2": (2, np.arctan2, dc.atan2),
    "sinh": (1, np.sinh, ufl.sinh), "cosh": (1, np.cosh, ufl.cosh), "tanh": (1, np.tanh, ufl.tanh),
    "sqrt": (1, np.sqrt, ufl.sqrt), "exp": (1, np.exp, ufl.exp), "log": (1, np.log, ufl.ln),
    "abs": (1, np.abs, abs), "min": (2, np.minimum, ufl.min_value), "max": (2, np.maximum, ufl.max_value),
}
_BINOPS = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**"}
_PRECEDENCE = {ast.Add: 1, ast.Sub: 1, ast.Mult: 2, ast.Div: 2, ast.Pow: 3}
_APPLY = {"+": operator.add, "-": operator.sub, "*": operator.mul, "/": operator.truediv,
          "**": operator.pow}
_OP_TEXT = {ast.FloorDiv: "//", ast.Mod: "%", ast.MatMult: "@", ast.LShift: "<<", ast.RShift: ">>",
            ast.BitOr: "|", ast.BitXor: "^", ast.BitAnd: "&", ast.Not: "not", ast.Invert: "~"}
_CONSTRUCTS = {ast.Attribute: "attribute access", ast.Subscript: "indexing", ast.Lambda: "lambda",
               ast.Compare: "comparison", ast.BoolOp: "boolean operator", ast.IfExp: "conditional "
               "expression", ast.ListComp: "comprehension", ast.SetComp: "comprehension",
               ast.DictComp: "comprehension", ast.GeneratorExp: "comprehension",
               ast.JoinedStr: "f-string", ast.Starred: "starred argument", ast.Tuple: "tuple",
               ast.List: "list", ast.Dict: "dict", ast.Set: "set", ast.NamedExpr: "assignment"}


class ExpressionError(ValueError):
    """An invalid value in a scene file; the message names the scene key and what is wrong."""


def _quote(text):
    return f'"{text}"' if len(text) <= 80 else f'"{text[:77]}..."'


def _finite(v):
    """float(v) for a finite int/float (not bool), else None."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    try:
        return float(v) if math.isfinite(float(v)) else None
    except OverflowError:
        return None


class _Builder:
    """Checks a Python AST against the whitelist and turns it into nested tuples:
    ("num", float), ("sym", name), ("neg", a), ("call", name, args), (op, a, b) for op in + - * / **."""

    def __init__(self, text, where, symbols):
        self.text, self.where, self.symbols, self.used = text, where, tuple(symbols), set()

    def fail(self, what, node=None, hint=""):
        at = f" at column {node.col_offset + 1}" if hasattr(node, "col_offset") else ""
        raise ExpressionError(f"{self.where}: {what}{at} in {_quote(self.text)}{hint}")

    def build(self, node, depth=1):
        tree = self._build(node, depth)
        if tree[0] not in ("num", "sym") and all(a[0] == "num" for a in _children(tree)):
            tree = self.fold(tree, node)
        return tree

    def fold(self, tree, node):
        """A part without symbols -> ("num", its value); a value that is not finite refuses the
        expression (an overflow would otherwise reach the solver or the generated C code as inf)."""
        with np.errstate(all="ignore"):
            v = float(_walk(tree, {}, 0))
        if not math.isfinite(v):
            seg = ast.get_source_segment(self.text, node) or self.text
            self.fail(f"'{seg}' is not finite (it computes to {v})", node,
                      " (a part without symbols must compute to a finite number)")
        return ("num", v)

    def _build(self, node, depth):
        if depth > MAX_DEPTH:
            self.fail(f"expression nests too deeply (more than {MAX_DEPTH} levels)")
        seg = ast.get_source_segment(self.text, node) or type(node).__name__
        if isinstance(node, ast.Constant):
            v = node.value
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                kind = {bool: "boolean", str: "string", bytes: "bytes", complex: "complex number"}
                self.fail(f"{kind.get(type(v), 'constant')} {seg} is not allowed (numbers only)", node)
            if _finite(v) is None:
                self.fail(f"number {seg} is not finite", node)
            return ("num", _finite(v))
        if isinstance(node, ast.Name):
            if "__" in node.id:
                self.fail(f"dunder name '{node.id}' is not allowed", node)
            if node.id in self.symbols:
                self.used.add(node.id)
                return ("sym", node.id)
            if node.id in CONSTANTS:
                return ("num", CONSTANTS[node.id])
            if node.id in FUNCTIONS:
                self.fail(f"function '{node.id}' used without a call", node, f" (write {node.id}(...))")
            self.fail(f"unknown symbol '{node.id}'", node, f" (allowed: {', '.join(self.symbols)})")
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.UAdd, ast.USub)):
            a = self.build(node.operand, depth + 1)
            return a if isinstance(node.op, ast.UAdd) else ("neg", a)
        if isinstance(node, ast.BinOp) and type(node.op) in _BINOPS:
            # a chain a + b - c + ... (or a * b / c ...) nests to the left in the tree: one level
            chain = (isinstance(node.left, ast.BinOp) and type(node.left.op) in _BINOPS
                     and _PRECEDENCE[type(node.left.op)] == _PRECEDENCE[type(node.op)] != 3)
            return (_BINOPS[type(node.op)], self.build(node.left, depth if chain else depth + 1),
                    self.build(node.right, depth + 1))
        if isinstance(node, (ast.UnaryOp, ast.BinOp)):
            self.fail(f"operator '{_OP_TEXT.get(type(node.op), type(node.op).__name__)}' is not allowed", node)
        if isinstance(node, ast.Call):
            return self.call(node, seg, depth)
        what = _CONSTRUCTS.get(type(node), f"construct {type(node).__name__}")
        self.fail(f"{what} '{seg}' is not allowed", node)

    def call(self, node, seg, depth):
        name = node.func.id if isinstance(node.func, ast.Name) else None
        if name is None:
            self.fail(f"only named functions can be called, not '{seg}'", node)
        if "__" in name:
            self.fail(f"dunder name '{name}' is not allowed", node)
        if name not in FUNCTIONS:
            self.fail(f"unknown function '{name}'", node, f" (allowed: {', '.join(FUNCTIONS)})")
        for a in node.args:
            if isinstance(a, ast.Starred):
                self.fail(f"starred argument '{ast.get_source_segment(self.text, a)}' is not allowed", a)
        if node.keywords:
            k = node.keywords[0]
            self.fail(f"keyword argument '{ast.get_source_segment(self.text, k)}' is not allowed", k)
        n = FUNCTIONS[name][0]
        if len(node.args) != n:
            self.fail(f"{name} takes {n} argument{'s' * (n > 1)}, got {len(node.args)} ('{seg}')", node)
        return ("call", name, tuple(self.build(a, depth + 1) for a in node.args))


def _children(tree):
    """The operand subtrees of a checked tree node (none for a number or a symbol)."""
    if tree[0] in ("num", "sym"):
        return ()
    if tree[0] == "neg":
        return (tree[1],)
    if tree[0] == "call":
        return tree[2]
    return tree[1:]


def _walk(node, env, backend):
    """Evaluate a checked tree; backend 0 is numpy (float64), 1 is UFL."""
    tag = node[0]
    if tag == "num":
        return np.float64(node[1]) if backend == 0 else node[1]
    if tag == "sym":
        return env[node[1]]
    if tag == "neg":
        return -_walk(node[1], env, backend)
    if tag == "call":
        return FUNCTIONS[node[1]][1 + backend](*(_walk(a, env, backend) for a in node[2]))
    return _APPLY[tag](_walk(node[1], env, backend), _walk(node[2], env, backend))


def _unparse(tree) -> str:
    """A checked tree as text (fully bracketed), for messages."""
    tag = tree[0]
    if tag == "num":
        return f"{tree[1]:g}"
    if tag == "sym":
        return tree[1]
    if tag == "neg":
        return f"-{_unparse(tree[1])}"
    if tag == "call":
        return f"{tree[1]}({', '.join(_unparse(a) for a in tree[2])})"
    return f"({_unparse(tree[1])} {tag} {_unparse(tree[2])})"


def _denominators(tree):
    """Every divisor subtree (the right operand of each /) of a checked tree."""
    if tree[0] == "/":
        yield tree[2]
    for child in _children(tree):
        yield from _denominators(child)


#: how many times from 0 to the end of an analysis a value of t is checked at before the run
CHECK_TIMES = 65


def check_times(t_end: float, n: int = CHECK_TIMES) -> np.ndarray:
    """``n`` equally spaced times from 0 to ``t_end`` (both included), where values of t are checked
    before a run (static: pseudo-time; explicit: µs as written in the scene)."""
    return np.linspace(0.0, float(t_end), n)


def check_output_expression(expression: "Expression", t_end: float, samples: int = 64) -> None:
    """Refuse before the run an output expression (of t and other outputs' values) that divides by a
    denominator that is zero for any values, or that is not finite in the first history row (t = 0)
    whatever the outputs' values: :class:`ExpressionError` naming the key.

    The outputs' values are unknown before the run: ``samples`` sets of them are drawn (a fixed seed;
    either sign, magnitudes 1e-3 to 1e3), half at t = 0 and half at times in [0, ``t_end``]. An
    expression finite for some of them passes; a non-finite value during the run fails the run then."""
    rng = np.random.default_rng(12345)
    half = samples // 2
    env = {s: rng.choice([-1.0, 1.0], samples) * 10.0 ** rng.uniform(-3.0, 3.0, samples)
           for s in expression._order if s != "t"}
    env["t"] = np.concatenate([np.zeros(half), rng.uniform(0.0, max(float(t_end), 0.0), samples - half)])
    names = ", ".join(s for s in expression._order) or "its symbols"
    with np.errstate(all="ignore"):
        for d in _denominators(expression.tree):
            if np.all(np.broadcast_to(_walk(d, env, 0), (samples,)) == 0.0):
                raise ExpressionError(f"{expression.where}: {_quote(expression.text)} divides by "
                                      f"{_unparse(d)}, which is 0 whatever the values of {names}")
        r = np.broadcast_to(np.asarray(_walk(expression.tree, env, 0), dtype=float), (samples,))
    if not np.isfinite(r[:half]).any():
        raise ExpressionError(f"{expression.where}: {_quote(expression.text)} is not finite at t = 0 (the "
                              f"first history row) for any of {half} sampled values of {names}")


def parse_expression(text, where, symbols=("x", "y", "z", "t")) -> "Expression":
    """Parse a scene-file expression (see the module docstring for what is accepted)."""
    if not isinstance(text, str):
        raise ExpressionError(f"{where}: an expression must be a string, got {type(text).__name__}")
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"{where}: expression is {len(text)} characters long (at most {MAX_LENGTH})")
    text = text.strip()
    b = _Builder(text, where, symbols)
    if not text:
        b.fail("empty expression")
    level = 0
    for c in text:          # the parser does not nest parentheses into the AST: bound them here
        level += (c in "([{") - (c in ")]}")
        if level > MAX_DEPTH:
            b.fail(f"expression nests too deeply (more than {MAX_DEPTH} levels of brackets)")
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as exc:
        line = f"line {exc.lineno}, " if (exc.lineno or 1) > 1 else ""
        col = exc.offset if exc.offset else len(text.splitlines()[-1]) + 1
        b.fail(f"does not parse: {exc.msg} at {line}column {col}")
    except (ValueError, RecursionError, MemoryError) as exc:
        b.fail(f"does not parse: {exc}")
    return Expression(text, where, b.build(tree.body), frozenset(b.used), tuple(symbols))


class Expression:
    """A checked expression: ``.text``, ``.symbols`` (those it uses), ``.evaluate``, ``.to_ufl``."""

    def __init__(self, text, where, tree, symbols, order=("x", "y", "z", "t")):
        self.text, self.where, self.tree, self.symbols = text, where, tree, symbols
        self._order = [s for s in order if s in symbols]

    def __repr__(self):
        return f"Expression({self.text!r})"

    def _env(self, given):
        missing = [s for s in self._order if given.get(s) is None]
        if missing:
            raise ExpressionError(f"{self.where}: {_quote(self.text)} uses {', '.join(missing)} "
                                  f"but no value was given for {'it' if len(missing) == 1 else 'them'}")
        return {s: given[s] for s in self._order}

    def evaluate(self, x=None, y=None, z=None, t=None, *, check_finite=True, **others) -> np.ndarray:
        """Values in float64, broadcast over the arrays given for the symbols used.

        With ``check_finite`` a nan or inf result raises, naming the first point that gives it."""
        env = self._env(dict(x=x, y=y, z=z, t=t, **others))
        with np.errstate(all="ignore"):
            try:
                env = {k: np.asarray(v, dtype=float) for k, v in env.items()}
                r = np.asarray(_walk(self.tree, env, 0), dtype=float)
            except ValueError as exc:
                raise ExpressionError(f"{self.where}: cannot evaluate {_quote(self.text)}: {exc}") from None
        bad = ~np.isfinite(r)
        if check_finite and bad.any():
            i = tuple(np.argwhere(bad)[0])
            at = ", ".join(f"{s}={np.broadcast_to(env[s], r.shape)[i]:g}" for s in self._order)
            raise ExpressionError(f"{self.where}: {_quote(self.text)} gives a non-finite value "
                                  f"({r[i]})" + (f" at {at}" if at else ""))
        return r

    def to_ufl(self, x=None, y=None, z=None, t=None, **others):
        """The same expression in UFL of the given UFL arguments (SpatialCoordinate, Constant)."""
        env = self._env(dict(x=x, y=y, z=z, t=t, **others))
        try:
            return ufl.as_ufl(_walk(self.tree, env, 1))
        except (ArithmeticError, ValueError, TypeError) as exc:
            raise ExpressionError(f"{self.where}: {_quote(self.text)} cannot be built in UFL: {exc}") from None


def piecewise_linear(t, knots, values, use_ufl):
    """Piecewise-linear interpolation through (knots, values), constant outside the knots.

    The same formula as ``contact._piecewise``: numpy ``np.interp`` (a float for a scalar t, else
    an array), UFL ``values[0] + sum_k slope_k min(max(t - a_k, 0), b_k - a_k)``."""
    knots = [float(k) for k in knots]
    values = [float(v) for v in values]
    if len(knots) == 1:
        if use_ufl:
            return ufl.as_ufl(values[0])
        return values[0] if np.ndim(t) == 0 else np.full(np.shape(t), values[0])
    if not use_ufl:
        r = np.interp(np.asarray(t, dtype=float), knots, values)
        return float(r) if r.ndim == 0 else r
    out = ufl.as_ufl(values[0])
    for k in range(len(knots) - 1):
        a, b = knots[k], knots[k + 1]
        slope = (values[k + 1] - values[k]) / (b - a)
        if slope != 0.0:
            out = out + slope * ufl.min_value(ufl.max_value(t - a, 0.0), b - a)
    return out


def _numbers(seq, key, name):
    if not isinstance(seq, (list, tuple)):
        raise ExpressionError(f"{key}: expected a list of numbers, got {type(seq).__name__}")
    for i, v in enumerate(seq):
        if _finite(v) is None:
            raise ExpressionError(f"{key}: {name}[{i}] = {v!r} is not a finite number")
    return [float(v) for v in seq]


class Table:
    """Piecewise-linear table of one variable (``.knots``, ``.values``), constant outside."""

    def __init__(self, knots, values, where="table", variable="t"):
        self.where, self.variable = where, variable
        self.knots = _numbers(knots, f"{where}.{variable}", variable)
        self.values = _numbers(values, f"{where}.value", "value")
        if len(self.knots) != len(self.values) or not self.knots:
            raise ExpressionError(f"{where}: a table needs as many values as {variable} (at least one); "
                                  f"got {len(self.knots)} {variable} and {len(self.values)} values")
        k, what = self.knots, "times" if variable == "t" else f"{variable} knots"
        for i in range(1, len(k)):
            if not k[i] > k[i - 1]:
                raise ExpressionError(f"{where}.{variable}: {what} must increase strictly "
                                      f"({variable}[{i}] = {k[i]:g} <= {variable}[{i - 1}] = {k[i - 1]:g})")

    def evaluate(self, t):
        return piecewise_linear(t, self.knots, self.values, use_ufl=False)

    def to_ufl(self, t):
        return piecewise_linear(t, self.knots, self.values, use_ufl=True)


class Value:
    """A constant, a :class:`Table` or an :class:`Expression`, behind one interface."""

    def __init__(self, where, constant=None, expression=None, table=None):
        self.where, self.constant, self.expression, self.table = where, constant, expression, table
        self.symbols = (expression.symbols if expression else
                        frozenset([table.variable]) if table else frozenset())
        self.depends_on_space = bool(self.symbols & set(SPACE))
        self.depends_on_time = "t" in self.symbols

    def describe(self):
        if self.expression:
            return f"expression {_quote(self.expression.text)}"
        if self.table:
            v, k = self.table.variable, self.table.knots
            return f"table of {v} ({len(k)} points, {v} from {k[0]:g} to {k[-1]:g})"
        return f"constant {self.constant:g}"

    __repr__ = describe

    def _table_arg(self, given):
        v = given.get(self.table.variable)
        if v is None:
            raise ExpressionError(f"{self.where}: a table of {self.table.variable} needs a value of it")
        return v

    def evaluate(self, x=None, y=None, z=None, t=None, *, check_finite=True, **others):
        """Values broadcast to the shape of the given x, y, z (a float when that is a scalar)."""
        given = dict(x=x, y=y, z=z, t=t, **others)
        if self.expression:
            r = self.expression.evaluate(**given, check_finite=check_finite)
        elif self.table:
            r = self.table.evaluate(self._table_arg(given))
        else:
            r = self.constant
        shape = np.broadcast_shapes(np.shape(r), *(np.shape(given[s]) for s in SPACE if given[s] is not None))
        r = np.array(np.broadcast_to(r, shape), dtype=float)
        return float(r) if r.ndim == 0 else r

    def check_finite(self, times, x=None, y=None, z=None):
        """ExpressionError naming the key and the first point where the value is not finite, over the
        ``times`` (1-D array) and, for a value of x, y, z, the points given (1-D arrays of coordinates).
        Numbers and tables of numbers are finite: nothing to do."""
        if self.expression is None:
            return
        times = np.asarray(times, dtype=float)
        if not self.depends_on_time:
            times = times[:1]
        if not self.depends_on_space:
            self.expression.evaluate(t=times)
            return
        for t in times:
            self.expression.evaluate(x=x, y=y, z=z, t=t)

    def to_ufl(self, x=None, y=None, z=None, t=None, **others):
        given = dict(x=x, y=y, z=z, t=t, **others)
        if self.expression:
            return self.expression.to_ufl(**given)
        if self.table:
            return self.table.to_ufl(self._table_arg(given))
        return ufl.as_ufl(self.constant)


def parse_value(raw, where, symbols=("x", "y", "z", "t"), table_variable="t") -> Value:
    """A TOML value -> :class:`Value`: a finite number, an expression string, or an inline table
    ``{ t = [...], value = [...] }`` (the first key is ``table_variable``)."""
    if isinstance(raw, (int, float)) and not isinstance(raw, bool):
        if _finite(raw) is None:
            raise ExpressionError(f"{where}: {raw!r} is not a finite number")
        return Value(where, constant=_finite(raw))
    if isinstance(raw, str):
        return Value(where, expression=parse_expression(raw, where, symbols))
    if isinstance(raw, dict):
        expected = {table_variable, "value"}
        if set(raw) != expected:
            wrong = sorted(map(str, set(raw) - expected)) or sorted(expected - set(raw))
            raise ExpressionError(f"{where}: a table takes exactly the keys '{table_variable}' and 'value' "
                                  f"({'unknown' if set(raw) - expected else 'missing'}: {', '.join(wrong)})")
        return Value(where, table=Table(raw[table_variable], raw["value"], where, table_variable))
    shown = repr(raw) if len(repr(raw)) <= 60 else repr(raw)[:57] + "..."
    raise ExpressionError(f"{where}: expected a number, an expression string or a table "
                          f"{{ {table_variable} = [...], value = [...] }}, got {type(raw).__name__} {shown}")
