"""Checkpoints of long runs, and resuming a killed run (``fenics-plast run ... --resume DIR``).

A checkpoint lives in ``DIR/checkpoint/`` (DIR: the run's output directory) and is two kinds of files:

* ``ckpt_<counter>.rank<r>.npz`` (one per MPI rank): the rank's rows of the distributed arrays
  (displacements, velocities, quadrature-point state, contact history), each row with a key that
  names its node, cell or quadrature point independently of the mesh partition (:class:`Keyed`);
* ``ckpt_<counter>.json``, the manifest, written by rank 0 LAST, after every rank's file is on disk
  (fsync) and a barrier. It names the rank files (size, sha256), the number of ranks, the format
  version :data:`FORMAT`, the scene settings that matter (:func:`scene_settings`), the JSON state
  (run-loop variables, history lists of the runner, solver records) and the history.csv rows written
  so far.

Every file is written to a temporary name, fsynced and renamed (``os.replace``), so a killed run
leaves either a complete file or a temporary one, never a truncated file under its final name; and a
checkpoint without a manifest does not exist as far as :meth:`Checkpointer.load` is concerned. The
two newest complete checkpoints are kept (the older ones are deleted after a new manifest is in
place); a run that ends successfully removes its checkpoint files (:meth:`Checkpointer.clear`, called
by the CLI after summary.json), and a fresh run removes those of an earlier run. Only files named as
a checkpointer names them (:func:`own_files`) are ever deleted, and the directory only when nothing
else is left in it.

Fingerprint: the manifest carries the problem's :func:`fingerprint` (the run's
``RunOutput.fingerprint``, set by the CLI): sha256 of the mesh (:func:`mesh_fingerprint`, the same on
any number of ranks) and of every file the mesh is read from (the mesh file, its Includes and
Merges, named relative to the scene's folder: :func:`file_label`). A resumed run whose mesh or mesh
files differ is refused (:func:`check_fingerprint`).

Resuming reads the newest complete checkpoint whose rank files verify (size and sha256; an older one
otherwise, with a warning on stderr and in summary.json "warnings") and refuses, with
:class:`CheckpointError`, when the number of ranks, the scene settings (mesh, material, loading,
solver, ...; not ``output.xdmf|every|plots|checkpoint_every`` nor ``scene.description``) or the
format differ. history.csv is rewritten from the checkpoint's rows,
so rows a killed run wrote after its last checkpoint are dropped, not duplicated.

State layout: :meth:`Checkpointer.save` takes named groups (``solver``, ``loop``, ``runner``, ...),
each a dict. :class:`Keyed` values (rows + int64 keys, owned rows only) go to the rank's npz file
as ``group.key`` and ``group.key@keys``; every other value (numbers, strings, lists, dicts) must be
JSON-able and identical on all ranks (reduce rank-local sums first), and goes to the manifest.
:meth:`Checkpointer.load` returns the same groups, a :class:`Keyed` value as a :class:`KeyedTable`
whose ``take(keys)`` gives the rows of the keys this rank owns now, wherever they were saved:
dolfinx does not always partition a mesh the same way twice under MPI (measured: 1 of 16 runs of
the Taylor bar on 2 ranks swapped the halves and renumbered them), so rows are matched by key, not
by position. Keys: :func:`dof_keys` (input node index or original cell index, times 16, plus the
component), :func:`qp_keys` (original cell index times the points per cell plus the point).

Test hook (tests/test_checkpoint.py): ``FENICS_PLAST_KILL_AFTER_CHECKPOINTS=N`` ends the process
with ``os._exit(137)`` on every rank, no clean-up, right after the N-th checkpoint of the process is
complete (``FENICS_PLAST_KILL_POINT=after``, default) or at the (N+1)-th checkpoint after its rank
files are written and before its manifest (``FENICS_PLAST_KILL_POINT=during``).

This module imports no dolfinx (the key helpers read the dolfinx objects they are given; ufl is
imported when needed) and knows no physics; ``comm`` is an mpi4py communicator or None (serial).
"""
from __future__ import annotations

import hashlib
import io
import json
import os
import re
import sys
import time
from pathlib import Path
from typing import Any, Mapping

import numpy as np

