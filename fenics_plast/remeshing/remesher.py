"""When and how a running 2-D analysis is meshed anew: the part of remeshing that does not depend on
the solver (issue 35; the runners rebuild their solvers on the new mesh,
:func:`fenics_plast.runner_static_remesh.remeshed`, :func:`fenics_plast.runner_explicit_remesh.remeshed_explicit`).

A :class:`Remesher` is built from the scene's ``[remeshing]`` table. After every converged increment
the runner asks :meth:`Remesher.due` with the deformed node positions: the worst cell's scaled
Jacobian and corner angle (:mod:`~fenics_plast.remeshing.quality`) against the table's thresholds,
or ``every`` increments since the last remesh. :meth:`Remesher.new_mesh` meshes the deformed outline
(:mod:`~fenics_plast.remeshing.outline`, :mod:`~fenics_plast.remeshing.new_mesh`) at ``size`` [mm],
``refine_size`` [mm] near the outline's corners (the vertices where the deformed boundary turns by
more than ``corner_angle``: where it wraps a tool edge or folds); :meth:`Remesher.transfer` carries
the quadrature state (:class:`~fenics_plast.remeshing.transfer.StateTransfer`). Each remesh is kept
as a :class:`RemeshRecord` for the history, the log and summary.json (:meth:`Remesher.summary`).
"""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field

import numpy as np

from .new_mesh import RemeshError, mesh_outline
from .outline import outline
from .quality import Thresholds, mesh_quality, reference_orientation
from .transfer import StateTransfer

__all__ = ["Remesher", "RemeshRecord", "outline_corners", "carry_displacement", "MIN_EDGE"]

#: old boundary vertices nearer than this times the smallest cell size to their kept neighbour are
#: dropped from a new outline: material flowing round a tool edge crowds the old boundary facets, and
#: keeping them all would force ever smaller cells (measured on demos/backward_extrusion.toml: 800 ->
#: 18448 cells in 7 remeshes, the new meshes' worst scaled Jacobian 0.003)
MIN_EDGE = 0.5
#: the deformed outline's coordinates are rounded to this many decimals [mm] (1 nm) before Gmsh meshes it:
#: serial and parallel runs reach the same deformed shape to round-off only (1e-13 mm), and Gmsh's
#: Frontal-Delaunay and Blossom turn such a difference into another mesh (measured on the backward
#: extrusion: 2313 cells serially, 2315 on 2 ranks at the third remesh, forces 1e-5 apart after it)
OUTLINE_DECIMALS = 6
#: a new mesh whose worst cell is already beyond a threshold is remeshed only once that cell has got worse
#: by this much (its scaled Jacobian) or these degrees (its largest corner angle)
FRESH_MARGIN_SJ = 0.1
FRESH_MARGIN_DEG = 5.0


@dataclass
class RemeshRecord:
    """One remesh: ``number`` (1, 2, ...), the load or time ``at`` which it was made, ``reason`` (the
    threshold passed, "every N increments" or the failed increment's message), the old and new cell
    counts, the worst old and new cells (``old_quality`` / ``new_quality``: min scaled Jacobian, max
    corner angle [deg]), where the time went [s] (``mesh_s``: outline and Gmsh; ``transfer_s``;
    ``rebuild_s``: the solver on the new mesh; ``equilibrium_s``), the re-equilibration's Newton
    iterations (static runs), the transfer report (:class:`~fenics_plast.remeshing.transfer.TransferReport`),
    the jump of the one-column outputs across the remesh (``jump``: {output: (before, after)}) and, in
    explicit runs, of the kinetic and elastic energy (``energy_jump``: {energy: (before, after)} [J])."""
    number: int
    at: float
    reason: str
    old_cells: int
    new_cells: int = 0
    old_quality: tuple = ()
    new_quality: tuple = ()
    mesh_s: float = 0.0
    transfer_s: float = 0.0
    rebuild_s: float = 0.0
    equilibrium_s: float = 0.0
    equilibrium_iterations: int | None = None
    transfer: dict = field(default_factory=dict)
    jump: dict = field(default_factory=dict)
    energy_jump: dict = field(default_factory=dict)

    @property
    def seconds(self) -> float:
        return self.mesh_s + self.transfer_s + self.rebuild_s + self.equilibrium_s

    def line(self) -> str:
        """The record in one log line."""
        jumps = ", ".join(f"{k} {a:.5g} -> {b:.5g}" for k, (a, b) in {**self.energy_jump, **self.jump}.items())
        equilibrium = ("" if self.equilibrium_iterations is None else
                       f", equilibrium in {self.equilibrium_iterations} Newton iterations")
        return (f"remesh {self.number} at {self.at:.6g} ({self.reason}): {self.old_cells} -> {self.new_cells} cells, "
                f"worst scaled Jacobian {self.old_quality[0]:.3g} -> {self.new_quality[0]:.3g}{equilibrium}, "
                f"{self.seconds:.2f} s" + (f"; {jumps}" if jumps else ""))


