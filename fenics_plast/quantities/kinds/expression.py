"""expression: a value computed from t and the other one-column outputs declared before it (its
column is the output's name as written)."""
from __future__ import annotations

from fenics_plast.scene_key import REQUIRED, Key

NAME, ORDER = "expression", 100
DOC = ("expression: a value computed from other outputs (its column is the output's name as written: put "
       "the unit in the name, e.g. pressure_MPa)")
TAKES = ()
DERIVED = True         # computed from other outputs: later expressions only may name it
KEYS = {
    "expression": Key("str", REQUIRED, "An expression (see [boundary] values) of t and of the names "
                      "of other one-column outputs declared before it, each in its column's unit."),
}


def columns(name, o):
    return [name]


def check(d, o, ctx, fail):
    from fenics_plast.expressions import ExpressionError, check_output_expression, parse_expression
    try:
        e = parse_expression(o.expression, f"{d}.expression", symbols=("t",) + tuple(ctx["symbols"]))
        check_output_expression(e, ctx["end"])
    except ExpressionError as e:
        fail(str(e))


def setup(name, o, q):
    from fenics_plast.expressions import parse_expression
    symbols = ("t",) + tuple(n for n, cols in q.columns.items() if len(cols) == 1)
    q.expressions[name] = parse_expression(o.expression, f"outputs.{name}.expression", symbols)


def value(name, o, q, time, row):
    return [float(q.expressions[name].evaluate(t=time, **row))]
