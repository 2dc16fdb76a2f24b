"""The quantities a scene declares in ``[outputs.<name>]``, measured on a running solver.

Each output becomes one history.csv column ``<name>_<unit>`` (``<name>`` for dimensionless ones;
an ``energy = "all"`` output gives five columns) and its final value goes into summary.json, with
``max_``/``min_`` entries when its ``summary`` asks for them. Thickness outputs are profiles: they
are written to ``<name>.csv`` at every step end (and the final state) and summarised by their
smallest value, where it is, and the value at the start of the group.

The solver is seen through a small adapter (:class:`Body`) that both solvers provide the pieces
of: current nodal positions, the displacement, quadrature-point fields, reactions, tool forces and
energies. Units: mm, N (or kN), MPa, J.
"""
from __future__ import annotations

import numpy as np
from dolfinx import fem
from mpi4py import MPI

from fenics_plast.expressions import parse_expression
from fenics_plast.schema import component_index
from fenics_plast.quadrature import von_mises

N_MM_TO_J = 1e-3
ENERGIES = ("kinetic", "elastic", "plastic", "external_work", "balance_error")
ENERGY_COLUMNS = {"kinetic": "kinetic_energy_J", "elastic": "elastic_energy_J",
                  "plastic": "plastic_dissipation_J", "external_work": "external_work_J",
                  "balance_error": "energy_balance_error"}


def column_names(name: str, spec) -> list[str]:
    """The history.csv column(s) of output ``name``."""
    q = spec.quantity
    if q in ("reaction", "tool_force"):
        return [f"{name}_{spec.unit}"]
    if q in ("displacement", "position", "extent", "tool_displacement"):
        return [f"{name}_mm"]
    if q == "field":
        return [{"von_mises": f"{name}_MPa", "temperature": f"{name}_K"}.get(spec.field, name)]
    if q == "energy":
        if spec.energy == "all":
            return [ENERGY_COLUMNS[e] for e in ENERGIES]
        return [ENERGY_COLUMNS[spec.energy]]
    if q == "expression":
        return [name]
    return []          # thickness: a profile, no history column


class Body:
    """What the quantities need from a solver (filled by the runner).

    * ``V``: the CG1 vector space of the displacement ``u`` (a Function on V, owned + ghosts);
    * ``X``: reference coordinates of V's nodes (n, gdim); ``positions()``: current ones (n, gdim), gdim 2
      or 3 (``geometry``: the scene's mesh.geometry, which names the components);
    * ``qmap``: the :class:`fenics_plast.quadrature.QuadratureMap` (eqps, temperature, tau per owned
      point);
    * ``reaction(dofs)`` [N] for owned V-dof indices of one component (unrolled, V numbering);
    * ``tool_force(tool)`` -> (Fx, Fy[, Fz]) [N]; ``tool_translation(tool, t)`` -> (dx, dy[, dz]) [mm];
      ``energies()`` -> dict [N mm] (explicit only).
    """

    def __init__(self, comm, V, X, positions, qmap, cell_regions, *, geometry, reaction=None, tool_force=None,
                 energies=None, tool_translation=None):
        self.comm, self.V, self.X, self.positions, self.qmap = comm, V, X, positions, qmap
        self.geometry = geometry
        self.cell_regions = cell_regions           # region name -> owned cell indices
        self.reaction, self.tool_force, self.energies = reaction, tool_force, energies
        self.tool_translation = tool_translation
        self.n_owned_nodes = V.dofmap.index_map.size_local

    def component(self, name: str) -> int:
        """Index of the component ``name`` (x, y, z; r, z in 2-D) in this body's geometry."""
        return component_index(name, self.geometry)

    def group_nodes(self, facet_tags, tag, owned=True):
        nodes = fem.locate_dofs_topological(self.V, self.V.mesh.topology.dim - 1, facet_tags.find(tag))
        return nodes[nodes < self.n_owned_nodes] if owned else nodes


