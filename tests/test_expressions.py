"""Safe scene-file values (fenics_plast.expressions): expressions, tables, constants.

Closed-form values, numpy broadcasting, UFL == numpy on a unit square, tables (and their identity
against np.interp and in UFL at mesh points), and the refusals: every message names the scene key and the culprit.
"""
from __future__ import annotations

import builtins
import math
import time

import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx import mesh as dm
from mpi4py import MPI
from petsc4py import PETSc

from fenics_plast import dolfinx_compat as dc
from fenics_plast.expressions import (ExpressionError, Expression, FUNCTIONS, Table, Value, check_output_expression,
                                      check_times, parse_expression, parse_value, piecewise_linear)

W = "boundary.top.value"
PTS = np.array([[0.2, 0.3], [0.6, 0.1], [1 / 3, 1 / 3], [0.9, 0.05]])   # reference points


@pytest.fixture(scope="module")
def square():
    """(mesh, SpatialCoordinate, cells, physical coordinates (ncells, npts, 2)) of a 2x2 square."""
    m = dm.create_unit_square(MPI.COMM_SELF, 2, 2)
    X = ufl.SpatialCoordinate(m)
    cells = np.arange(m.topology.index_map(2).size_local, dtype=np.int32)
    xy = dc.eval_expression(fem.Expression(X, PTS), m, cells).reshape(len(cells), len(PTS), 2)
    return m, X, cells, xy


def ufl_values(m, expr, cells):
    return dc.eval_expression(fem.Expression(expr, PTS), m, cells).reshape(len(cells), len(PTS))


# ---------------------------------------------------------------------------------------------
# accepted expressions


@pytest.mark.parametrize("text, args, expected", [
    ("2*x + 3*t**2", dict(x=0.5, t=2.0), 13.0),
    ("sqrt(x**2+y**2)", dict(x=3.0, y=4.0), 5.0),
    ("atan2(y, x)", dict(x=-1.0, y=1.0), 0.75 * math.pi),
    ("pi", {}, math.pi),
    ("-e + +2", {}, 2.0 - math.e),
    ("7/2", {}, 3.5),
    ("2**-1 * 4", {}, 2.0),
    ("min(x, 1) + max(y, 1)", dict(x=3.0, y=-2.0), 2.0),
    ("log(exp(z)) + abs(-t)", dict(z=1.5, t=2.0), 3.5),
    ("sinh(x) - cosh(x) + tanh(0)", dict(x=0.3), -math.exp(-0.3)),
    ("sin(x)**2 + cos(x)**2 + tan(0) + asin(1) - acos(0) + atan(1)", dict(x=0.7), 1.0 + math.pi / 4),
    ("  1e-3 * x  ", dict(x=2000.0), 2.0),
])
def test_closed_form(text, args, expected):
    e = parse_expression(text, W)
    assert isinstance(e, Expression)
    assert e.text == text.strip()
    assert e.symbols == frozenset(args)
    r = e.evaluate(**args)
    assert isinstance(r, np.ndarray) and r.shape == ()
    assert float(r) == pytest.approx(expected, rel=1e-14, abs=1e-14)


def test_broadcasting():
    e = parse_expression("x + 10*y + 100*t", W)
    r = e.evaluate(x=np.array([[1.0], [2.0], [3.0]]), y=np.array([0.0, 1.0, 2.0, 3.0]), t=1.0)
    assert r.shape == (3, 4)
    assert r[2, 3] == 3.0 + 30.0 + 100.0 and r[0, 0] == 101.0
    x = np.linspace(0, 1, 7)
    np.testing.assert_allclose(parse_expression("sin(pi*x)", W).evaluate(x=x), np.sin(np.pi * x))
    # a time-only expression ignores x, a Value broadcasts it to the points
    assert parse_expression("2*t", W).evaluate(x=x, t=3.0).shape == ()
    np.testing.assert_array_equal(parse_value("2*t", W).evaluate(x=x, t=3.0), np.full(7, 6.0))
    with pytest.raises(ExpressionError, match=W):
        e.evaluate(x=np.zeros(3), y=np.zeros(4), t=0.0)   # shapes that do not broadcast


