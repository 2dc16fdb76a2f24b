"""The runs of an accuracy request: a :class:`Setting` is one combination of axis factors, a
:class:`Ladder` runs settings (one process each, through :func:`fenics_plast.study.execute`) and keeps
them by name, so that asking again reuses every run already made.

The ladder itself: the mesh at factors 1, :data:`LADDER_RATIO` and its square, each made exact on the
smallest cell count (:meth:`fenics_plast.accuracy.axes.Axis.exact`; the scene's own mesh first, so
its cheapest run comes first), then one probe per other axis the scene has, at the
coarsest mesh with that axis refined :data:`PROBE_RATIO` times.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Sequence

from ..study.execute import Run, execute
from .axes import AXES, Axis

#: the mesh factor between two levels of the ladder (sqrt 2: each level costs 2-3 times the one before
#: in 2-D, so the ladder costs less than twice its finest level)
LADDER_RATIO = math.sqrt(2.0)
#: levels of the mesh ladder (three: an observed order and an extrapolation)
LADDER_LEVELS = 3
#: how much a probe refines its axis
PROBE_RATIO = {"time": 2.0, "contact": 4.0}
#: what a ladder run does not write (the final run writes what the scene asks)
LEAN = ("output.xdmf=false", "output.plots=false")


@dataclass(frozen=True)
class Setting:
    """Axis factors (axis -> factor >= 1; an axis absent or at 1 is the scene's own setting)."""
    factors: tuple[tuple[str, float], ...]

    @classmethod
    def of(cls, **factors: float) -> "Setting":
        return cls(tuple((a, float(factors[a])) for a in AXES if a in factors and
                         (a == "mesh" or float(factors[a]) != 1.0)))

    def factor(self, axis: str) -> float:
        return dict(self.factors).get(axis, 1.0)

    @property
    def name(self) -> str:
        """The run's folder name: ``mesh-1.414``, ``mesh-1_time-2``."""
        return "_".join(f"{a}-{f:.4g}" for a, f in self.factors)

    def overrides(self, axes: dict[str, Axis]) -> list[str]:
        return [s for a, f in self.factors for s in axes[a].overrides(f)]

    def others_at_one(self) -> bool:
        """Whether every axis but the mesh is at the scene's setting."""
        return all(f == 1.0 for a, f in self.factors if a != "mesh")


def ladder_settings(axes: dict[str, Axis]) -> tuple[list[Setting], dict[str, Setting]]:
    """The mesh levels (coarse to fine) and the probes {axis: setting} of a scene's axes."""
    mesh = axes["mesh"]
    factors = [1.0]
    for i in range(1, LADDER_LEVELS):
        f = mesh.exact(LADDER_RATIO ** i)
        factors.append(f if f > factors[-1] else mesh.exact(factors[-1] * (1 + 1e-6), up=True))
    levels = [Setting.of(mesh=f) for f in factors]
    probes = {a: Setting.of(mesh=1.0, **{a: PROBE_RATIO[a]}) for a in axes if a != "mesh"}
    return levels, probes


@dataclass
class Ladder:
    """The runs of one request, by setting name, in the folder ``out``/runs."""
    scene: Path
    axes: dict[str, Axis]
    out: Path
    sets: Sequence[str] = ()
    np_ranks: int = 1
    reuse: bool = True
    trust_mesh_script: bool = False
    log: Callable[[str], None] = print
    runs: dict[str, Run] = field(default_factory=dict)
    setting_of: dict[str, Setting] = field(default_factory=dict)
    final_names: list[str] = field(default_factory=list)

    def run(self, setting: Setting, final: bool = False) -> Run:
        """Run ``setting`` (or reuse it); ``final``: with the scene's own outputs (fields, plots)."""
        name = setting.name
        if name in self.runs and not final:
            return self.runs[name]
        sets = [*(() if final else LEAN), *self.sets, *setting.overrides(self.axes)]
        if final:
            name = f"final_{name}"
        run = Run(name=name, label=name, settings=dict(o.split("=", 1) for o in setting.overrides(self.axes)))
        self.log(f"accuracy: run {name} ...")
        execute(run, self.scene, sets, self.out / "runs" / name, np_ranks=self.np_ranks, reuse=self.reuse,
                trust_mesh_script=self.trust_mesh_script, root=self.out)
        t = run.value("wall_time_s")
        self.log(f"accuracy: run {name}: {run.status}" + (" (reused)" if run.reused else "")
                 + (f", {t:.2f} s" if t is not None else "") + (f": {run.reason}" if run.reason else ""))
        self.runs[name] = run
        self.setting_of[name] = setting
        if final:
            self.final_names.append(name)
        return run

    def process_time(self, names: Sequence[str]) -> float:
        """Process seconds of the runs ``names`` (a reused run counts what it took when it ran)."""
        return sum(self.runs[n].process_time_s or 0.0 for n in names if n in self.runs)