class Quantities:
    """Evaluates every declared output on a :class:`Body`; ``row()`` -> {column: value}."""

    def __init__(self, outputs: dict, body: Body, facet_tags, groups: dict, reactions=None):
        self.outputs, self.body = outputs, body
        self.facet_tags, self.groups = facet_tags, groups
        self.reactions = reactions or {}          # (group, component) -> owned dof indices
        self.history: dict[str, list[float]] = {}
        self.times: list[float] = []
        self.profiles: dict[str, list[tuple[float, np.ndarray, np.ndarray]]] = {}
        self._nodes = {}
        self._expressions = {}       # name -> parsed expression of t and earlier one-column outputs
        for name, o in outputs.items():
            if o.quantity == "expression":
                symbols = ("t",) + tuple(n for n, p in outputs.items() if len(column_names(n, p)) == 1)
                self._expressions[name] = parse_expression(o.expression, f"outputs.{name}.expression", symbols)
            if o.quantity in ("extent", "thickness") and o.group is not None:
                self._nodes[name] = body.group_nodes(facet_tags, groups[o.group][1])
            if o.quantity == "thickness":
                self._nodes[name + "/opposite"] = body.group_nodes(facet_tags, groups[o.opposite][1])
                self.profiles[name] = []
            if o.quantity in ("displacement", "position"):
                self._nodes[name] = self._nearest_node(np.asarray(o.point))

    def _nearest_node(self, p):
        X = self.body.X[: self.body.n_owned_nodes]
        d = np.linalg.norm(X - p, axis=1) if len(X) else np.array([np.inf])
        i = int(np.argmin(d))
        best = self.body.comm.allreduce((float(d[i]), self.body.comm.rank), op=MPI.MINLOC)
        return np.array([i] if self.body.comm.rank == best[1] and len(X) else [], dtype=np.int64)

    # -- one output -------------------------------------------------------------------------
    def value(self, name, o, time, row):
        """The output's column value(s) at ``time``; ``row``: the columns measured so far in this row
        (``{output name: value}`` of one-column outputs, read by expressions)."""
        b, comm = self.body, self.body.comm
        q = o.quantity
        if q == "reaction":
            f = b.reaction(self.reactions[(o.group, o.component)])
            return [o.scale * f / (1e3 if o.unit == "kN" else 1.0)]
        if q == "tool_force":
            f = b.tool_force(o.tool)[b.component(o.component)]
            return [o.scale * f / (1e3 if o.unit == "kN" else 1.0)]
        if q == "tool_displacement":
            return [o.scale * float(b.tool_translation(o.tool, time)[b.component(o.component)])]
        if q == "expression":
            return [float(self._expressions[name].evaluate(t=time, **row))]
        if q in ("displacement", "position"):
            nodes = self._nodes[name]
            c = b.component(o.component)
            x = b.positions()[nodes, c]
            if q == "displacement":
                x = o.scale * (x - b.X[nodes, c])
            return [comm.allreduce(float(x[0]) if len(x) else 0.0, op=MPI.SUM)]
        if q == "extent":
            x = b.positions()[: b.n_owned_nodes]
            nodes = self._nodes.get(name)
            x = x if nodes is None else x[nodes]
            # radial: distance from the z axis (3-D), r itself in axisymmetry
            vals = (np.hypot(x[:, 0], x[:, 1]) if o.component == "radial" and x.shape[1] == 3 else
                    x[:, 0] if o.component == "radial" else x[:, b.component(o.component)])
            if o.which == "max":
                return [comm.allreduce(float(vals.max()) if vals.size else -np.inf, op=MPI.MAX)]
            return [comm.allreduce(float(vals.min()) if vals.size else np.inf, op=MPI.MIN)]
        if q == "field":
            qm = b.qmap
            vals = (qm.eqps if o.field == "eqps" else qm.temperature if o.field == "temperature"
                    else von_mises(qm.tau_values))
            if o.regions is not None:
                cells = np.concatenate([b.cell_regions[r] for r in o.regions])
                vals = vals.reshape(-1, qm.nq)[cells]
            vals = np.asarray(vals).reshape(-1)
            if o.which == "max":
                return [comm.allreduce(float(vals.max()) if vals.size else -np.inf, op=MPI.MAX)]
            return [comm.allreduce(float(vals.min()) if vals.size else np.inf, op=MPI.MIN)]
        if q == "energy":
            e = b.energies()
            keys = ENERGIES if o.energy == "all" else (o.energy,)
            return [e[k] if k == "balance_error" else o.scale * e[k] * N_MM_TO_J for k in keys]
        return []

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
        self.times.append(float(time))
        return out

    # -- thickness profiles -----------------------------------------------------------------
    def thickness(self, name) -> tuple[np.ndarray, np.ndarray]:
        """(reference coordinate along the group, ln(t / t0)) at the group's nodes, all ranks.
        The facing node is matched by the reference coordinate along the group (interpolated)."""
        a, c = self._gather(self._nodes[name]), self._gather(self._nodes[name + "/opposite"])
        # along: the coordinate in which the group extends most
        ax = int(np.argmax(np.ptp(a[:, :2], axis=0))) if len(a) > 1 else 0
        a = a[np.argsort(a[:, ax], kind="stable")]
        c = c[np.argsort(c[:, ax], kind="stable")]
        s = a[:, ax]
        if len(c) == len(a) and np.allclose(c[:, ax], s, atol=1e-8 * max(1.0, np.abs(s).max())):
            X2, x2 = c[:, :2], c[:, 2:4]
        else:
            X2 = np.column_stack([np.interp(s, c[:, ax], c[:, k]) for k in (0, 1)])
            x2 = np.column_stack([np.interp(s, c[:, ax], c[:, k]) for k in (2, 3)])
        t0 = np.linalg.norm(X2 - a[:, :2], axis=1)
        t = np.linalg.norm(x2 - a[:, 2:4], axis=1)
        return s, np.log(t / t0)

    def _gather(self, nodes):
        b = self.body
        x = b.positions()[nodes]
        a = np.hstack([b.X[nodes], x]) if len(nodes) else np.zeros((0, 4))
        a = np.vstack(b.comm.allgather(a))
        _, keep = np.unique(np.round(a[:, :2], 9), axis=0, return_index=True)
        return a[np.sort(keep)]

    def record_profiles(self, time: float):
        for name in self.profiles:
            s, v = self.thickness(name)
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
            if o.quantity == "thickness":
                if not self.profiles[name]:
                    continue
                for i, (t, s, v) in enumerate(self.profiles[name]):
                    tag = "" if i == len(self.profiles[name]) - 1 else f"_at_{time_label}_{t:g}"
                    k = int(np.argmin(v))
                    res[f"min_{name}{tag}"] = float(v[k])
                    res[f"s0_of_min_{name}{tag}_mm"] = float(s[k])
                    res[f"{name}_at_start{tag}"] = float(v[0])
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

    def study_keys(self) -> dict:
        """summary.json's key_results / info_results / references (read by `fenics-plast study`)."""
        return study_keys(self.outputs)


def study_keys(outputs: dict) -> dict:
    """key_results / info_results (summary.json keys of the declared outputs, key ones first listed
    in ``key_results``) and references ({summary key: {value, source}}) of ``outputs``."""
    key, info, refs = [], [], {}
    for name, o in outputs.items():
        if o.quantity == "thickness":
            cols = [f"min_{name}", f"{name}_at_start"]
        else:       # the summary entries, in the order `summary` lists them
            cols = [c if w == "final" else f"{w}_{c}" for c in column_names(name, o) for w in o.summary]
            if o.at_max_of is not None:
                cols.append(f"{column_names(name, o)[0]}_at_max_"
                            f"{column_names(o.at_max_of, outputs[o.at_max_of])[0]}")
        (key if o.key else info).extend(cols)
        if o.reference is not None and cols:
            refs[cols[0]] = dict(value=o.reference, source=o.reference_source)
    return dict(key_results=key, info_results=info, references=refs)
