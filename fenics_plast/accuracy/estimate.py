"""The error of one result from a ladder of runs: its observed order, its error bar, and the setting
that brings the bar within a tolerance.

Mesh ladder (three or more runs, mesh sizes h0 > h1 > h2 > ..., the other settings fixed), after
the practice of Roache's grid convergence index and of Eça and Hoekstra (J. Comput. Phys. 262, 2014):

* **monotone** (every difference f_i - f_i+1 of one sign): the observed order p (three levels: from
  :func:`fenics_plast.study.references.richardson`; more: the least-squares fit of f_ext + A h^p, its
  standard deviation sigma added to the bar); f(h) = f_ext + A h^p and the error bar U(h) =
  :data:`SAFETY` |A| h^p + sigma. Refused when p < :data:`ORDERS` [0] (the ladder is not in the
  asymptotic range). Above :data:`ORDERS` [1] the bar is taken at that order (a lower order predicts a
  larger error from the same differences: the bar is on the safe side);
* **oscillating** (the differences change sign): U = :data:`SAFETY_OSCILLATING` x the range of the
  values, whatever h (refining does not shrink it predictably): accepted only where it is within the
  tolerance;
* **at round-off** (the two finest agree to 1e-12): U = :data:`SAFETY_OSCILLATING` x the range.

Probe (one run with one setting refined by a factor, the mesh at its coarsest: the time step, the
contact penalty): the difference d between the two bounds the error of the unrefined setting when
the error falls at least as fast as the setting's declared order q (:data:`PROBE_ORDER`): e <= |d|
r^q / (r^q - 1). Refining the setting by a further factor s divides the bound by s^q.

Pure functions of numbers: nothing here runs anything.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

from ..study.references import richardson

#: safety factor on a monotone three-level estimate (Roache's GCI, three or more grids)
SAFETY = 1.25
#: the error bar of an oscillating or round-off-converged ladder, in ranges of its three values
#: (Eça and Hoekstra 2014)
SAFETY_OSCILLATING = 3.0
#: the observed orders trusted: below, not in the asymptotic range; above, the bar uses the upper bound
ORDERS = (0.5, 3.0)
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
        return self.bar

    @property
    def used_order(self) -> float:
        """The order the bar is computed at (the observed one, capped at :data:`ORDERS` [1])."""
        return min(self.order, ORDERS[1])

    def size_for(self, bar: float) -> float | None:
        """The mesh size at which the bar equals ``bar``; None when no size does (the range rule)."""
        if self.kind != "monotone":
            return None if self.bar > bar else max(self.h)
        if bar <= self.sigma:
            return None
        if self.coefficient == 0.0:
            return max(self.h)
        return ((bar - self.sigma) / (SAFETY * self.coefficient)) ** (1.0 / self.used_order)


def mesh_estimate(h: Sequence[float], f: Sequence[float]) -> MeshEstimate:
    """The estimate from three or more levels h[0] > h[1] > ... (any unit) of a result f (see the module
    docstring); with more than three, f_ext + A h^p fitted by least squares and the fit's standard
    deviation added to the bar (Eça and Hoekstra's procedure)."""
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
    if p is None or p < ORDERS[0]:
        why = "the differences do not shrink" if p is None else f"observed order {p:.2f} < {ORDERS[0]:g}"
        return MeshEstimate("refused", h, f, order=p, note=f"not in the asymptotic range: {why}")
    used = min(p, ORDERS[1])
    value, a = _fit(h, f, used)
    note = f"observed order {p:.2f}" + (f" (bar at order {used:g})" if used < p else "") + (
        f", least squares over {len(h)} meshes, standard deviation {sigma:.3g}" if len(h) > 3 else "")
    est = MeshEstimate("monotone", h, f, order=p, value=value, coefficient=abs(a), sigma=sigma, note=note)
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
    """What one probe says about one result: ``bound`` the error of the unrefined setting (absolute),
    assuming an order of at least ``order``; ``ratio`` the probe's refinement factor."""
    axis: str
    ratio: float
    difference: float
    order: float

    @property
    def bound(self) -> float:
        r_q = self.ratio ** self.order
        return abs(self.difference) * r_q / (r_q - 1.0)

    def bound_at(self, factor: float) -> float:
        """The bound with the setting refined ``factor`` times from the unrefined run."""
        return self.bound / factor ** self.order

    def factor_for(self, bar: float) -> float:
        """The refinement factor (>= 1) that brings the bound within ``bar``."""
        if self.bound <= bar or bar <= 0.0:
            return 1.0
        return (self.bound / bar) ** (1.0 / self.order)


def probe_estimate(axis: str, ratio: float, coarse: float, fine: float) -> ProbeEstimate:
    """The probe of ``axis`` refined ``ratio`` times: results ``coarse`` (unrefined) and ``fine``."""
    return ProbeEstimate(axis, float(ratio), float(coarse) - float(fine), PROBE_ORDER[axis])
