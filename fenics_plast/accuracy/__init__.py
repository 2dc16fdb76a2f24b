"""Accuracy on demand: ``fenics-plast run SCENE --accuracy RESULT=TOL [...]``.

The user states a tolerance on the results they care about; the package runs a short ladder of the
scene's discretisation settings, measures how each result converges, runs the cheapest setting
predicted to meet every tolerance, and reports each result as value ± error bar, or refuses, with the
table and what to do, where the ladder cannot vouch for a bar.

Modules, in the order a request goes through them:

* :mod:`.tolerance`: ``--accuracy`` arguments (:class:`Tolerance`, :class:`AccuracyError`);
* :mod:`.axes`: the scene's discretisation axes (mesh, time, contact) from the schema, and the
  ``--set`` overrides that refine one by a factor;
* :mod:`.ladder`: the settings of the ladder and the runs (one process each, through
  :mod:`fenics_plast.study.execute`), kept and reused by setting;
* :mod:`.estimate`: a result's observed order and error bar from three meshes, and the bound a
  probe gives on another axis;
* :mod:`.probes`: the probed axes' refinement as measured (a static run's increments counted), and
  more probes where one matters;
* :mod:`.plan`: the factors each result needs, the final setting, its predicted cost;
* :mod:`.driver`: :func:`run_accuracy`, the request from start to end;
* :mod:`.report`: accuracy.json, accuracy.md and the printed lines.
"""
from __future__ import annotations

from .driver import MAX_FINALS, run_accuracy
from .estimate import (MIN_ORDER, SAFETY, SAFETY_OSCILLATING, THEORETICAL_ORDER, MeshEstimate, ProbeEstimate,
                       mesh_estimate, probe_estimate)
from .ladder import LADDER_RATIO, PROBE_RATIO, Setting
from .plan import SHARE, TARGET
from .probes import MAX_PROBE_LEVELS
from .report import Outcome, lines
from .tolerance import AccuracyError, Tolerance, parse_tolerance

__all__ = ["run_accuracy", "MAX_FINALS", "MAX_PROBE_LEVELS", "MIN_ORDER", "THEORETICAL_ORDER", "SAFETY",
           "SAFETY_OSCILLATING", "MeshEstimate", "ProbeEstimate", "mesh_estimate", "probe_estimate",
           "LADDER_RATIO", "PROBE_RATIO", "Setting", "SHARE", "TARGET", "Outcome", "lines", "AccuracyError",
           "Tolerance", "parse_tolerance"]