def test_missing_symbol_at_evaluation():
    e = parse_expression("x*t", W)
    with pytest.raises(ExpressionError) as err:
        e.evaluate(x=1.0)
    assert W in str(err.value) and "uses t" in str(err.value)
    with pytest.raises(ExpressionError, match="uses x, t"):
        e.to_ufl()


def test_other_symbols_and_constants_pi_e():
    e = parse_expression("2*lam + pi", W, symbols=("lam",))
    assert e.symbols == frozenset({"lam"})
    assert float(e.evaluate(lam=1.0)) == pytest.approx(2 + math.pi)
    with pytest.raises(ExpressionError, match=r"unknown symbol 'x'.*allowed: lam"):
        parse_expression("x", W, symbols=("lam",))


def test_no_eval_or_exec(monkeypatch):
    def boom(*a, **k):
        raise AssertionError("eval/exec called")
    monkeypatch.setattr(builtins, "eval", boom)
    monkeypatch.setattr(builtins, "exec", boom)
    assert float(parse_expression("1 + 2*x", W).evaluate(x=1.0)) == 3.0


def test_literals_are_floats():
    def nums(node):
        if isinstance(node, tuple) and node and node[0] == "num":
            yield node[1]
        elif isinstance(node, tuple):
            for child in node:
                yield from nums(child)
    found = list(nums(parse_expression("x**100 + max(3, x) - 7", W).tree))
    assert sorted(found) == [3.0, 7.0, 100.0]
    assert all(type(v) is float for v in found)
    # a part without symbols is computed once, in floats (2**100 is not a huge-integer computation)
    assert parse_expression("2**100 * x", W).tree == ("*", ("num", 2.0 ** 100), ("sym", "x"))


def test_non_finite_is_reported_and_can_be_allowed():
    t0 = time.perf_counter()
    e = parse_expression("9**9**t", W)
    with pytest.raises(ExpressionError) as err:
        e.evaluate(t=9.0)
    assert time.perf_counter() - t0 < 1.0
    assert W in str(err.value) and "9**9**t" in str(err.value) and "non-finite" in str(err.value)
    assert e.evaluate(t=9.0, check_finite=False) == np.inf
    e = parse_expression("1/x + t", W)
    with pytest.raises(ExpressionError, match=r"non-finite value \(inf\) at x=0, t=3"):
        e.evaluate(x=[1.0, 0.0, 2.0], t=3.0)
    with pytest.raises(ExpressionError, match=r"at x=-1"):
        parse_expression("sqrt(x)", W).evaluate(x=np.array([4.0, -1.0]))
    np.testing.assert_array_equal(e.evaluate(x=[1.0, 0.0], t=0.0, check_finite=False), [1.0, np.inf])


# ---------------------------------------------------------------------------------------------
# UFL == numpy


def test_ufl_matches_numpy(square):
    m, X, cells, xy = square
    t = fem.Constant(m, PETSc.ScalarType(0.7))
    text = ("sin(x)+cos(y)+tan(x)+asin(x/2)+acos(y/2)+atan(x)+atan2(y, x+1)+sinh(x)+cosh(y)"
            "+tanh(x)+sqrt(1+x)+exp(-y)+log(1+x)+abs(x-0.5)+min(x, y)+max(x, y)+x**2.5-3/(1+t)+pi*e")
    e = parse_expression(text, W)
    assert {n for n in FUNCTIONS if n + "(" in text} == set(FUNCTIONS)   # every function is used
    compiled = fem.Expression(e.to_ufl(x=X[0], y=X[1], t=t), PTS)
    for tv in (0.7, 2.5):
        t.value = tv
        u = dc.eval_expression(compiled, m, cells).reshape(xy.shape[:2])
        np.testing.assert_allclose(u, e.evaluate(x=xy[..., 0], y=xy[..., 1], t=tv), rtol=1e-13, atol=1e-13)


def test_value_ufl_matches_numpy(square):
    m, X, cells, xy = square
    t = fem.Constant(m, PETSc.ScalarType(1.5))
    v = parse_value("2*x + 3*t**2 - y", W)
    u = ufl_values(m, v.to_ufl(x=X[0], y=X[1], t=t), cells)
    np.testing.assert_allclose(u, v.evaluate(x=xy[..., 0], y=xy[..., 1], t=1.5), rtol=1e-14)
    # a division by the number 0 (which UFL cannot build) is refused when the expression is read
    with pytest.raises(ExpressionError, match=r"'1/0' is not finite \(it computes to inf\) at column 1"):
        parse_expression("1/0 + x", W)


