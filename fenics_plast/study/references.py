"""What each run's results are compared with, and the relative errors.

Keys that order runs from coarse to fine (:data:`fenics_plast.study.plan.ORDERED_KEYS`) make a
convergence study; every other varied key (``materials.<name>.model``, ``contact.<name>.law``...) is categorical
and splits the runs into groups, each with its own :class:`Reference`: the group's finest run
(finest in every ordered key). When a Richardson key (``mesh.refine``) takes >= 3 values, the
reference is instead the Richardson extrapolation from the three finest levels (mesh size
h = 1/refine, the other ordered keys at their finest value) with the observed order p; when the
three values do not converge monotonically (or p falls outside :data:`ORDER_RANGE`) the reference
falls back to the finest run, with a note. With no ordered key varied the reference is the first
run that succeeded (a comparison of variants, not a convergence study).

* :func:`richardson`: three-level extrapolation with the observed order;
* :func:`references`: one :class:`Reference` per group of categorical values;
* :func:`relative_error`: (value - reference) / |reference|.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

from .execute import Run
from .plan import Vary, as_number, mesh_size, ordered_varies

#: Accepted range of the observed order; outside it the extrapolation is not trusted.
ORDER_RANGE = (0.3, 8.0)


@dataclass
class Richardson:
    """Result of a three-level extrapolation f(h) = f_ext + C h^p."""
    value: float | None
    order: float | None
    note: str = ""

    @property
    def ok(self) -> bool:
        return self.value is not None


def richardson(h: Sequence[float], f: Sequence[float], order_range=ORDER_RANGE) -> Richardson:
    """Extrapolate to h = 0 from three levels h[0] > h[1] > h[2] (coarse to fine) of f.

    Solves (h0^p - h1^p) / (h1^p - h2^p) = (f0 - f1) / (f1 - f2) for the observed order p
    (closed form ln(ratio)/ln(r) for a constant refinement ratio r, bisection otherwise), then
    f_ext = f2 - (f1 - f2) h2^p / (h1^p - h2^p). Returns value None with a note when the levels
    do not converge monotonically or p is outside ``order_range``.
    """
    h = [float(x) for x in h]
    f = [float(x) for x in f]
    if len(h) != 3 or len(f) != 3:
        raise ValueError("richardson needs three levels")
    if not (h[0] > h[1] > h[2] > 0):
        raise ValueError(f"richardson: mesh sizes must decrease, got {h}")
    if not all(math.isfinite(x) for x in f):
        return Richardson(None, None, "a value is not finite")
    d1, d2 = f[0] - f[1], f[1] - f[2]
    scale = max(abs(x) for x in f) or 1.0
    if abs(d2) <= 1e-14 * scale:
        return Richardson(None, None, "the two finest levels agree to round-off")
    if abs(d1) <= 1e-14 * scale or d1 / d2 <= 0:
        return Richardson(None, None, f"not monotone (differences {d1:+.3g}, {d2:+.3g})")
    ratio = d1 / d2
    r1, r2 = h[0] / h[1], h[1] / h[2]

    def g(p):
        return (h[0] ** p - h[1] ** p) / (h[1] ** p - h[2] ** p)

    if abs(r1 - r2) <= 1e-12 * r1:
        p = math.log(ratio) / math.log(r1)
    else:
        lo, hi = 1e-6, 60.0
        if not g(lo) < ratio < g(hi):
            return Richardson(None, None, f"the differences ({d1:+.3g}, {d2:+.3g}) shrink too slowly (or too "
                                          f"fast) for an order p in ({lo:g}, {hi:g})")
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if g(mid) < ratio else (lo, mid)
        p = 0.5 * (lo + hi)
    if not order_range[0] <= p <= order_range[1]:
        return Richardson(None, p, f"observed order {p:.3g} outside [{order_range[0]:g}, {order_range[1]:g}]")
    value = f[2] - d2 * h[2] ** p / (h[1] ** p - h[2] ** p)
    return Richardson(value, p)


@dataclass
class Reference:
    """What the runs of one group are compared with, per key result."""
    group: tuple
    runs: list[Run]
    values: dict[str, float | None] = field(default_factory=dict)
    orders: dict[str, float | None] = field(default_factory=dict)
    kind: dict[str, str] = field(default_factory=dict)          # per key: "finest run X" / "Richardson ..."
    notes: list[str] = field(default_factory=list)
    run: Run | None = None                                       # the reference run (None: none succeeded)


def finite(x) -> bool:
    """True for a finite int or float (not a bool)."""
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _fineness(run: Run, ordered: list[Vary]) -> tuple:
    """Sort key: rank of the run's value in each ordered key, coarse (0) to fine."""
    ranks = []
    for v in ordered:
        nums = sorted(v.values, key=lambda s: v.sign * (as_number(s) or 0.0))
        ranks.append(nums.index(run.settings[v.key]))
    return tuple(ranks)


