"""From the ladder's estimates to the final run: the factors each result needs, the setting that
meets every tolerance, what it is predicted to cost, and the error bar of a result at a setting.

Mesh sizes are relative: the scene's own mesh is h = 1, a mesh refined by a factor F has h = 1/F
(F exact on the smallest cell count, :meth:`fenics_plast.accuracy.axes.Axis.exact`). The error bar of
a result at a setting is the sum of its sources' (:mod:`.estimate`):

* the mesh's, from the three-level estimate at that h;
* each probed source's bound at the setting's factor on its axis. In an explicit run the stable
  step shrinks with the cells, so the time step's error is part of what the mesh ladder measures:
  it is reported (its bound at dt proportional to h), not added, and never refined on its own.

The final setting aims every bar at :data:`TARGET` of its tolerance, split between the sources so
that the run costs least (:func:`need`). Pure functions of numbers: nothing here runs anything.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Callable

from .estimate import MeshEstimate, ProbeEstimate

#: the fraction of a tolerance the final run aims its error bar at (the estimate is itself uncertain)
TARGET = 0.8
#: the fraction of a tolerance above which a probed source's order is measured, not assumed
#: (:func:`fenics_plast.accuracy.probes.axes_to_measure`)
SHARE = 0.2
#: the shares of a tolerance a probed source (time, contact) may take, tried in turn: the split of a
#: tolerance between the sources whose run costs least wins
SHARES = (0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7)
#: how refining a probed axis multiplies a run's cost: the time step's linearly (the increments or
#: steps), the penalty's not at all
AXIS_COST = {"time": 1.0, "contact": 0.0}


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


def need(tolerance: float, mesh: MeshEstimate, probes: dict[str, ProbeEstimate], explicit: bool,
         cost_exponent: float = 3.0) -> Need:
    """The cheapest factors that bring one result's bar within ``TARGET`` x ``tolerance`` (absolute):
    each probed source takes one of :data:`SHARES` of the tolerance and the mesh the rest, and the
    split whose run costs least (mesh factor^``cost_exponent`` x each axis's factor^:data:`AXIS_COST`)
    wins."""
    if not mesh.ok:
        return Need(refusal=mesh.note)
    active = {a: p for a, p in probes.items() if not (explicit and a == "time")}
    for axis, probe in active.items():
        if probe.ladder is not None and not probe.ladder.ok:
            return Need(refusal=f"the {axis} probes: {probe.ladder.note}", axis=axis)
    best, why = None, Need(refusal=f"{mesh.note}; the bar {mesh.bar:.4g} exceeds the tolerance's share: no mesh "
                                   f"is predicted to meet it")
    for shares in itertools.product(SHARES, repeat=len(active)):
        factors, left = {}, TARGET * tolerance
        for (axis, probe), share in zip(active.items(), shares):
            f = probe.factor_for(share * tolerance)
            if not math.isfinite(f):
                why = Need(refusal=f"the {axis} probes: their bar {probe.bound:.4g} exceeds "
                                   f"{share * tolerance:.4g} at any setting", axis=axis)
                break
            factors[axis] = f
            left -= probe.bound_at(f)
        else:
            h = mesh.size_for(left) if left > 0 else None
            if h is None:
                continue
            factors["mesh"] = max(1.0, 1.0 / h)
            cost = factors["mesh"] ** cost_exponent * math.prod(factors[a] ** AXIS_COST[a] for a in active)
            if best is None or cost < best[0]:
                best = (cost, factors)
    return Need(factors=best[1]) if best is not None else why


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