# ---------------------------------------------------------------------------------------------
# tables


def test_table_values():
    tb = Table([0.0, 1.0, 3.0], [0.0, 2.0, 1.0], W)
    assert [tb.evaluate(k) for k in (0.0, 1.0, 3.0)] == [0.0, 2.0, 1.0]        # at the knots
    assert tb.evaluate(0.25) == 0.5 and tb.evaluate(2.0) == 1.5               # between
    assert tb.evaluate(-5.0) == 0.0 and tb.evaluate(9.0) == 1.0               # constant outside
    np.testing.assert_array_equal(tb.evaluate(np.array([-1.0, 0.5, 2.0, 4.0])), [0.0, 1.0, 1.5, 1.0])
    one = Table([2.0], [4.0], W)
    assert one.evaluate(-3.0) == 4.0 and one.evaluate(7.0) == 4.0
    np.testing.assert_array_equal(one.evaluate(np.zeros(3)), [4.0, 4.0, 4.0])


def test_table_ufl_matches_numpy(square):
    m, X, cells, xy = square
    tb = Table([0.0, 1.0, 3.0], [0.0, 2.0, 1.0], W)
    c = fem.Constant(m, PETSc.ScalarType(0.0))
    compiled = fem.Expression(tb.to_ufl(c) + 0 * X[0], PTS)
    for tv in (-1.0, 0.0, 0.3, 1.0, 2.2, 3.0, 5.0):
        c.value = tv
        np.testing.assert_allclose(dc.eval_expression(compiled, m, cells), tb.evaluate(tv), rtol=1e-14, atol=1e-15)
    # a table over x (space) through parse_value
    v = parse_value({"x": [0.0, 0.5, 1.0], "value": [1.0, -1.0, 3.0]}, W, table_variable="x")
    assert v.depends_on_space and not v.depends_on_time
    np.testing.assert_allclose(ufl_values(m, v.to_ufl(x=X[0]), cells), v.evaluate(x=xy[..., 0]), rtol=1e-14)


def test_piecewise_linear_is_np_interp_with_constant_ends():
    """contact.py's tool paths use piecewise_linear; numpy side: np.interp (constant outside)."""
    rng = np.random.default_rng(7)
    for n in (1, 2, 3, 6):
        knots = np.cumsum(rng.uniform(0.1, 1.0, n)) - 1.0
        values = rng.normal(size=n)
        for lam in rng.uniform(knots[0] - 1, knots[-1] + 1, 20).tolist() + knots.tolist():
            expect = values[0] if n == 1 else np.interp(lam, knots, values)
            assert piecewise_linear(lam, knots, values, False) == pytest.approx(expect, rel=1e-14, abs=1e-14)
    many = rng.uniform(-2, 4, 50)
    np.testing.assert_allclose(piecewise_linear(many, [0, 1, 2], [1, 3, 0], False),
                               np.interp(many, [0, 1, 2], [1, 3, 0]), rtol=1e-14)


# ---------------------------------------------------------------------------------------------
# parse_value: one interface


def test_value_forms(square):
    m, X, cells, xy = square
    c = parse_value(3, W)
    assert isinstance(c, Value) and c.constant == 3.0 and not c.depends_on_space and not c.depends_on_time
    assert c.evaluate() == 3.0 and isinstance(c.evaluate(), float)
    np.testing.assert_array_equal(c.evaluate(x=np.zeros((2, 3))), np.full((2, 3), 3.0))
    assert float(c.to_ufl()) == 3.0 and "3" in c.describe()
    tb = parse_value({"t": [0, 1], "value": [0.0, 10]}, W)
    assert tb.constant is None and tb.depends_on_time and not tb.depends_on_space
    assert tb.evaluate(t=0.5) == 5.0 and tb.evaluate(x=np.zeros(4), t=0.5).shape == (4,)
    assert "table of t" in tb.describe() and "2 points" in tb.describe()
    with pytest.raises(ExpressionError, match=f"{W}: a table of t needs a value"):
        tb.evaluate()
    ex = parse_value("x*t", W)
    assert ex.constant is None and ex.depends_on_space and ex.depends_on_time
    assert '"x*t"' in ex.describe()
    np.testing.assert_array_equal(ex.evaluate(x=np.array([1.0, 2.0]), t=2.0), [2.0, 4.0])


