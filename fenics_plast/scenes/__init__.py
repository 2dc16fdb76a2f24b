"""Scene runners, one module per scene kind, imported lazily by the CLI.

Contract (docs/DESIGN.md): ``run(scene, output) -> dict`` where ``output`` is a
:class:`fenics_plast.output.RunOutput`; the dict holds the results for summary.json (unit in every
key) plus ``cells``, ``dofs`` and ``converged``.
"""
from __future__ import annotations

import importlib
from typing import Callable

RUNNERS: dict[str, str] = {
    "bar_tension": "fenics_plast.scenes.bar_tension:run",
    "taylor_bar": "fenics_plast.scenes.taylor_bar:run",
    "thick_cylinder": "fenics_plast.scenes.thick_cylinder:run",
    "punch_stretching": "fenics_plast.scenes.punch_stretching:run",
}


def newton_options(solver_section) -> dict:
    """StaticSolver keyword arguments from a validated [solver] section of a static scene."""
    sv = solver_section
    return dict(rtol=sv.rtol, atol=sv.atol, max_iterations=sv.max_iterations, linesearch=sv.linesearch)


class RunnerNotFound(LookupError):
    """No runner can be imported for a scene kind."""


def get_runner(kind: str) -> Callable:
    """Import and return the runner for ``kind``; raises :class:`RunnerNotFound` with a clear message."""
    try:
        target = RUNNERS[kind]
    except KeyError:
        raise RunnerNotFound(f"no runner registered for scene kind {kind!r} "
                             f"(known: {', '.join(RUNNERS)})") from None
    modname, func = target.split(":")
    try:
        mod = importlib.import_module(modname)
    except ModuleNotFoundError as e:
        if e.name is not None and (modname == e.name or modname.startswith(e.name + ".")):
            raise RunnerNotFound(f"the runner for scene kind {kind!r} is not available: "
                                 f"module {modname} does not exist yet") from None
        raise
    try:
        return getattr(mod, func)
    except AttributeError:
        raise RunnerNotFound(f"the runner module {modname} has no function {func!r}") from None