__all__ = ["FORMAT", "CheckpointError", "Checkpointer", "Keyed", "KeyedTable", "scene_settings", "check_resume",
           "write_atomic", "dof_keys", "qp_keys", "cell_keys", "owned_keyed", "set_owned", "raise_on_any",
           "DIRNAME", "mesh_fingerprint", "file_digest", "file_label", "fingerprint", "check_fingerprint", "own_files",
           "remove_own"]

#: version of the checkpoint layout; bump it when a solver's state_dict changes meaning
FORMAT = 3
DIRNAME = "checkpoint"
#: output keys that do not change the numbers (a resumed run may change them)
FREE_KEYS = {("scene", "description"), ("output", "xdmf"), ("output", "every"), ("output", "plots"),
             ("output", "checkpoint_every")}
KEEP = 2            # complete checkpoints kept on disk
_NAME = re.compile(r"^ckpt_(\d+)\.json$")
#: every file a checkpointer writes: manifests, rank files, and their temporary names (write_atomic)
_OWN = re.compile(r"^(ckpt_\d+\.(json|rank\d+\.npz)|\.ckpt_\d+\.(json|rank\d+\.npz)\.tmp\d+)$")
KILL_ENV = "FENICS_PLAST_KILL_AFTER_CHECKPOINTS"
KILL_POINT_ENV = "FENICS_PLAST_KILL_POINT"


class CheckpointError(RuntimeError):
    """A run cannot be resumed from a checkpoint (the message says why)."""


SLOTS = 16      # key = entity key * SLOTS + component slot (components of all sub-spaces < SLOTS)


class Keyed:
    """A distributed array to checkpoint: ``values`` (n, ...) and int64 ``keys`` (n,), one key per
    row naming what the row belongs to independently of the partition (owned rows only)."""

    def __init__(self, values, keys):
        self.values = np.asarray(values)
        self.keys = np.asarray(keys, dtype=np.int64)
        if self.values.shape[:1] != self.keys.shape:
            raise ValueError(f"Keyed: {self.values.shape[0]} rows but {self.keys.size} keys")


class KeyedTable:
    """The rows of one :class:`Keyed` array gathered from every rank file of a checkpoint."""

    def __init__(self, name, values, keys):
        self.name = name
        keys, first = np.unique(keys, return_index=True)
        self.keys = keys
        self.values = values[first]

    def take(self, keys) -> np.ndarray:
        """Rows for ``keys`` (in that order). Raises CheckpointError (rank-local) for a key the
        checkpoint does not hold: another mesh."""
        keys = np.asarray(keys, dtype=np.int64)
        pos = np.searchsorted(self.keys, keys)
        pos[pos >= self.keys.size] = 0
        missing = int(np.count_nonzero(self.keys[pos] != keys)) if self.keys.size else keys.size
        if missing:
            raise CheckpointError(f"the checkpoint's {self.name} has no values for {missing} of this rank's "
                                  f"{keys.size} nodes/cells/points: another mesh")
        return self.values[pos]


def cell_keys(mesh) -> np.ndarray:
    """Original (input) index of every local cell, owned then ghost, int64."""
    return np.asarray(mesh.topology.original_cell_index, dtype=np.int64)


def qp_keys(mesh, n_owned_cells: int, nq: int) -> np.ndarray:
    """Keys of the owned quadrature points laid out cell by cell (n_owned_cells * nq,)."""
    oc = cell_keys(mesh)[:n_owned_cells]
    return (oc[:, None] * nq + np.arange(nq)[None, :]).reshape(-1)