def carry_displacement(b, u_before) -> None:
    """Give the build ``b`` of a new mesh the displacement ``u_before`` (its CG1 space's local entries,
    owned and ghost, [mm]) from the first mesh's reference to its own nodes: ``b.u_before``, and
    ``b.body.X`` = its nodes minus that, the reference the outputs measure from (nearest nodes,
    displacements, thicknesses)."""
    b.u_before = np.asarray(u_before, dtype=float).copy()
    b.body.X = b.body.X - b.u_before.reshape(b.body.X.shape)


def outline_corners(out, corner_deg: float) -> np.ndarray:
    """(k, 2) [mm] the vertices of the outline ``out`` where the boundary turns by more than
    ``corner_deg`` [deg] between its two facets, and those where more than two facets meet (region
    interfaces); (0, 2) on the ranks without the outline."""
    seg = np.asarray(out.segments)
    if len(seg) == 0:
        return np.zeros((0, 2))
    p = np.asarray(out.points)
    count = np.bincount(seg.reshape(-1), minlength=len(p))
    incoming = np.full(len(p), -1)
    outgoing = np.full(len(p), -1)
    incoming[seg[:, 1]] = np.arange(len(seg))
    outgoing[seg[:, 0]] = np.arange(len(seg))
    two = (count == 2) & (incoming >= 0) & (outgoing >= 0)
    corner = count > 2
    v = np.flatnonzero(two)
    a = p[seg[incoming[v], 1]] - p[seg[incoming[v], 0]]
    b = p[seg[outgoing[v], 1]] - p[seg[outgoing[v], 0]]
    cos = np.einsum("ij,ij->i", a, b) / np.maximum(np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1), 1e-300)
    corner[v] = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))) > corner_deg
    # a vertex whose two facets both start (or end) there: orientation unknown, take the unsigned turn
    odd = np.flatnonzero((count == 2) & ~two)
    for i in odd:
        e = seg[np.any(seg == i, axis=1)]
        d = [p[s[1] if s[0] == i else s[0]] - p[i] for s in e]
        c = np.dot(d[0], d[1]) / max(np.linalg.norm(d[0]) * np.linalg.norm(d[1]), 1e-300)
        corner[i] = 180.0 - np.degrees(np.arccos(np.clip(c, -1.0, 1.0))) > corner_deg
    return p[corner]