# ---------------------------------------------------------------------------------------------
# refusals: the message names the key and the culprit


@pytest.mark.parametrize("text, culprit", [
    ("__import__('os')", "'__import__'"),
    ("().__class__", "attribute access '().__class__'"),
    ("x.real", "attribute access 'x.real'"),
    ("open('f')", "unknown function 'open' at column 1 in \"open('f')\" (allowed: sin, cos"),
    ("lambda: 1", "lambda 'lambda: 1'"),
    ("x if t else y", "conditional expression 'x if t else y'"),
    ("x < y", "comparison 'x < y'"),
    ("x and y", "boolean operator 'x and y'"),
    ("[1][0]", "indexing '[1][0]'"),
    ("[x for x in (1, 2)]", "comprehension"),
    ("f'{x}'", "f-string"),
    ('"a"', "string \"a\""),
    ("True", "boolean True"),
    ("1j", "complex number 1j"),
    ("None", "None"),
    ("max(x)", "max takes 2 arguments, got 1"),
    ("sin(x, y)", "sin takes 1 argument, got 2"),
    ("sin(x=1)", "keyword argument 'x=1'"),
    ("max(*x)", "starred argument '*x'"),
    ("x // 2", "operator '//'"),
    ("not x", "operator 'not'"),
    ("sin", "function 'sin' used without a call"),
    ("q*2", "unknown symbol 'q' at column 1 in \"q*2\" (allowed: x, y, z, t)"),
    ("__builtins__", "dunder name '__builtins__'"),
    ("1e999", "number 1e999 is not finite"),
    ("2 +", "does not parse: invalid syntax at column 4"),
    ("", "empty expression"),
    ("x" * 501, "501 characters long (at most 500)"),
    ("(" * 100 + "x" + ")" * 100, "nests too deeply"),
    ("-" * 100 + "x", "nests too deeply"),
    ("x" + "**x" * 41, "nests too deeply (more than 40 levels)"),
    ("x + " + "-" * 40 + "x", "nests too deeply (more than 40 levels)"),
    # a part without symbols is computed when the expression is read, and must be finite
    ("9**9**9", "'9**9**9' is not finite (it computes to inf) at column 1"),
    ("10**400", "'10**400' is not finite (it computes to inf)"),
    ("1e308*10*t", "'1e308*10' is not finite (it computes to inf) at column 1"),
    ("x + log(0)", "'log(0)' is not finite (it computes to -inf) at column 5"),
    ("t * sqrt(-1)", "'sqrt(-1)' is not finite (it computes to nan) at column 5"),
])
def test_refused(text, culprit):
    with pytest.raises(ExpressionError) as err:
        parse_expression(text, W)
    msg = str(err.value)
    assert msg.startswith(W + ": ") and culprit in msg


def test_refused_non_string():
    with pytest.raises(ExpressionError, match=f"{W}: an expression must be a string, got int"):
        parse_expression(3, W)


@pytest.mark.parametrize("raw, message", [
    ({"t": [0.0, 0.5, 0.5], "value": [1, 2, 3]},
     f"{W}.t: times must increase strictly (t[2] = 0.5 <= t[1] = 0.5)"),
    ({"t": [0.0, 1.0], "value": [1.0, float("nan")]}, f"{W}.value: value[1] = nan is not a finite number"),
    ({"t": [0.0, True], "value": [1, 2]}, f"{W}.t: t[1] = True is not a finite number"),
    ({"t": [0.0, 1.0, 2.0], "value": [1, 2]}, "got 3 t and 2 values"),
    ({"t": [], "value": []}, "at least one"),
    ({"t": "0, 1", "value": [1, 2]}, f"{W}.t: expected a list of numbers, got str"),
    ({"t": [0.0], "value": [1.0], "unit": "mm"}, "exactly the keys 't' and 'value' (unknown: unit)"),
    ({"value": [1.0]}, "(missing: t)"),
    (True, "expected a number, an expression string or a table { t = [...], value = [...] }, got bool"),
    ([1, 2], "got list [1, 2]"),
    (None, "got NoneType"),
    (float("inf"), "inf is not a finite number"),
])
def test_refused_values(raw, message):
    with pytest.raises(ExpressionError) as err:
        parse_value(raw, W)
    assert str(err.value).startswith(W) and message in str(err.value)


