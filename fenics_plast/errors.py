"""Exceptions shared between runners, solvers and the CLI, and the messages solvers give them in
their own terms (:class:`Message`: text and the solver's arguments, :class:`Arg`), which a driver words
in the scene's (:class:`Terms`).
"""
from __future__ import annotations


class RunError(RuntimeError):
    """A run failed for a reason the user should read (no convergence, unstable time step, ...).

    The CLI prints the message, writes summary.json with ``converged = false`` and the message,
    keeps history.csv, and exits with status 1. Runners may attach partial results in
    ``results`` (a dict merged into summary.json).
    """

    def __init__(self, message, results: dict | None = None):
        super().__init__(message)
        self.results = dict(results or {})

    def worded(self, terms: "Terms") -> str:
        """The message in ``terms`` (a :class:`Message` from a solver: in the driver's words)."""
        m = self.args[0] if self.args else ""
        return m.worded(terms) if isinstance(m, Message) else str(m)

    def reword(self, terms: "Terms") -> "RunError":
        """This error, its message now in ``terms`` (a driver re-raises it so)."""
        self.args = (self.worded(terms),) + self.args[1:]
        return self


class SceneError(ValueError):
    """A scene file (or a ``--set`` override) is invalid. The message names the file and key; the
    CLI prints it and exits with status 2 before anything is written."""


class Arg:
    """A solver argument named in a :class:`Message`: the solver writes the message in its own terms
    (the argument's name, values in its units), the driver words it in the scene's (:class:`Terms`).

    ``form``: "name" (the argument), "value" (name = value unit), "amount" (value unit), "set" (how to
    set it to ``value``; ``digits``: rounded to that many significant digits in the unit shown) or
    "unit" (the unit of its values). ``unit``: the solver's unit of ``value``; ``fmt``: its format."""

    __slots__ = ("name", "value", "unit", "form", "fmt", "digits")

    def __init__(self, name: str, value=None, unit: str = "", form: str = "name", fmt: str = "g",
                 digits: int | None = None):
        self.name, self.value, self.unit, self.form, self.fmt, self.digits = name, value, unit, form, fmt, digits

    def __repr__(self) -> str:
        return f"Arg({self.name!r}, {self.value!r}, form={self.form!r})"


class Terms:
    """How a :class:`Message` words the arguments in it. This base is the solver's own wording: the
    argument's name, its values in the solver's units, ``name=value`` to set one. A driver words them
    in its own terms by overriding :meth:`name`, :meth:`scale_unit` and :meth:`setting`."""

    def name(self, arg: Arg) -> str:
        return arg.name

    def scale_unit(self, arg: Arg) -> tuple[float, str]:
        """(the factor from the unit shown to the solver's, the unit shown) of ``arg``'s values."""
        return 1.0, arg.unit

    def setting(self, arg: Arg, value: str) -> str:
        return f"{self.name(arg)}={value}"

    def word(self, arg: Arg) -> str:
        if arg.form == "name":
            return self.name(arg)
        scale, unit = self.scale_unit(arg)
        if arg.form == "unit":
            return unit
        v = arg.value
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            if scale != 1.0:
                v = v / scale
            if arg.digits is not None:
                v = float(f"{v:.{arg.digits}g}")
            text = f"{v:{arg.fmt}}"
        else:
            text = str(v)
        if arg.form == "set":
            return self.setting(arg, text)
        amount = f"{text} {unit}" if unit else text
        return amount if arg.form == "amount" else f"{self.name(arg)} = {amount}"


class Message:
    """A message in pieces, text and :class:`Arg`: ``str()`` words it in the solver's terms,
    :meth:`worded` in a driver's (:class:`Terms`). Pieces may be Messages or lists of pieces."""

    def __init__(self, *pieces):
        self.pieces = []
        for p in pieces:
            if isinstance(p, Message):
                self.pieces += p.pieces
            elif isinstance(p, (list, tuple)):
                self.pieces += Message(*p).pieces
            else:
                self.pieces.append(p)

    def worded(self, terms: Terms) -> str:
        return "".join(p if isinstance(p, str) else terms.word(p) for p in self.pieces)

    def __str__(self) -> str:
        return self.worded(Terms())

    def __add__(self, other):
        return Message(self, other)

    def __radd__(self, other):
        return Message(other, self)