class Remesher:
    """The remeshing of one run, from the validated ``[remeshing]`` table ``spec`` (sizes [mm],
    thresholds, ``every``, ``max_remeshes``); ``axisymmetric``: volumes weighted by r in the transfer."""

    def __init__(self, spec, axisymmetric: bool):
        self.spec = spec
        self.axisymmetric = axisymmetric
        self.thresholds = Thresholds(min_scaled_jacobian=spec.min_scaled_jacobian, max_angle_deg=spec.max_angle)
        self.records: list[RemeshRecord] = []
        self.fresh = None                   # (min scaled Jacobian, max angle [deg]) of the last new mesh
        self.increments_since = 0
        self._orientation = None            # (mesh, the reference cells' senses) of the current mesh

    @property
    def count(self) -> int:
        return len(self.records)

    def quality(self, mesh, x):
        """:func:`~fenics_plast.remeshing.quality.mesh_quality` of ``mesh`` deformed to ``x`` against this
        run's thresholds (collective)."""
        if self._orientation is None or self._orientation[0] is not mesh:
            self._orientation = (mesh, reference_orientation(mesh))
        return mesh_quality(mesh, x, self.thresholds, self._orientation[1])

    def due(self, mesh, x) -> str:
        """Why ``mesh`` deformed to ``x`` ((local geometry nodes, 2) [mm]) should be meshed anew after
        this converged increment, "" when it should not (counts the increment; collective)."""
        self.increments_since += 1
        q = self.quality(mesh, x)
        if q.remesh and self._worse_than_fresh(q):
            return q.reason
        every = self.spec.get("every")          # (static only)
        if every and self.increments_since >= every:
            return f"every {every} increments"
        return ""

    def _worse_than_fresh(self, q) -> bool:
        """Whether the worst cell ``q`` is worse than the worst cell of the mesh as it was made by a
        margin (:data:`FRESH_MARGIN_DEG` in angle, the scaled Jacobian down by :data:`FRESH_MARGIN_SJ`):
        a new mesh whose outline has a vertex of nearly 180 deg (or a sharp notch) starts beyond a
        threshold, and remeshing it at once would make the same cell again."""
        if self.fresh is None:
            return True
        sj, angle = self.fresh
        return q.min_scaled_jacobian < sj - FRESH_MARGIN_SJ or q.max_angle_deg > angle + FRESH_MARGIN_DEG

    def volumes(self, mesh, x, degree: int, binv) -> tuple[float, float]:
        """(the body's volume [mm^3] (axisymmetric: 2 pi r dA; plane strain: per mm), the same with each
        point's elastic dilatation taken out, sum of dv / J_e with J_e = det(b_e^-1)^(-1/2)) of ``mesh``
        deformed to ``x`` (None: as it stands), ``binv`` (points, 3, 3) at its owned points. The second is
        the volume the body would have unloaded: the first mesh's volume, whatever remeshing did, for a
        plastic flow that keeps volume (the isochoric model); its change measures what remeshing lost or
        added. Collective."""
        from mpi4py import MPI
        from .transfer import point_volumes
        dv, dV0 = point_volumes(mesh, degree, self.axisymmetric, binv, x)
        local = np.array([dv.sum(), dV0.sum()])
        return tuple(float(v) for v in mesh.comm.allreduce(local, op=MPI.SUM))

    def check_budget(self) -> str | None:
        """The message that stops the run when ``max_remeshes`` remeshes have been made, else None."""
        if self.count >= self.spec.max_remeshes:
            return (f"remeshing.max_remeshes = {self.spec.max_remeshes} remeshes made: the mesh keeps distorting "
                    f"faster than it is renewed (try a smaller remeshing.refine_size or analysis.max_increment)")
        return None

    def new_mesh(self, mesh, cell_tags, facet_tags, groups, x, group_facets=None, fits=None):
        """The outline of ``mesh`` deformed to ``x`` meshed anew
        (:class:`~fenics_plast.remeshing.new_mesh.Remeshed`; RemeshError on every rank when Gmsh or the
        outline fails; collective). ``fits``: {facet group: gap function of (k, 2) points [mm]}, the
        groups in contact with a rigid tool, whose new boundary follows the tool where an old facet cut
        across it (:func:`~fenics_plast.remeshing.new_mesh.fitted_chain`)."""
        try:
            out, why = outline(mesh, cell_tags, facet_tags, groups, x=x, group_facets=group_facets), None
        except (KeyError, IndexError, ValueError) as e:     # rank 0: the boundary walk met a folded cell
            out, why = None, f"{type(e).__name__}: {e}"
        why = mesh.comm.bcast(why, root=0)
        if why is not None:
            raise RemeshError(f"the deformed outline could not be traced (a folded cell on the boundary?): {why}; "
                              f"remesh earlier (a larger remeshing.min_scaled_jacobian)")
        out.points = np.round(out.points, OUTLINE_DECIMALS)
        spec = self.spec
        corners = outline_corners(out, spec.corner_angle) if spec.refine_size is not None else ()
        return mesh_outline(mesh.comm, out, spec.size, h_min=spec.refine_size, refine_points=corners,
                            radius=2.0 * spec.size, min_edge=MIN_EDGE * (spec.refine_size or spec.size), fits=fits)

    def transfer(self, mesh, x, degree: int, old_state: dict, new_mesh):
        """(the state at ``new_mesh``'s owned quadrature points, the report as a dict, the
        :class:`StateTransfer`, for further fields) from ``old_state`` on ``mesh`` deformed to ``x``."""
        t = StateTransfer(mesh, degree=degree, axisymmetric=self.axisymmetric, x=x)
        state, report = t.quadrature_state(old_state, new_mesh)
        return state, report.as_dict(), t

    def start(self, at: float, reason: str, old_cells: int, old_quality) -> RemeshRecord:
        rec = RemeshRecord(len(self.records) + 1, float(at), reason, int(old_cells),
                           old_quality=(old_quality.min_scaled_jacobian, old_quality.max_angle_deg))
        self.records.append(rec)
        self.increments_since = 0
        return rec

    def state_dict(self) -> dict:
        """What a checkpoint keeps of this remesher (JSON-able): its records, the last new mesh's worst
        cell, the increments since, the first mesh's volumes."""
        return dict(records=[asdict(r) for r in self.records], fresh=self.fresh, increments_since=self.increments_since,
                    initial_volumes=getattr(self, "initial_volumes", None))

    def load_state(self, d: dict) -> None:
        """Restore :meth:`state_dict`."""
        self.records = [RemeshRecord(**r) for r in d["records"]]
        self.fresh = None if d["fresh"] is None else tuple(d["fresh"])
        self.increments_since = int(d["increments_since"])
        if d.get("initial_volumes") is not None:
            self.initial_volumes = tuple(d["initial_volumes"])

    def summary(self, volumes=None) -> dict:
        """summary.json's entries: ``remeshes``, ``remesh_time_s``, per remesh its record, and with
        ``volumes`` ((first volume, its stress-free volume), (last volume, its stress-free volume)
        [mm^3], :meth:`volumes`) the volume change and the part of it that elasticity does not explain
        (``volume_change_unexplained``: relative change of the stress-free volume)."""
        out = dict(remeshes=self.count, remesh_time_s=round(sum(r.seconds for r in self.records), 4))
        if volumes is not None:
            (v0, f0), (v1, f1) = volumes
            out.update(volume_initial_mm3=v0, volume_final_mm3=v1, volume_change=(v1 - v0) / v0,
                       volume_change_elastic=(v1 - f1) / v0, volume_change_unexplained=(f1 - f0) / f0)
        out["remesh_records"] = [{k: v for k, v in asdict(r).items() if v is not None} for r in self.records]
        return out


def timed():
    """A stopwatch: ``lap()`` returns the seconds since the last lap (or the start)."""
    class Stopwatch:
        def __init__(self):
            self.t = time.perf_counter()

        def lap(self):
            now = time.perf_counter()
            dt, self.t = now - self.t, now
            return dt
    return Stopwatch()
