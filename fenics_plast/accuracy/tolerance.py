"""A tolerance a user states on a result: ``--accuracy radius_mm=0.5%`` (relative),
``--accuracy radius_mm=0.02`` (absolute, in the result's unit) or ``--accuracy 1%`` (every key result
of the scene, its outputs with ``key = true``)."""
from __future__ import annotations

import math
from dataclasses import dataclass


class AccuracyError(ValueError):
    """Bad ``--accuracy`` arguments or scene (exit status 2, nothing run)."""


@dataclass(frozen=True)
class Tolerance:
    """``key``: the summary.json key (None: every key result); ``value``: a fraction when
    ``relative`` (0.005 for 0.5 %), else in the result's unit."""
    key: str | None
    value: float
    relative: bool

    def absolute(self, reference: float) -> float:
        """The tolerance in the result's unit, relative ones taken of ``|reference|``."""
        return self.value * abs(reference) if self.relative else self.value

    @property
    def text(self) -> str:
        return f"{self.value * 100:g} %" if self.relative else f"{self.value:g}"


def parse_tolerance(text: str) -> Tolerance:
    """``"radius_mm=0.5%"``, ``"radius_mm=0.02"`` or ``"1%"``; AccuracyError if malformed."""
    key, _, value = text.rpartition("=")
    key = key.strip() or None
    value = value.strip()
    relative = value.endswith("%")
    try:
        x = float(value[:-1] if relative else value)
    except ValueError:
        raise AccuracyError(f"--accuracy {text!r}: the tolerance must be a number, or a percentage such as "
                            f"0.5%") from None
    if not (math.isfinite(x) and x > 0.0):
        raise AccuracyError(f"--accuracy {text!r}: the tolerance must be > 0")
    if relative and x >= 100.0:
        raise AccuracyError(f"--accuracy {text!r}: a relative tolerance must be below 100 %")
    if key is None and not relative:
        raise AccuracyError(f"--accuracy {text!r}: a tolerance for every key result must be relative (1%); "
                            f"name the result for an absolute one (radius_mm=0.02)")
    return Tolerance(key, x / 100.0 if relative else x, relative)


def expand(tolerances: list[Tolerance], declared: list[str], key_results: list[str]) -> dict[str, Tolerance]:
    """{summary key: its tolerance}: a keyless tolerance applies to every key result; a named one
    overrides it. AccuracyError naming the result when it is not among the ``declared`` summary keys
    of the scene's outputs."""
    out: dict[str, Tolerance] = {}
    for t in tolerances:
        if t.key is None:
            if not key_results:
                raise AccuracyError("--accuracy with no result named: the scene declares no key result (an "
                                    "output with key = true); name one: --accuracy RESULT=1%")
            for k in key_results:
                out.setdefault(k, Tolerance(k, t.value, t.relative))
    for t in tolerances:
        if t.key is not None:
            if t.key not in declared:
                raise AccuracyError(f"--accuracy {t.key}: no such result; the scene's outputs give "
                                    + ", ".join(declared))
            out[t.key] = t
    return out
