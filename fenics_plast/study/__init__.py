"""Parameter studies: ``fenics-plast study SCENE.toml --vary KEY=V1,V2,... [--vary ...] [--out DIR]``.

Runs every combination of the ``--vary`` values (their Cartesian product, in the order given) as
its own process, ``python -m fenics_plast.cli run SCENE --set KEY=V ... --out DIR/runs/<name>``
(under ``mpirun -n N`` with ``--np N``), reads each run's summary.json and writes into DIR
study.csv, study.md and study.png (:mod:`.report`).

The study knows no scene by name: each run's summary.json declares what to compare,

* ``key_results``: the summary keys whose error the study reports (``--results`` overrides);
* ``info_results``: summary keys shown without error;
* ``references``: ``{key: {"value": float, "source": "short text"}}``, published values; the study
  adds ``err_paper_<key>`` columns and lists the sources in study.md, unless it varies or
  ``--set``s a key that is not a discretisation key (then the published problem is not the one run).

The reference of a run's results is its group's finest run, or a Richardson extrapolation over
``mesh.refine`` (:mod:`.references`); which keys are discretisation keys, and in which direction
they refine, is :data:`.plan.ORDERED_KEYS` (and :data:`.plan.UNORDERED_KEYS`: a mesh's grading, the
stable-step estimate, which order nothing).

A run that fails (exit status 1: summary.json has ``error``; 2: invalid combination; a crash, a
signal or ``--timeout``) becomes a row with its reason; the study goes on. Exit status of the study:
0 when at least one run succeeded, 1 when none did, 2 for bad arguments (nothing run).

Modules: :mod:`.plan` (arguments, combinations, run names, ordered keys), :mod:`.execute` (one
process per run), :mod:`.references` (finest run, Richardson, relative errors), :mod:`.table`
(the study and its rows, declared outputs), :mod:`.report` (study.csv, study.md, study.png),
:mod:`.driver` (:func:`run_study`), :mod:`.cli` (command line).
"""
from __future__ import annotations

from .cli import add_study_arguments, main, study_command, study_from_args
from .driver import run_study
from .execute import Run, execute, prevalidate, run_command
from .plan import (ORDERED_KEYS, RICHARDSON_KEYS, UNORDERED_KEYS, StudyError, Vary, as_number, combinations,
                   non_discretisation_keys, order_sign, ordered_varies, parse_vary, run_label, run_name,
                   split_values, toml_value)
from .references import ORDER_RANGE, Reference, Richardson, references, relative_error, richardson
from .report import TOLERANCES, write_csv, write_markdown, write_plot
from .table import RUN_COLUMNS, Declared, Study, cheapest_within, declared_outputs

__all__ = [
    "add_study_arguments", "main", "study_command", "study_from_args", "run_study",
    "Run", "execute", "prevalidate", "run_command",
    "ORDERED_KEYS", "RICHARDSON_KEYS", "UNORDERED_KEYS", "non_discretisation_keys", "StudyError", "Vary",
    "as_number", "combinations", "order_sign", "ordered_varies", "parse_vary", "run_label", "run_name", "split_values", "toml_value",
    "ORDER_RANGE", "Reference", "Richardson", "references", "relative_error", "richardson",
    "TOLERANCES", "write_csv", "write_markdown", "write_plot",
    "RUN_COLUMNS", "Declared", "Study", "cheapest_within", "declared_outputs",
]
