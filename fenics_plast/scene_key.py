"""One scene key's declaration: :class:`Key` (type, default, range or choices, unit, meaning, the table
variants it applies to) and the :data:`REQUIRED` / :data:`OPTIONAL` default markers.

Its own module so that the tables of :mod:`fenics_plast.schema` and the declarations it gathers from
registries (the output quantities, :mod:`fenics_plast.quantities.kinds`) both build on it without an
import circle. Standard library only.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

__all__ = ["Key", "Marker", "REQUIRED", "OPTIONAL", "number_text"]


class Marker:
    """A default that is not a value: REQUIRED or OPTIONAL."""

    def __init__(self, name: str):
        self.name = name

    def __repr__(self) -> str:
        return self.name


REQUIRED = Marker("REQUIRED")   # must be given
OPTIONAL = Marker("OPTIONAL")   # may be omitted; then the attribute is None

@dataclass(frozen=True)
class Key:
    """One scene key. ``when`` = {discriminator key: allowed values} restricts it to table variants
    (e.g. {"type": ("static",)}); ``when_analysis`` restricts it to analysis types."""
    type: str                       # str | int | float | bool | floats | strs | vector | values | segments | path
    default: Any                    # a value, REQUIRED or OPTIONAL
    doc: str
    unit: str = ""
    choices: tuple | None = None
    lo: float | None = None
    lo_open: bool = True
    hi: float | None = None
    hi_open: bool = True
    when: dict | None = None
    when_analysis: tuple | None = None
    scale: float = 1.0              # file units -> internal units; the value as written stays in <name>_as_written
    analysis_default: dict | None = None   # {analysis type: default} when the default depends on it
    #: a discretisation or solver setting that orders runs from coarse to fine (``fenics-plast study``): +1
    #: a larger value is finer, -1 a smaller one, 0 one that orders nothing (a grading); None: the problem
    #: itself (a material, a load), which changes the answer rather than its accuracy
    refines: int | None = None
    #: the error source a discretisation setting controls, refined together by ``fenics-plast run
    #: --accuracy``: "mesh", "time" or "contact" (the penalty's compliance); None: not refined by it
    axis: str | None = None

    def range_text(self, name: str) -> str:
        lo = None if self.lo is None else f"{number_text(self.lo)} {'<' if self.lo_open else '<='} "
        hi = None if self.hi is None else f" {'<' if self.hi_open else '<='} {number_text(self.hi)}"
        if lo and hi:
            return f"{lo}{name}{hi}"
        if lo:
            return f"{name} {'>' if self.lo_open else '>='} {number_text(self.lo)}"
        if hi:
            return f"{name}{hi}"
        return ""

    def in_range(self, v: float) -> bool:
        """Whether ``v`` lies in the declared range (NaN lies in no bounded range)."""
        above = self.lo is None or (v > self.lo if self.lo_open else v >= self.lo)
        return above and (self.hi is None or (v < self.hi if self.hi_open else v <= self.hi))


def number_text(x) -> str:
    """A number as a scene file would write it (400.0 -> "400", 0.25 -> "0.25")."""
    if isinstance(x, float) and x.is_integer() and abs(x) < 1e15:
        return str(int(x))
    return repr(x) if isinstance(x, float) else str(x)
