"""The error sources probed beside the mesh (the time step, the contact penalty): how much a run
refines one, measured where the setting is adaptive, and more probes where one matters.

* :data:`EFFECTIVE`, :func:`effective_factor`: a static run's increments are counted, not taken as
  set (growth and cut-backs make a coarse run finer than asked), an explicit run's steps likewise;
* :func:`nominal_factor`: the setting expected to give a measured refinement (the probes' pairs);
* :func:`axes_to_measure`: the axes whose first probe takes more than its share of a tolerance;
* :func:`more_probes`: that axis refined ratio^2, ratio^3, ... times until the finest three converge;
* :func:`probe_advice`: what to do when they do not.
"""
from __future__ import annotations

import math
from typing import Sequence

from .estimate import ProbeEstimate, probe_estimate
from .ladder import PROBE_RATIO, Ladder, Setting
from .plan import SHARE

#: probe levels of an axis at most, the scene's setting included (the time step: up to 16 times finer)
MAX_PROBE_LEVELS = 5
#: what measures an adaptive axis's refinement in a run's summary.json: the time step's, the number of
#: increments (static: growth and cut-backs make it differ from the settings') or steps (explicit)
EFFECTIVE = {"time": {"static": "increments", "explicit": "steps"}}
#: the scene keys of each probed axis, as the advice names them
AXIS_KEYS = {"time": "analysis.increments and analysis.max_increment (and each step's), or analysis.dt_safety",
             "contact": "contact.<name>.penalty"}


def effective_factor(axis: str, name: str, ladder: Ladder, base: str, explicit: bool) -> float:
    """The factor by which run ``name`` refines ``axis`` against run ``base``, as measured (the
    increments or steps counted) where the axis is adaptive, else as set."""
    count = EFFECTIVE.get(axis, {}).get("explicit" if explicit else "static")
    n, n0 = (ladder.runs[x].value(count) if count else None for x in (name, base))
    if not (isinstance(n, (int, float)) and isinstance(n0, (int, float)) and n0 > 0):
        return ladder.setting_of[name].factor(axis)
    return max(n / n0, 1.0 + 1e-9)


def nominal_factor(axis: str, effective: float, ladder: Ladder, base: str, explicit: bool) -> float:
    """The setting's factor expected to refine ``axis`` ``effective`` times (measured), from the probes'
    (set, measured) pairs: log-linear between them, on the last segment's slope beyond."""
    if effective <= 1.0 or axis not in EFFECTIVE:
        return effective
    probes = [n for n, s in ladder.setting_of.items() if s.factor("mesh") == 1.0 and
              all(a in ("mesh", axis) for a, _ in s.factors)]
    pairs = sorted({(ladder.setting_of[n].factor(axis), effective_factor(axis, n, ladder, base, explicit))
                    for n in probes})
    for (n1, e1), (n2, e2) in zip(pairs[:-1], pairs[1:]):
        if effective <= e2 or (n2, e2) == pairs[-1]:
            slope = math.log(e2 / e1) / math.log(n2 / n1) if e2 > e1 else 1.0
            return n1 * (effective / e1) ** (1.0 / max(slope, 1e-3))
    return effective


def axes_to_measure(probes: dict[str, dict[str, ProbeEstimate]], tolerances: dict[str, float],
                    explicit: bool) -> list[str]:
    """The axes whose first probe bounds a result's error by more than its share (:data:`SHARE`) of
    its tolerance (``tolerances``: absolute, per result): their order is measured on more probes
    rather than assumed. (An explicit run's time step is not one: the mesh ladder refines it.)"""
    out = []
    for key, by_axis in probes.items():
        for axis, probe in by_axis.items():
            if explicit and axis == "time" or axis in out:
                continue
            if probe.bound > SHARE * tolerances[key]:
                out.append(axis)
    return out


def more_probes(axis: str, keys: Sequence[str], ladder: Ladder, names: list[str], explicit: bool,
                ladder_names: list[str]) -> tuple[dict[str, ProbeEstimate] | None, tuple[str, str] | None]:
    """``axis`` refined ratio^2, ratio^3, ... times at the coarsest mesh (``names``: the run at the
    scene's setting and the first probe; the runs made are appended to it and to ``ladder_names``) until
    every result's finest three converge, or :data:`MAX_PROBE_LEVELS`. Returns ({result: its estimate},
    None), or (None, (why, what to do)) when a run fails or the probes do not converge."""
    ratio = PROBE_RATIO[axis]
    base = names[0]
    out: dict[str, ProbeEstimate] = {}
    for k in range(2, MAX_PROBE_LEVELS):
        s = Setting.of(mesh=1.0, **{axis: ratio ** k})
        run = ladder.run(s)
        names.append(s.name)
        if s.name not in ladder_names:
            ladder_names.append(s.name)
        if not run.ok:
            return None, (f"the ladder's run {run.name} {run.status}: {run.reason}",
                          "fix what stopped it (its run.log is in runs/" + run.name + "/)")
        factors = [effective_factor(axis, n, ladder, base, explicit) for n in names]
        out = {key: probe_estimate(axis, factors, [ladder.runs[n].value(key) for n in names]) for key in keys}
        if all(p.ladder.kind in ("monotone", "round-off") for p in out.values()):
            return out, None
    key = next(k for k, p in out.items() if p.ladder.kind not in ("monotone", "round-off"))
    return None, (f"{key}: the {axis} probes up to {ratio ** (MAX_PROBE_LEVELS - 1):g} times the scene's "
                  f"setting: {out[key].ladder.note}", probe_advice(axis))


def probe_advice(axis: str) -> str:
    """What to do when a result does not converge with ``axis``'s setting."""
    return (f"the result does not converge with the {axis} setting in the probes' range: refine "
            f"{AXIS_KEYS[axis]} in the scene (--set) and ask again, or choose another result")
