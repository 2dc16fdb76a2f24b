"""The error of one result from a ladder of runs: its observed order, its error bar, and the setting
that brings the bar within a tolerance.

Mesh ladder (three or more runs, mesh sizes h0 > h1 > h2 > ..., the other settings fixed), after
the practice of Roache's grid convergence index and of Eça and Hoekstra (J. Comput. Phys. 262, 2014):

* **monotone** (every difference f_i - f_i+1 of one sign): the observed order p (three levels: from
  :func:`fenics_plast.study.references.richardson`; more: the least-squares fit of f_ext + A h^p, its
  standard deviation sigma added to the bar); f(h) = f_ext + A h^p and the error bar U(h) =
  :data:`SAFETY` |A| h^p + sigma. Refused when p < :data:`MIN_ORDER` (the ladder is not in the
  asymptotic range). Above the problem's theoretical order (:data:`THEORETICAL_ORDER`) the bar is taken
  at that order (a lower order predicts a larger error from the same differences: the bar is on the
  safe side);
* **oscillating** (the differences change sign): U = :data:`SAFETY_OSCILLATING` x the range of the
  values, whatever h (refining does not shrink it predictably): accepted only where it is within the
  tolerance;
* **at round-off** (the two finest agree to 1e-12): U = :data:`SAFETY_OSCILLATING` x the range.

Probe (one run with one setting refined by a factor, the mesh at its coarsest: the time step, the
contact penalty): the difference d between the two bounds the error of the unrefined setting when
the error falls at least as fast as the setting's declared order q (:data:`PROBE_ORDER`): e <= |d|
r^q / (r^q - 1). Refining the setting by a further factor s divides the bound by s^q. Where that bound
matters (more than its share of a tolerance), a second probe refines the setting r^2 times and the
three levels are estimated like the mesh's, the order measured rather than assumed.

Pure functions of numbers: nothing here runs anything.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

from ..study.references import richardson

#: safety factor on a monotone three-level estimate (Roache's GCI, three or more grids)
SAFETY = 1.25
#: the error bar of an oscillating or round-off-converged ladder, in ranges of its values
#: (Eça and Hoekstra 2014)
SAFETY_OSCILLATING = 3.0
#: the lowest observed order trusted: below it the ladder is not in the asymptotic range
MIN_ORDER = 0.5
#: the order a result can be expected to converge at (Eça and Hoekstra's theoretical order): an observed
#: order above it is taken as pre-asymptotic luck, and the bar is computed at this order through the
#: two finest meshes (larger than at the observed order: on the safe side). Q1 elements converge at
#: second order where the solution is smooth; a plastic front or the edge of a contact is a kink in
#: the displacement's gradient, and the results of such problems converge at first order (the Taylor
#: bar's radius and length: 1.1 and 1.3 over refine 1, 2, 4, docs/STUDIES.md)
THEORETICAL_ORDER = {"smooth": 2.0, "plastic or contact": 1.0}
#: the order at which each probed error source falls at least: the time step's (backward Euler in the
#: static increments, the radial return, and central differences cut to first order by contact and
#: plasticity), the penalty's compliance (u_pen = p / penalty, exactly first order)
PROBE_ORDER = {"time": 1.0, "contact": 1.0}


@dataclass
class MeshEstimate:
    """What three or more mesh levels say about one result.

    ``kind``: "monotone", "oscillating", "round-off" or "refused"; ``order`` p (monotone), ``value``
    the extrapolated f_ext (monotone) or None; ``coefficient`` |A| (the error at h is |A| h^p,
    monotone); ``sigma`` the least-squares fit's standard deviation (0 for three levels); ``bar`` the
    error bar at the finest level (absolute, in the result's unit); ``note``: what a user is told (why
    refused, or which rule gave the bar)."""
    kind: str
    h: tuple[float, ...]
    values: tuple[float, ...]
    order: float | None = None
    order_cap: float = THEORETICAL_ORDER["smooth"]
    value: float | None = None
    coefficient: float | None = None
    bar: float | None = None
    sigma: float = 0.0
    note: str = ""

    @property
    def ok(self) -> bool:
        return self.kind != "refused"

    def bar_at(self, h: float) -> float:
        """The error bar at mesh size ``h`` (same unit as ``self.h``): SAFETY |A| h^p + the fit's standard
        deviation when monotone, the range rule otherwise (it does not shrink with h)."""
        if self.kind == "monotone":
            return SAFETY * self.coefficient * h ** self.used_order + self.sigma
        return math.inf if self.bar is None else self.bar

    @property
    def used_order(self) -> float:
        """The order the bar is computed at: the observed one, capped at the theoretical one."""
        return min(self.order, self.order_cap)

    def size_for(self, bar: float) -> float | None:
        """The mesh size at which the bar equals ``bar``; None when no size does (the range rule, or no
        estimate)."""
        if self.kind == "refused":
            return None
        if self.kind != "monotone":
            return None if self.bar > bar else max(self.h)
        if bar <= self.sigma:
            return None
        if self.coefficient == 0.0:
            return max(self.h)
        return ((bar - self.sigma) / (SAFETY * self.coefficient)) ** (1.0 / self.used_order)


def mesh_estimate(h: Sequence[float], f: Sequence[float],
                  order_cap: float = THEORETICAL_ORDER["smooth"]) -> MeshEstimate:
    """The estimate from three or more levels h[0] > h[1] > ... (any unit) of a result f (see the module
    docstring); with more than three, f_ext + A h^p fitted by least squares and the fit's standard
    deviation added to the bar (Eça and Hoekstra's procedure). ``order_cap``: the theoretical order
    (:data:`THEORETICAL_ORDER`)."""
    h, f = tuple(float(x) for x in h), tuple(float(x) for x in f)
    if len(h) < 3 or len(h) != len(f):
        raise ValueError("mesh_estimate needs three or more levels")
    if not all(math.isfinite(x) for x in f):
        return MeshEstimate("refused", h, f, note="a level has no finite value")
    spread = max(f) - min(f)
    scale = max(abs(x) for x in f) or 1.0
    diffs = [a - b for a, b in zip(f[:-1], f[1:])]
    if abs(diffs[-1]) <= 1e-12 * scale:
        return MeshEstimate("round-off", h, f, bar=SAFETY_OSCILLATING * spread,
                            note=f"the two finest levels agree to round-off: bar = {SAFETY_OSCILLATING:g} x the range")
    if any(d * diffs[-1] <= 0 for d in diffs):
        shown = ", ".join(f"{d:+.4g}" for d in diffs)
        return MeshEstimate("oscillating", h, f, bar=SAFETY_OSCILLATING * spread,
                            note=f"not monotone (differences {shown}): bar = {SAFETY_OSCILLATING:g} x the range of "
                                 f"the levels, which refining does not shrink predictably")
    if len(h) == 3:
        p = richardson(h, f, order_range=(0.0, math.inf)).order
        sigma = 0.0
    else:
        p, sigma = _least_squares_order(h, f)
    if p is None or p < MIN_ORDER:
        why = "the differences do not shrink" if p is None else f"observed order {p:.2f} < {MIN_ORDER:g}"
        return MeshEstimate("refused", h, f, order=p, note=f"not in the asymptotic range: {why}")
    used = min(p, order_cap)
    value, a = _fit(h, f, used)
    note = f"observed order {p:.2f}" + (f" (bar at the theoretical order {used:g})" if used < p else "") + (
        f", least squares over {len(h)} meshes, standard deviation {sigma:.3g}" if len(h) > 3 else "")
    est = MeshEstimate("monotone", h, f, order=p, order_cap=order_cap, value=value, coefficient=abs(a),
                       sigma=sigma, note=note)
    est.bar = est.bar_at(h[-1])
    return est


def _fit(h: Sequence[float], f: Sequence[float], p: float) -> tuple[float, float]:
    """(f_ext, A) of f = f_ext + A h^p, least squares (exact through the two finest levels of three)."""
    if len(h) == 3:
        a = (f[1] - f[2]) / (h[1] ** p - h[2] ** p)
        return f[2] - a * h[2] ** p, a
    x = [hi ** p for hi in h]
    n, sx, sy = len(x), sum(x), sum(f)
    sxx, sxy = sum(v * v for v in x), sum(v * y for v, y in zip(x, f))
    a = (n * sxy - sx * sy) / (n * sxx - sx * sx)
    return (sy - a * sx) / n, a


def _least_squares_order(h: Sequence[float], f: Sequence[float]) -> tuple[float | None, float]:
    """(p, the fit's standard deviation) minimising the squared residuals of f_ext + A h^p over p in
    (0, 8]; p None when the best fit is at the bound (no order fits)."""
    def residual(p):
        value, a = _fit(h, f, p)
        return sum((value + a * hi ** p - fi) ** 2 for hi, fi in zip(h, f))

    grid = [0.05 * k for k in range(1, 161)]
    best = min(grid, key=residual)
    lo, hi = max(best - 0.05, 1e-3), best + 0.05
    for _ in range(60):                      # golden-section search about the best grid point
        m1, m2 = lo + 0.382 * (hi - lo), lo + 0.618 * (hi - lo)
        lo, hi = (lo, m2) if residual(m1) < residual(m2) else (m1, hi)
    p = 0.5 * (lo + hi)
    if p >= grid[-1] - 0.05:
        return None, 0.0
    return p, math.sqrt(residual(p) / (len(h) - 3))


@dataclass
class ProbeEstimate:
    """What the probes of one axis say about one result: ``bound`` the error of the unrefined setting
    (absolute), assuming an order of at least ``order``, from one probe refined ``ratio`` times. With
    ``ladder`` (more probes, the setting refined ``ratio``^k: three levels or more), the bound is the
    bar of that ladder's finest three levels (:class:`MeshEstimate` over the setting's size 1/factor),
    valid from ``min_factor``, its coarsest level, on."""
    axis: str
    ratio: float
    difference: float
    order: float
    ladder: MeshEstimate | None = None
    min_factor: float = 1.0

    @property
    def bound(self) -> float:
        return self.bound_at(self.min_factor)

    def bound_at(self, factor: float) -> float:
        """The bound with the setting refined ``factor`` (>= ``min_factor``) times from the scene's."""
        if self.ladder is not None:
            return self.ladder.bar_at(1.0 / factor)
        r_q = self.ratio ** self.order
        return abs(self.difference) * r_q / (r_q - 1.0) / factor ** self.order

    def factor_for(self, bar: float) -> float:
        """The refinement factor (>= ``min_factor``) that brings the bound within ``bar`` (inf: none)."""
        if self.bound <= bar:
            return self.min_factor
        if bar <= 0.0:
            return math.inf
        if self.ladder is not None:
            size = self.ladder.size_for(bar)
            return math.inf if size is None else max(self.min_factor, 1.0 / size)
        return (self.bound / bar) ** (1.0 / self.order)


def probe_estimate(axis: str, factors: Sequence[float], values: Sequence[float]) -> ProbeEstimate:
    """The probes of ``axis``: ``values`` of a result at the setting refined ``factors`` times (the
    first 1: the scene's; measured where the setting is adaptive, e.g. a static run's increments). Two:
    the bound at the declared order (:data:`PROBE_ORDER`); three or more: the finest three's estimate,
    the order measured (capped at the declared one)."""
    factors, values = [float(f) for f in factors], [float(v) for v in values]
    p = ProbeEstimate(axis, factors[1] / factors[0], values[0] - values[1], PROBE_ORDER[axis])
    if len(values) >= 3:
        p.ladder = mesh_estimate([1.0 / f for f in factors[-3:]], values[-3:], order_cap=PROBE_ORDER[axis])
        p.min_factor = factors[-3]
    return p
