"""From the ladder's estimates to the final run: the factors each result needs, the setting that
meets every tolerance, what it is predicted to cost, and the error bar of a result at a setting.

Mesh sizes are relative: the scene's own mesh is h = 1, a mesh refined by a factor F has h = 1/F
(F exact on the smallest cell count, :meth:`fenics_plast.accuracy.axes.Axis.exact`). The error bar of a result at a setting is
the sum of its sources' (:mod:`.estimate`):

* the mesh's, from the three-level estimate at that h;
* each probed source's bound at the setting's factor on its axis. In an explicit run the stable
  step shrinks with the cells, so the time step's error is part of what the mesh ladder measures:
  it is reported (its bound at dt proportional to h), not added, and never refined on its own.

The final setting aims every bar at :data:`TARGET` of its tolerance, a probed source taking at most
:data:`SHARE` of it before its axis is refined. Pure functions of numbers: nothing here runs anything.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

from .estimate import MeshEstimate, ProbeEstimate

#: the fraction of a tolerance the final run aims its error bar at (the estimate is itself uncertain)
TARGET = 0.8
#: the fraction of a tolerance a probed source (time, contact) may take before its axis is refined
SHARE = 0.2


def round_up(x: float, digits: int = 2) -> float:
    """``x`` rounded up to ``digits`` significant digits (2.27 -> 2.3)."""
    if x <= 0.0:
        return x
    e = math.floor(math.log10(x)) - digits + 1
    step = 10.0 ** e
    return round(math.ceil(x / step - 1e-9) * step, 12)


@dataclass
class Need:
    """What one result needs: ``factors`` {axis: factor}; ``refusal``: why none can be given, and
    ``axis``: the source that refused."""
    factors: dict[str, float] = field(default_factory=dict)
    refusal: str | None = None
    axis: str = "mesh"


def need(tolerance: float, mesh: MeshEstimate, probes: dict[str, ProbeEstimate], explicit: bool) -> Need:
    """The factors that bring one result's bar within ``TARGET`` x ``tolerance`` (absolute)."""
    if not mesh.ok:
        return Need(refusal=mesh.note)
    out = Need()
    left = TARGET * tolerance
    for axis, probe in probes.items():
        if explicit and axis == "time":
            continue
        if probe.ladder is not None and not probe.ladder.ok:
            return Need(refusal=f"the {axis} probes: {probe.ladder.note}", axis=axis)
        f = probe.factor_for(SHARE * tolerance)
        if not math.isfinite(f):
            return Need(refusal=f"the {axis} probes: {probe.ladder.note}; their bar {probe.bound:.4g} exceeds "
                                f"the tolerance's share {SHARE * tolerance:.4g} at any setting", axis=axis)
        out.factors[axis] = f
        left -= probe.bound_at(f)
    h = mesh.size_for(left)
    if h is None:
        out.refusal = (f"{mesh.note}; the bar {mesh.bar:.4g} exceeds the tolerance's share {left:.4g}: no mesh "
                       f"is predicted to meet it")
        return out
    out.factors["mesh"] = max(1.0, 1.0 / h)
    return out


def final_factors(needs: list[Need], finest: float, exact: Callable[..., float]) -> dict[str, float]:
    """The setting that meets every need: each axis's largest factor, rounded up (the mesh's by
    ``exact(factor, up=True)``, the others' to two digits); the mesh at least at the ladder's ``finest``
    factor (its run is made: a coarser final would waste it)."""
    out: dict[str, float] = {"mesh": finest}
    for n in needs:
        for axis, f in n.factors.items():
            out[axis] = max(out.get(axis, 1.0), f)
    for axis, f in out.items():
        if axis == "mesh":
            out[axis] = finest if f <= finest * (1 + 1e-9) else exact(f, up=True)
        else:
            out[axis] = 1.0 if f < 1.05 else round_up(f)
    return out


def bar_parts(mesh_bar: float, probes: dict[str, ProbeEstimate], factors: dict[str, float], explicit: bool,
              h: float) -> tuple[float, dict[str, float]]:
    """(the error bar, {source: its part}) of a result at ``factors`` with mesh size ``h``; the parts
    include an explicit run's time step (``time_in_mesh``), which the bar does not add."""
    parts = {"mesh": mesh_bar}
    total = mesh_bar
    for axis, probe in probes.items():
        if explicit and axis == "time":
            parts["time_in_mesh"] = probe.bound * h ** probe.order
            continue
        parts[axis] = probe.bound_at(factors.get(axis, 1.0))
        total += parts[axis]
    return total, parts


def predicted_cost(walls: tuple[float, float], factors: tuple[float, float], factor: float,
                   time_factor: float) -> tuple[float, float]:
    """(the predicted wall time of a run at mesh ``factor`` and ``time_factor``, the cost exponent k) from
    two ladder levels' wall times at mesh ``factors``: wall ~ factor^k x time_factor, k >= 1."""
    (w1, w2), (f1, f2) = walls, factors
    k = math.log(max(w2, 1e-6) / max(w1, 1e-6)) / math.log(f2 / f1)
    k = max(k, 1.0)
    return w2 * (factor / f2) ** k * time_factor, k


def predicted_memory(memories: tuple[float, float], cells: tuple[float, float], cells_final: float) -> float:
    """The predicted peak memory (MB) at ``cells_final`` cells from two levels': linear in the cells."""
    (m1, m2), (c1, c2) = memories, cells
    slope = max((m2 - m1) / (c2 - c1), 0.0) if c2 != c1 else 0.0
    return m2 + slope * (cells_final - c2)