def references(runs: list[Run], varies: Sequence[Vary], keys: list[str]) -> list[Reference]:
    """One :class:`Reference` per group of categorical values (see the module docstring)."""
    ordered = ordered_varies(varies)
    okeys = {v.key for v in ordered}
    categorical = [v for v in varies if v.key not in okeys]
    if not ordered:
        ref = Reference(group=(), runs=list(runs))
        first = next((r for r in runs if r.ok), None)
        ref.run = first
        for k in keys:
            ref.values[k] = first.summary.get(k) if first is not None and finite(first.summary.get(k)) else None
            ref.orders[k] = None
            ref.kind[k] = f"first run {first.name}" if first is not None else "none (no run succeeded)"
        if first is not None:
            ref.notes.append(f"no refinement key varied: every run is compared with the first run that "
                             f"succeeded, {first.name} ({first.label})")
        return [ref]
    groups: dict[tuple, list[Run]] = {}
    for r in runs:
        groups.setdefault(tuple(r.settings[v.key] for v in categorical), []).append(r)
    out = []
    for gkey, members in groups.items():
        ref = Reference(group=tuple(zip([v.key for v in categorical], gkey)), runs=members)
        ok = [r for r in members if r.ok]
        finest_combo = max(members, key=lambda r: sum(_fineness(r, ordered)))
        best = max(ok, key=lambda r: (sum(_fineness(r, ordered)), members.index(r)), default=None)
        ref.run = best
        if best is None:
            ref.notes.append("no run of this group succeeded")
        elif best is not finest_combo:
            ref.notes.append(f"the finest run {finest_combo.name} failed; reference is {best.name}")
        rich = _richardson_levels(members, ordered)
        if rich is not None and len(rich[1]) < 3:
            ref.notes.append(f"{rich[0]}: fewer than three successful levels, no Richardson extrapolation")
            rich = None
        for k in keys:
            ref.orders[k] = None
            ref.values[k] = best.summary.get(k) if best is not None and finite(best.summary.get(k)) else None
            ref.kind[k] = f"finest run {best.name}" if best is not None else "none"
            if rich is None:
                continue
            rkey, levels = rich
            vals = [r.summary.get(k) for r in levels]
            if not all(finite(x) for x in vals):
                ref.notes.append(f"{k}: a level has no value; error against the finest run")
                continue
            h = [mesh_size(rkey)(as_number(r.settings[rkey])) for r in levels]
            res = richardson(h, vals)
            names = ", ".join(r.name for r in levels)
            if res.ok:
                ref.values[k], ref.orders[k] = res.value, res.order
                ref.kind[k] = f"Richardson from {names} (p = {res.order:.2f})"
            else:
                ref.notes.append(f"{k}: no Richardson extrapolation from {names}: {res.note}; "
                                 f"error against the finest run")
        out.append(ref)
    return out


def _richardson_levels(members: list[Run], ordered: list[Vary]):
    """(key, the three finest successful levels of a Richardson key, coarse to fine), with the
    other ordered keys at their finest value; None when no Richardson key has >= 3 values."""
    for v in ordered:
        if mesh_size(v.key) is None or len(v.values) < 3:
            continue
        others = [o for o in ordered if o is not v]
        finest_other = {o.key: max(o.values, key=lambda s, o=o: o.sign * as_number(s)) for o in others}
        cand = [r for r in members if r.ok and all(r.settings[o] == val for o, val in finest_other.items())]
        cand.sort(key=lambda r: v.sign * as_number(r.settings[v.key]))
        return v.key, cand[-3:]
    return None


def relative_error(value, ref) -> float | None:
    """(value - ref) / |ref| (fraction); None when either is missing; absolute error when ref is 0."""
    if not (finite(value) and finite(ref)):
        return None
    return (value - ref) / abs(ref) if ref != 0 else value - ref
