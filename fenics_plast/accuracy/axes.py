"""The discretisation axes of one scene: which of its settings ``run --accuracy`` refines, and the
``--set`` overrides that refine them by a factor.

An axis is an error source (:func:`fenics_plast.schema.discretisation_keys`, declared in the schema
with ``Key.axis`` and ``Key.refines``):

* **mesh**: ``mesh.refine`` (a .geo mesh), and where remeshing is on ``remeshing.size`` and
  ``remeshing.refine_size``;
* **time**: a static run's increments (``analysis.increments``, ``analysis.max_increment`` and each
  step's), an explicit run's step (``analysis.dt_safety``, ``analysis.time_steps``);
* **contact**: the penalties a scene sets (``contact.<name>.penalty``, ``tangential_penalty``); an
  absent penalty is 0.3 E / h and grows with the mesh, so it is on no axis of its own.

Refining an axis by a factor s multiplies the settings that refine when larger by s (rounded up for
integers) and divides those that refine when smaller; only the settings the scene has (given, or
defaulted by the schema) move.
"""
from __future__ import annotations

import fnmatch
import math
from dataclasses import dataclass, field
from typing import Any

from ..schema import discretisation_keys, is_cell_count, key as schema_key

#: the axes, in the order the ladder refines them (the mesh first)
AXES = ("mesh", "time", "contact")


@dataclass
class Axis:
    """One error source of a scene: its settings {dotted key: (refines, the scene's value)}; the mesh
    axis also has ``counts``, the cell counts of ``[mesh.parameters]`` times ``mesh.refine``."""
    name: str
    settings: dict[str, tuple[int, Any]] = field(default_factory=dict)
    counts: tuple[int, ...] = ()

    def exact(self, factor: float, up: bool = False) -> float:
        """The factor nearest ``factor`` (``up``: the smallest not below it) that refines the mesh's
        smallest cell count to a whole number, so that the mesh size is exactly 1/factor along it (6
        cells at sqrt 2: 8, factor 4/3); any other axis's factor as it is."""
        if self.name != "mesh" or not self.counts:
            return factor
        n = min(self.counts)
        k = math.ceil(n * factor - 1e-9) if up else max(round(n * factor), 1)
        return k / n

    def overrides(self, factor: float) -> list[str]:
        """The ``--set`` overrides that refine every setting of the axis ``factor`` times (none at 1)."""
        if factor == 1.0:
            return []
        out = []
        for dotted, (refines, value) in self.settings.items():
            x = value * factor if refines > 0 else value / factor
            if schema_key(_pattern(dotted)).type == "int":
                out.append(f"{dotted}={int(math.ceil(x - 1e-9))}")
            else:
                out.append(f"{dotted}={x:.6g}")
        return out


def _pattern(dotted: str) -> str:
    """``contact.punch.penalty`` -> ``contact.*.penalty`` (the schema's path of a collection's key)."""
    for pattern in discretisation_keys():
        if fnmatch.fnmatchcase(dotted, pattern):
            return pattern
    raise KeyError(dotted)


def _scene_values(problem, pattern: str) -> dict[str, Any]:
    """{dotted key: value} of the keys matching the schema path ``pattern`` that the scene has
    (a value, given or defaulted; OPTIONAL keys left out are None and skipped)."""
    section, *rest = pattern.split(".")
    table = problem.tables.get(section)
    if table is None:
        return {}
    if rest[0] == "*":
        found = {}
        for name, sub in table.items():
            v = sub.get(rest[1]) if len(rest) == 2 else None
            if v is not None:
                found[f"{section}.{name}.{rest[1]}"] = v
        return found
    if len(rest) != 1:
        return {}
    v = table.get(rest[0])
    return {pattern: v} if v is not None and not isinstance(v, bool) else {}


def scene_axes(problem) -> dict[str, Axis]:
    """The scene's axes with at least one setting ({name: Axis}, in :data:`AXES` order). The mesh axis
    needs a .geo mesh (``mesh.refine``) with a cell count among its parameters (what ``mesh.refine``
    multiplies); a .msh mesh, or a .geo sized by lengths alone, has none."""
    axes = {name: Axis(name) for name in AXES}
    geo = problem.mesh_file.suffix.lower() == ".geo"
    for pattern, (refines, axis) in discretisation_keys().items():
        if axis is None or refines == 0:
            continue
        if pattern == "mesh.refine" and not geo:
            continue
        for dotted, value in _scene_values(problem, pattern).items():
            if isinstance(value, (int, float)) and value > 0:
                axes[axis].settings[dotted] = (refines, value)
    counts = tuple(int(round(v * problem.mesh.refine)) for k, v in problem.mesh.parameters.items()
                   if is_cell_count(k))
    if "mesh.refine" not in axes["mesh"].settings or not counts:
        axes["mesh"].settings.clear()        # mesh.refine refines nothing: no mesh axis
    axes["mesh"].counts = counts
    return {n: a for n, a in axes.items() if a.settings}
