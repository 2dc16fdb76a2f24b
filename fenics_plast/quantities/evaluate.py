"""Measuring the declared outputs on a :class:`~fenics_plast.quantities.body.Body`:
:class:`Quantities` asks each output's kind (:mod:`fenics_plast.quantities.registry`) for its column
values every history row, keeps them for summary.json, and keeps the profiles of profile kinds
(thickness: ``<name>.csv``, (time, s0 [mm], value) rows)."""
from __future__ import annotations

import numpy as np
from mpi4py import MPI

from .body import Body
from .registry import AUTOMATIC, KINDS, column_names, study_keys

__all__ = ["Quantities"]


class Quantities:
    """Evaluates every declared output on a :class:`Body`; ``row()`` -> {column: value}.

    What the kinds read and fill: ``body``, ``facet_tags``, ``groups`` (name -> (dim, tag)),
    ``reactions`` ((group, component) -> owned dof indices), ``nodes`` (per output: its node indices),
    ``expressions`` (per expression output: the parsed expression), ``columns`` (per output: its
    history.csv columns), ``profiles`` (per profile output:
    [(time, s, values)]), :meth:`nearest_node`. ``automatic``: the automatic kinds the body has
    (columns after the declared outputs'; summary entries from :meth:`automatic_summary`)."""

    def __init__(self, outputs: dict, body: Body, facet_tags, groups: dict, reactions=None):
        self.outputs, self.body = outputs, body
        self.facet_tags, self.groups = facet_tags, groups
        self.reactions = reactions or {}          # (group, component) -> owned dof indices
        self.history: dict[str, list[float]] = {}
        self.times: list[float] = []
        self.profiles: dict[str, list[tuple[float, np.ndarray, np.ndarray]]] = {}
        self.nodes = {}
        self.expressions = {}       # name -> parsed expression of t and earlier one-column outputs
        self.columns = {name: column_names(name, o) for name, o in outputs.items()}   # name -> its columns
        for name, o in outputs.items():
            setup = getattr(KINDS[o.quantity], "setup", None)
            if setup is not None:
                setup(name, o, self)
        self.automatic = [m for m in AUTOMATIC.values() if m.active(body)]

    def nearest_node(self, p, among=None):
        """[index] of the owned node nearest the reference point ``p`` on the rank that holds it, [] on
        the others; ``among``: owned node indices to choose from (a group's or region's nodes; default all)."""
        nodes = np.arange(self.body.n_owned_nodes) if among is None else np.asarray(among, dtype=np.int64)
        X = self.body.X[nodes]
        d = np.linalg.norm(X - p, axis=1) if len(X) else np.array([np.inf])
        i = int(np.argmin(d))
        best = self.body.comm.allreduce((float(d[i]), self.body.comm.rank), op=MPI.MINLOC)
        return np.array([nodes[i]] if self.body.comm.rank == best[1] and len(X) else [], dtype=np.int64)

    # -- one output -------------------------------------------------------------------------
    def value(self, name, o, time, row):
        """The output's column value(s) at ``time``; ``row``: the columns measured so far in this row
        (``{output name: value}`` of one-column outputs, read by expressions)."""
        m = KINDS[o.quantity]
        return [] if getattr(m, "PROFILE", False) else m.value(name, o, self, time, row)

    def row(self, time: float) -> dict[str, float]:
        """Measure every history output at ``time``; the values are also kept for the summary."""
        out, by_name = {}, {}
        for name, o in self.outputs.items():
            cols = column_names(name, o)
            for col, v in zip(cols, self.value(name, o, time, by_name)):
                out[col] = float(v)
                self.history.setdefault(col, []).append(float(v))
            if len(cols) == 1:
                by_name[name] = out[cols[0]]
        for m in self.automatic:             # (their summary is measured at the end: not kept)
            out.update(zip(m.columns(m.NAME, None), m.value(m.NAME, None, self, time, by_name)))
        self.times.append(float(time))
        return out

    def one_column_values(self, time: float) -> dict[str, float]:
        """{output name: value} of the one-column outputs (not expressions, not profiles) at ``time``,
        measured without being recorded (the jump of each output across a remesh)."""
        out = {}
        for name, o in self.outputs.items():
            if o.quantity == "expression" or getattr(KINDS[o.quantity], "PROFILE", False) or len(self.columns[name]) != 1:
                continue
            out[name] = float(self.value(name, o, time, {})[0])
        return out

    # -- profiles ---------------------------------------------------------------------------
    def record_profiles(self, time: float):
        for name in self.profiles:
            s, v = KINDS[self.outputs[name].quantity].profile(name, self)
            self.profiles[name].append((float(time), s, v))

    def profile_table(self, name) -> dict[str, list]:
        cols = dict(time=[], s0_mm=[], value=[])
        for t, s, v in self.profiles[name]:
            cols["time"] += [t] * len(s)
            cols["s0_mm"] += list(s)
            cols["value"] += list(v)
        return cols

    # -- summary ----------------------------------------------------------------------------
    def summary(self, time_label: str) -> dict:
        """Final values (and max/min where asked) of the history outputs; profile summaries."""
        res = {}
        for name, o in self.outputs.items():
            m = KINDS[o.quantity]
            if getattr(m, "PROFILE", False):
                res.update(m.summary(name, o, self, time_label))
                continue
            for col in column_names(name, o):
                h = self.history.get(col)
                if not h:
                    continue
                if "final" in o.summary:
                    res[col] = h[-1]
                for which, f in (("max", np.argmax), ("min", np.argmin)):
                    if which in o.summary:
                        i = int(f(h))
                        res[f"{which}_{col}"] = h[i]
                        res[f"{time_label}_at_{which}_{col}"] = self.times[i]
                if o.at_max_of is not None:
                    other = column_names(o.at_max_of, self.outputs[o.at_max_of])[0]
                    res[f"{col}_at_max_{other}"] = h[int(np.argmax(self.history[other]))]
        return res

    def automatic_summary(self, failed: bool = False) -> dict:
        """The automatic quantities' summary.json entries, measured now (``failed``: those of a run
        gone unstable)."""
        res = {}
        for m in self.automatic:
            res.update(m.failed(self) if failed else m.summary(self))
        return res

    def study_keys(self, automatic: bool = False) -> dict:
        """summary.json's key_results / info_results / references (read by `fenics-plast study`);
        ``automatic``: with the automatic quantities' keys in info_results."""
        keys = study_keys(self.outputs)
        if automatic:
            keys["info_results"] = keys["info_results"] + [
                k for m in sorted(self.automatic, key=lambda m: m.INFO_ORDER) for k in m.INFO]
        return keys