def dof_keys(space) -> np.ndarray:
    """Key of every local entry (owned then ghost, unrolled: block * bs + component) of a dolfinx
    function space's array: continuous degree-1 (nodes of a first-order mesh: the input node index)
    and degree-0 (cells: the original cell index) spaces, blocked or not, and mixed spaces of them."""
    from fenics_plast import dolfinx_compat as dc
    kind = dc.space_kind(space)
    dm = space.dofmap
    n_local = (dm.index_map.size_local + dm.index_map.num_ghosts) * dm.index_map_bs
    if kind == "mixed":
        keys = np.full(n_local, -1, dtype=np.int64)
        offset = 0
        for i in range(space.num_sub_spaces):
            sub, parent = space.sub(i).collapse()
            k = dof_keys(sub)
            keys[np.asarray(parent)] = k + offset
            offset += sub.dofmap.index_map_bs
        if offset > SLOTS:
            raise ValueError(f"dof_keys: {offset} components, at most {SLOTS}")
        return keys
    mesh = space.mesh
    bs = dm.index_map_bs
    nblocks = dm.index_map.size_local + dm.index_map.num_ghosts
    cells = dc.cell_dofs(space)
    base = np.full(nblocks, -1, dtype=np.int64)
    if kind == "degree 0":
        base[cells[:, 0]] = cell_keys(mesh)[: cells.shape[0]]
    elif kind == "continuous degree 1":
        gd = dc.geometry_dofs(mesh)
        if gd.shape != cells.shape:
            raise ValueError("dof_keys: the space's nodes are not the mesh's geometry nodes")
        base[cells.reshape(-1)] = np.asarray(mesh.geometry.input_global_indices, dtype=np.int64)[gd.reshape(-1)]
    else:
        raise ValueError(f"dof_keys: unsupported element {space.ufl_element()} (degree-1 continuous or degree-0 only)")
    if (base < 0).any() or bs > SLOTS:
        raise ValueError("dof_keys: could not key every dof")
    return (base[:, None] * SLOTS + np.arange(bs)[None, :]).reshape(-1)


def mesh_fingerprint(mesh) -> str:
    """sha256 (hex) of a dolfinx mesh that does not depend on the partition (collective; every rank
    gets it): the node coordinates (float64) ordered by input node index, then each cell's original
    index and its nodes' input indices, in original cell order. Gathered on rank 0."""
    from fenics_plast import dolfinx_compat as dc
    comm = mesh.comm
    n_own = mesh.topology.index_map(mesh.topology.dim).size_local
    nodes = np.asarray(mesh.geometry.input_global_indices, dtype=np.int64)
    x = np.asarray(mesh.geometry.x, dtype=np.float64)
    conn = nodes[np.asarray(dc.geometry_dofs(mesh))[:n_own]]
    parts = comm.gather((nodes, x, cell_keys(mesh)[:n_own], conn), root=0)
    digest = None
    if comm.rank == 0:
        keys = np.concatenate([p[0] for p in parts])
        keys, first = np.unique(keys, return_index=True)
        xs = np.concatenate([p[1] for p in parts])[first] + 0.0      # + 0.0: a -0.0 hashes as 0.0
        cells = np.concatenate([p[2] for p in parts])
        order = np.argsort(cells, kind="stable")
        cc = np.concatenate([p[3] for p in parts])[order]
        h = hashlib.sha256()
        for a in (keys, xs, cells[order], cc):
            h.update(str(a.shape).encode())
            h.update(np.ascontiguousarray(a).astype(a.dtype.newbyteorder("<")).tobytes())
        digest = h.hexdigest()
    return comm.bcast(digest, root=0)


def file_digest(path) -> str:
    """sha256 (hex) of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def file_label(path, scene_dir=None) -> str:
    """How a fingerprint names a mesh file: its path relative to the scene's folder ``scene_dir`` when it
    lies there, ``<meshes>/...`` in the package's meshes/, else the absolute path; so a project folder
    (scene, mesh files and results) moved elsewhere resumes as it was."""
    from .geo_screen import MESH_DIR
    path = Path(path).absolute()
    for root, prefix in ((scene_dir, ""), (MESH_DIR, "<meshes>/")):
        if root is None:
            continue
        try:
            return prefix + path.relative_to(Path(root).absolute()).as_posix()
        except ValueError:
            pass
    return str(path)


def fingerprint(mesh, files, scene_dir=None) -> dict:
    """The problem's fingerprint for checkpoints (collective): ``{"mesh": mesh_fingerprint(mesh),
    "files": {label: sha256}}`` of the files the mesh is read from (``files``: paths, read on rank 0;
    labels: :func:`file_label` against ``scene_dir``)."""
    comm = mesh.comm
    digests = None
    if comm.rank == 0:
        digests = {}
        for f in files:
            try:
                digests[file_label(f, scene_dir)] = file_digest(f)
            except OSError as e:
                digests[file_label(f, scene_dir)] = f"unreadable: {e.strerror or e}"
    return {"mesh": mesh_fingerprint(mesh), "files": comm.bcast(digests, root=0)}


def check_fingerprint(out_dir, manifest: Mapping, now: Mapping | None) -> None:
    """Raise :class:`CheckpointError` saying what changed when the problem's fingerprint ``now``
    (:func:`fingerprint`) differs from the checkpoint manifest's (a mesh file edited, added or no
    longer read; the mesh itself). Nothing is checked when either is missing."""
    then = manifest.get("fingerprint")
    if not now or not then:
        return
    what = []
    a, b = dict(now.get("files") or {}), dict(then.get("files") or {})
    for f in sorted(set(a) | set(b)):
        if f not in a:
            what.append(f"the mesh was read from {f} then, not now")
        elif f not in b:
            what.append(f"the mesh is read from {f} now, not then")
        elif a[f] != b[f]:
            what.append(f"the mesh file {f} was edited (sha256 {b[f][:12]}... then, {a[f][:12]}... now)")
    if now.get("mesh") != then.get("mesh"):
        what.append("the mesh differs (node coordinates or cells)")
    if what:
        raise CheckpointError(f"{out_dir}: the problem changed since the checkpoint was written: {'; '.join(what)}. "
                              f"A resumed run needs the same mesh: restore the file, or rerun from the start "
                              f"(without --resume)")


def own_files(ckdir: Path) -> list[Path]:
    """The files in ``ckdir`` that a checkpointer wrote (manifests, rank files, temporary files): regular
    files only, and none when ``ckdir`` is a link (out_files: nothing is deleted through a link)."""
    ckdir = Path(ckdir)
    if ckdir.is_symlink() or not ckdir.is_dir():
        return []
    return [p for p in ckdir.iterdir() if _OWN.match(p.name) and not p.is_symlink() and p.is_file()]


def remove_own(ckdir: Path) -> None:
    """Delete the checkpointer's files in ``ckdir``, then the folder if nothing else is in it."""
    from .out_files import remove_file
    ckdir = Path(ckdir)
    for p in own_files(ckdir):
        remove_file(p, root=ckdir.parent)
    try:
        ckdir.rmdir()
    except OSError:
        pass