def test_expression_error_is_value_error():
    assert issubclass(ExpressionError, ValueError)
    with pytest.raises(ValueError):
        parse_value("x.y", W)


# ---------------------------------------------------------------------------------------------
# issue 21: nesting depth, checks before the run


def test_nesting_depth_counts_levels_not_terms(square):
    """A flat sum or product of many terms is one level (it was refused as "nesting deeper than 40
    levels" at 41 terms); numpy and UFL give its value."""
    m, X, cells, xy = square
    for op, n in (("+", 200), ("-", 200), ("*", 150), ("/", 150)):
        text = op.join(["x"] * n)
        e = parse_expression(text, W)
        x = np.array([0.5, 1.0, 2.0])
        expected = {"+": n * x, "-": (2 - n) * x, "*": x ** n, "/": x ** (2 - n)}[op]
        np.testing.assert_allclose(e.evaluate(x=x), expected, rtol=1e-12)
    u = ufl_values(m, parse_expression("+".join(["x"] * 200), W).to_ufl(x=X[0]), cells)
    np.testing.assert_allclose(u, 200 * xy[..., 0], rtol=1e-13)
    # brackets, calls, signs and powers still open a level each
    parse_expression("sin(" * 39 + "x" + ")" * 39, W)
    with pytest.raises(ExpressionError, match="nests too deeply"):
        parse_expression("sin(" * 41 + "x" + ")" * 41, W)


def test_value_check_finite_over_times_and_points():
    """Value.check_finite: over the analysis's times (check_times) and, for values of x, y, z, over the
    points given; the message names the key and the first point."""
    times = check_times(1.0)
    assert times[0] == 0.0 and times[-1] == 1.0 and len(times) == 65
    parse_value("exp(10*t)", W).check_finite(times)
    parse_value(3.0, W).check_finite(times)
    parse_value({"t": [0, 1], "value": [0, 2]}, W).check_finite(times)
    with pytest.raises(ExpressionError, match=rf'^{W}: "log\(t\)" gives a non-finite value \(-inf\) at t=0$'):
        parse_value("log(t)", W).check_finite(times)
    with pytest.raises(ExpressionError, match=r"\(inf\) at t=0.71875"):
        parse_value("exp(1000*t)", W).check_finite(times)
    x = np.array([200.0, 150.0, 50.0])
    parse_value("sqrt(x - 100) * t", W).check_finite(times, x=x[:2], y=x[:2], z=x[:2])
    with pytest.raises(ExpressionError, match=r"\(nan\) at x=50"):
        parse_value("sqrt(x - 100)", W).check_finite(times, x=x, y=x, z=x)


@pytest.mark.parametrize("text, message", [
    ("force/(elongation - elongation)", "divides by (elongation - elongation), which is 0 whatever the values"),
    ("force * elongation / (t - t)", "divides by (t - t)"),
    ("log(t) + force", "is not finite at t = 0 (the first history row) for any of 32 sampled values"),
    ("1/t", "is not finite at t = 0"),
    ("sqrt(-1 - force**2)", "is not finite at t = 0"),
])
def test_output_expression_refused_before_the_run(text, message):
    e = parse_expression(text, "outputs.ratio.expression", symbols=("t", "force", "elongation"))
    with pytest.raises(ExpressionError) as err:
        check_output_expression(e, 1.0)
    assert str(err.value).startswith("outputs.ratio.expression: ") and message in str(err.value)


@pytest.mark.parametrize("text", ["force / elongation", "sqrt(force)", "log(force) + t", "force / (elongation - 1)",
                                  "1 / (t - 0.5)", "t"])
def test_output_expression_that_may_be_finite_passes(text):
    """What can be finite for some values of the outputs is left to the run (a non-finite value then
    fails the run with exit 1 and the key)."""
    check_output_expression(parse_expression(text, "o", symbols=("t", "force", "elongation")), 2.0)