def owned_keyed(fun, keys=None) -> Keyed:
    """The owned entries of a dolfinx Function (unrolled) with their :func:`dof_keys`."""
    dm = fun.function_space.dofmap
    n = dm.index_map.size_local * dm.index_map_bs
    keys = dof_keys(fun.function_space) if keys is None else keys
    return Keyed(fun.x.array[:n].copy(), keys[:n])


def set_owned(fun, values) -> None:
    """The owned entries of a dolfinx Function (unrolled, its first ``len(values)``) set to ``values``, and its
    ghosts updated from their owners (collective): the restore of :func:`owned_keyed`'s values."""
    fun.x.array[: len(values)] = values
    fun.x.scatter_forward()


# ----------------------------------------------------------------------------------------------
# helpers


def _plain(obj: Any) -> Any:
    """JSON-able plain Python (numpy scalars and arrays to numbers and lists; tuples to lists).
    Non-finite floats stay (json writes NaN/Infinity and reads them back)."""
    if isinstance(obj, Mapping):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, np.ndarray):
        return _plain(obj.tolist())
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, (str, int, float, bool)) or obj is None:
        return obj
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    raise TypeError(f"checkpoint state value of type {type(obj).__name__} is not JSON-able: {obj!r}")


def _json_default(obj: Any) -> Any:
    """json.dumps hook for what the C encoder does not know (numpy scalars and arrays, paths)."""
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    raise TypeError(f"checkpoint state value of type {type(obj).__name__} is not JSON-able: {obj!r}")


def write_atomic(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same directory: write, fsync,
    ``os.replace`` (atomic on POSIX), fsync of the directory. A crash leaves the old file or the new
    one under ``path``, never a partial one. Neither the file nor its folder (checkpoint/) may be a
    link (:class:`fenics_plast.out_files.LinkRefused`)."""
    from . import out_files
    path = Path(path)
    out_files.write_atomic(path, data, root=path.parent.parent)


def scene_settings(scene) -> dict:
    """The scene's settings that a resumed run must share with the checkpoint: ``scene.to_dict()``
    (internal units) without :data:`FREE_KEYS`, as plain JSON values."""
    d = _plain(scene.to_dict())
    for sec, key in FREE_KEYS:
        if isinstance(d.get(sec), dict):
            d[sec].pop(key, None)
    return d


def _flat(d: Mapping, prefix: str = "") -> dict[str, Any]:
    out = {}
    for k, v in d.items():
        name = f"{prefix}{k}"
        if isinstance(v, Mapping):
            out.update(_flat(v, name + "."))
        else:
            out[name] = v
    return out


def _settings_diff(now: Mapping, saved: Mapping) -> list[str]:
    a, b = _flat(now), _flat(saved)
    diffs = []
    for k in sorted(set(a) | set(b)):
        if a.get(k, "<absent>") != b.get(k, "<absent>"):
            diffs.append(f"{k} = {a.get(k, '<absent>')!r} (checkpoint: {b.get(k, '<absent>')!r})")
    return diffs


def _manifests(ckdir: Path) -> list[tuple[int, Path]]:
    """(counter, path) of the manifests in ckdir, newest first."""
    if not ckdir.is_dir():
        return []
    found = []
    for p in ckdir.iterdir():
        m = _NAME.match(p.name)
        if m:
            found.append((int(m.group(1)), p))
    return sorted(found, reverse=True)


def _read_manifest(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def _compatibility(manifest: dict, ranks: int, settings: dict, where: Path) -> str | None:
    """Why the manifest cannot be resumed here (None: it can)."""
    fmt = manifest.get("format")
    if fmt != FORMAT:
        return (f"{where}: checkpoint format {fmt!r} was written by another version of fenics-plast; "
                f"this one reads format {FORMAT}. Rerun from the start.")
    if manifest.get("ranks") != ranks:
        return (f"{where}: the checkpoint was written by {manifest.get('ranks')} MPI rank(s), this run has "
                f"{ranks}: resume with `mpirun -n {manifest.get('ranks')}` (the state is stored per rank).")
    diffs = _settings_diff(settings, manifest.get("settings", {}))
    if diffs:
        shown = "; ".join(diffs[:6]) + (f"; ... ({len(diffs)} in all)" if len(diffs) > 6 else "")
        return (f"{where}: the scene settings differ from the checkpoint's: {shown}. Resume with the same "
                f"scene file and --set options (only output.xdmf, every, plots, checkpoint_every may change).")
    return None


def check_resume(out_dir: str | os.PathLike, scene, ranks: int) -> dict:
    """Cheap check before a resumed run starts (no MPI call; every rank reads the same files):
    returns the newest complete manifest, or raises :class:`CheckpointError` saying why ``out_dir``
    cannot be resumed with this scene and number of ranks."""
    out_dir = Path(out_dir)
    ckdir = out_dir / DIRNAME
    if not out_dir.is_dir():
        raise CheckpointError(f"{out_dir}: no such output directory to resume")
    found = _manifests(ckdir)
    if not found:
        if (out_dir / "summary.json").is_file():
            raise CheckpointError(f"{out_dir}: the run has finished (summary.json is there) and left no "
                                  f"checkpoint: nothing to resume")
        raise CheckpointError(f"{out_dir}: no complete checkpoint in {ckdir} (the run was killed before its "
                              f"first checkpoint, or output.checkpoint_every = 0): rerun from the start")
    for counter, path in found:
        m = _read_manifest(path)
        if m is None:
            continue
        why = _compatibility(m, ranks, scene_settings(scene), out_dir)
        if why:
            raise CheckpointError(why)
        if m.get("analysis") != scene.analysis.type:
            raise CheckpointError(f"{out_dir}: the checkpoint is of a {m.get('analysis')!r} analysis, the scene's "
                                  f"is {scene.analysis.type!r}")
        return m
    raise CheckpointError(f"{out_dir}: no readable checkpoint manifest in {ckdir}")


# ----------------------------------------------------------------------------------------------


class Checkpointer:
    """Saves and loads a run's checkpoints in ``out_dir/checkpoint`` (see the module doc).

    Parameters
    ----------
    out_dir : the run's output directory.
    comm : mpi4py communicator or None (serial).
    settings : :func:`scene_settings` of the scene (stored, and compared on resume).
    analysis : the analysis type (static | explicit), checked on resume.
    every : checkpoint every ``every`` steps (explicit) or increments (static); 0: never save.
    resume : this run continues from the newest complete checkpoint (:meth:`load`).
    output : the run's :class:`fenics_plast.output.RunOutput` (its history rows are saved and, on
        resume, written back to history.csv), or None.
    """

    def __init__(self, out_dir, comm, settings: dict, analysis: str, every: int = 0, resume: bool = False,
                 output=None):
        self.dir = Path(out_dir) / DIRNAME
        self.comm = comm
        self.rank = 0 if comm is None else comm.rank
        self.size = 1 if comm is None else comm.size
        self.settings = settings
        self.analysis = analysis
        self.every = int(every)
        self.resuming = bool(resume)
        self.output = output
        self.saved = 0                  # checkpoints completed by this process
        self.write_times: list[float] = []
        self.last_bytes = 0             # all ranks, last checkpoint
        self.resumed_from: int | None = None
        kill = os.environ.get(KILL_ENV)
        self._kill_after = int(kill) if kill else None
        self._kill_point = os.environ.get(KILL_POINT_ENV, "after")
        self.warnings: list[str] = []   # e.g. the newest checkpoint was corrupt (summary.json "warnings")
        if self.rank == 0:
            if not self.resuming:
                remove_own(self.dir)            # a fresh run: stale checkpoints of an earlier run go
            if self.every > 0 or self.resuming:
                from .out_files import make_dir
                self.dir.parent.mkdir(parents=True, exist_ok=True)
                make_dir(self.dir, root=self.dir.parent)        # a link there is refused
        self._barrier()
        if output is not None:
            output.checkpointer = self

    # -- MPI helpers -------------------------------------------------------------------------
    def _barrier(self):
        if self.size > 1:
            self.comm.barrier()

    def _gather_all(self, x):
        return [x] if self.size == 1 else self.comm.allgather(x)

    def _bcast(self, x):
        return x if self.size == 1 else self.comm.bcast(x, root=0)

    def _kill(self):
        os._exit(137)       # test hook: a hard kill, no clean-up, no flush of anything not yet flushed

    # -- saving ------------------------------------------------------------------------------
    def save(self, counter: int, **groups: Mapping[str, Any]) -> Path:
        """Write checkpoint ``counter`` (collective): the arrays of every group to this rank's file,
        then (rank 0, after a barrier) the manifest. Returns the manifest path."""
        t0 = time.perf_counter()
        counter = int(counter)
        arrays, meta = {}, {}
        for g, d in groups.items():
            meta[g] = {}
            for k, v in d.items():
                if isinstance(v, Keyed):
                    arrays[f"{g}.{k}"] = v.values
                    arrays[f"{g}.{k}@keys"] = v.keys
                elif isinstance(v, np.ndarray):
                    raise TypeError(f"checkpoint {g}.{k}: a distributed array must be Keyed (rows named "
                                    f"independently of the partition); global values go as lists")
                else:
                    meta[g][k] = v
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        data = buf.getvalue()
        name = f"ckpt_{counter:09d}.rank{self.rank}.npz"
        write_atomic(self.dir / name, data)
        info = dict(name=name, bytes=len(data), sha256=hashlib.sha256(data).hexdigest())
        files = self._gather_all(info)          # collective: every rank's file is on disk after this
        if self._kill_after is not None and self._kill_point == "during" and self.saved == self._kill_after:
            self._barrier()
            self._kill()
        path = self.dir / f"ckpt_{counter:09d}.json"
        if self.rank == 0:
            manifest = dict(format=FORMAT, analysis=self.analysis, counter=counter, ranks=self.size, files=files,
                            written_unix=time.time(), settings=self.settings, state=meta,
                            fingerprint=getattr(self.output, "fingerprint", None),
                            history_rows=self.output.history_rows if self.output is not None else None)
            write_atomic(path, json.dumps(manifest, default=_json_default).encode("utf-8"))
            self._prune(counter)
        self._barrier()
        self.saved += 1
        self.write_times.append(time.perf_counter() - t0)
        self.last_bytes = sum(f["bytes"] for f in files)
        if self._kill_after is not None and self._kill_point != "during" and self.saved == self._kill_after:
            self._kill()
        return path

    def _prune(self, newest: int):
        """Rank 0: delete the complete checkpoints beyond the KEEP newest (manifest first), and
        leftovers (temporary files, rank files without a manifest) older than the newest."""
        found = _manifests(self.dir)
        keep = {c for c, _ in found[:KEEP]}
        from .out_files import remove_file
        for c, p in found[KEEP:]:
            remove_file(p, root=self.dir.parent)
        for p in self.dir.iterdir():
            m = re.match(r"^\.?ckpt_(\d+)\.", p.name)
            if m and int(m.group(1)) not in keep and int(m.group(1)) < newest:
                remove_file(p, root=self.dir.parent)

    # -- loading -----------------------------------------------------------------------------
    def load(self) -> dict[str, Any]:
        """Read the newest complete checkpoint (collective). Returns ``{"counter": n, group: {...}}``
        with the arrays of this rank and the JSON values; restores the output's history.csv.
        Raises :class:`CheckpointError` (on every rank) when none can be resumed."""
        err, manifests, reasons = None, [], []
        if self.rank == 0:
            found = _manifests(self.dir)
            for c, p in found:
                m = _read_manifest(p)
                if m is not None:
                    manifests.append(m)
                elif not manifests:         # newer than every readable one: a corrupt newest checkpoint
                    reasons.append(f"checkpoint {c}: its manifest {p.name} cannot be read")
            if not manifests:
                err = (f"{self.dir.parent}: no complete checkpoint in {self.dir} (the run was killed before "
                       f"its first checkpoint, or output.checkpoint_every = 0): rerun from the start")
            else:
                err = _compatibility(manifests[0], self.size, self.settings, self.dir.parent)
        err, manifests, reasons = self._bcast((err, manifests, reasons))
        if err:
            raise CheckpointError(err)
        for m in manifests:
            # every rank reads every rank file: the partition of this run may differ from the saved one
            why, parts = None, []
            for info in m["files"]:
                try:
                    data = (self.dir / info["name"]).read_bytes()
                    if len(data) != info["bytes"] or hashlib.sha256(data).hexdigest() != info["sha256"]:
                        why = f"{info['name']} does not match its manifest (size or sha256)"
                        break
                    with np.load(io.BytesIO(data), allow_pickle=False) as z:
                        parts.append({k: z[k] for k in z.files})
                except (OSError, ValueError) as e:
                    why = f"{info['name']}: {e}"
                    break
            whys = [w for w in self._gather_all(why) if w]
            if whys:
                reasons.append(f"checkpoint {m['counter']}: {whys[0]}")
                continue
            state: dict[str, Any] = {"counter": m["counter"]}
            for g, d in m["state"].items():
                state[g] = dict(d)
            for key in parts[0]:
                if key.endswith("@keys"):
                    continue
                g, k = key.split(".", 1)
                state.setdefault(g, {})[k] = KeyedTable(
                    key, np.concatenate([p[key] for p in parts]), np.concatenate([p[key + "@keys"] for p in parts]))
            self.resumed_from = int(m["counter"])
            if reasons:
                msg = (f"warning: {self.dir}: the newest checkpoint could not be used ({'; '.join(reasons)}): "
                       f"resumed from the older checkpoint {m['counter']}")
                self.warnings.append(msg[len("warning: "):])
                if self.rank == 0:              # stderr: seen whatever the progress display
                    print(msg, file=sys.stderr, flush=True)
            if self.output is not None and m.get("history_rows") is not None:
                self.output.restore_history(m["history_rows"])
            return state
        raise CheckpointError(f"{self.dir.parent}: no checkpoint could be read: " + "; ".join(reasons))

    # -- end of run --------------------------------------------------------------------------
    def clear(self):
        """Remove this run's checkpoint files, and the directory when nothing else is in it
        (collective; after a successful run)."""
        self._barrier()
        if self.rank == 0:
            remove_own(self.dir)
        self._barrier()

    def summary(self) -> dict[str, Any]:
        """Checkpoint statistics for summary.json."""
        out = dict(checkpoint_every=self.every, checkpoints_written=self.saved)
        if self.write_times:
            out.update(checkpoint_write_s_mean=float(np.mean(self.write_times)),
                       checkpoint_write_s_max=float(np.max(self.write_times)),
                       checkpoint_bytes=int(self.last_bytes))
        if self.resumed_from is not None:
            out["resumed_from_checkpoint"] = self.resumed_from
        return out


def require(state: Mapping[str, Any], keys, what: str) -> None:
    """Raise CheckpointError if ``state`` lacks one of ``keys`` (a checkpoint of another layout)."""
    missing = [k for k in keys if k not in state]
    if missing:
        raise CheckpointError(f"the checkpoint's {what} state lacks {', '.join(missing)}: written by another "
                              f"version of fenics-plast (format {FORMAT}); rerun from the start")


def raise_on_any(comm, why: str | None) -> None:
    """Collective: raise CheckpointError on every rank if any rank has a reason ``why``."""
    whys = [why] if comm is None or comm.size == 1 else comm.allgather(why)
    whys = [w for w in whys if w]
    if whys:
        raise CheckpointError(whys[0])
