"""Run output: history.csv, other CSV tables, PNG plots, fields.xdmf path, summary.json.

Knows nothing of physics. Rank 0 writes every file except fields.xdmf (written collectively by
dolfinx through :attr:`RunOutput.xdmf_path`). ``comm`` may be an mpi4py communicator or None
(serial, no MPI import).

The output folder (used by the CLI before a run starts, rank 0): :func:`check_out_dir` refuses a
folder a run must not write into (a file, not writable, a non-empty folder that is not a results
folder, another scene's results without ``--overwrite``); :func:`make_out_dir` creates it, the
marker :data:`MARKER` says it is a results folder and of which scene, and the lock :data:`LOCK`
(:mod:`fenics_plast.run_lock`) keeps a second run out while one runs. :func:`file_name_problem`
says why a scene, plot or output name cannot become a file name.
"""
from __future__ import annotations

import csv
import json
import math
import os
from pathlib import Path
from typing import Any, Mapping

import numpy as np

__all__ = ["RunOutput", "to_jsonable", "file_name_problem", "NAME_MAX", "OutputDirError", "MARKER", "LOCK",
           "results_folder_scene", "check_out_dir", "make_out_dir", "remove_created", "mark_results_folder"]


def to_jsonable(obj: Any) -> Any:
    """Plain Python types for json: numpy scalars/arrays, Paths, tuples, sets; non-finite floats -> None."""
    if isinstance(obj, Mapping):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, (list, tuple, set, frozenset)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.generic):
        return to_jsonable(obj.item())
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, (str, int, bool)) or obj is None:
        return obj
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    return str(obj)


def _cell(v: Any) -> Any:
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float):
        return repr(v)
    return v


class RunOutput:
    """Everything a run writes, in one directory.

    * ``history(**row)``: one row of history.csv (header from the first row, flushed every row);
      ``restore_history(rows)`` rewrites it from a checkpoint's rows (resumed runs).
    * ``write_csv(name, columns)``: a table ``name``.csv from ``{column: 1-D array}``.
    * ``xdmf_path``: where fields go (``out_dir/fields.xdmf``).
    * ``finish(summary)``: summary.json, written last and atomically.
    * ``log(msg)``: a progress line on stdout, rank 0 only (through the progress bar if one is on).
    * ``progress(total, label, ...)``: start the run's :class:`fenics_plast.progress.Progress`
      (rank 0 prints); ``end_progress()`` (also done by ``finish``) ends it.
    """

    def __init__(self, out_dir: str | os.PathLike, comm=None, resume: bool = False):
        self.out_dir = Path(out_dir)
        self.comm = comm
        self.rank = 0 if comm is None else comm.rank
        self.size = 1 if comm is None else comm.size
        self.is_root = self.rank == 0
        self.resume = bool(resume)          # continues a killed run from its checkpoint (checkpoint.py)
        self.checkpointer = None            # set by fenics_plast.checkpoint.Checkpointer
        self.fingerprint = None             # the problem's fingerprint (checkpoint.fingerprint): checkpoints carry it
        if self.is_root:
            self.out_dir.mkdir(parents=True, exist_ok=True)
            # a summary.json of an earlier run must not make this one look complete if it is killed
            self.summary_path.unlink(missing_ok=True)
            if self.resume:
                self._keep_fields_before_resume()
        if self.size > 1:
            comm.barrier()
        self._hist_file = None
        self._hist_writer = None
        self._hist_header: list[str] | None = None
        self.history_rows: list[dict] = []  # every row written (checkpoints save them)
        self._progress = None
        self.finished = False

    def _keep_fields_before_resume(self) -> None:
        """Rank 0, resumed run: fields.xdmf/.h5 of the killed run become fields_part<k>.xdmf/.h5 (its
        frames up to the kill); the resumed run writes a new fields.xdmf from the checkpoint on."""
        xdmf, h5 = self.xdmf_path, self.xdmf_path.with_suffix(".h5")
        if not xdmf.is_file():
            return
        k = 1
        while self.out_dir.joinpath(f"fields_part{k}.xdmf").exists():
            k += 1
        new = self.out_dir / f"fields_part{k}.xdmf"
        text = xdmf.read_text(encoding="utf-8", errors="replace")
        if h5.is_file():
            os.replace(h5, new.with_suffix(".h5"))
            text = text.replace(f"{h5.name}:", f"{new.with_suffix('.h5').name}:")
        new.write_text(text, encoding="utf-8")
        xdmf.unlink()

    # -- paths ---------------------------------------------------------------------------------
    @property
    def xdmf_path(self) -> Path:
        return self.out_dir / "fields.xdmf"

    @property
    def history_path(self) -> Path:
        return self.out_dir / "history.csv"

    @property
    def summary_path(self) -> Path:
        return self.out_dir / "summary.json"

    # -- progress ------------------------------------------------------------------------------
    def log(self, msg: str) -> None:
        if self._progress is not None:
            self._progress.write(msg)
        elif self.is_root:
            print(msg, flush=True)

    def progress(self, total: float, label: str = "", **kwargs):
        """Start (replacing any earlier one) and return the run's progress bar; ``kwargs`` go to
        :class:`fenics_plast.progress.Progress` (what, unit, stream, is_tty, ...)."""
        from .progress import Progress
        self.end_progress()
        self._progress = Progress(total, label, comm=self.comm, **kwargs)
        return self._progress

    def end_progress(self) -> None:
        """Close the progress bar (final state, newline on a terminal); no-op without one."""
        if self._progress is not None:
            self._progress.close()
            self._progress = None

    # -- tables --------------------------------------------------------------------------------
    def history(self, **row: Any) -> None:
        """Append one row to history.csv. Later rows may omit columns (left empty) but not add new ones."""
        if self._hist_header is None:
            self._hist_header = list(row)
            if self.is_root:
                self._hist_file = open(self.history_path, "w", newline="", encoding="utf-8")
                self._hist_writer = csv.writer(self._hist_file)
                self._hist_writer.writerow(self._hist_header)
        else:
            extra = [k for k in row if k not in self._hist_header]
            if extra:
                raise ValueError(f"history row has columns {extra} not in the header {self._hist_header}")
        self.history_rows.append({k: (v.item() if isinstance(v, np.generic) else v) for k, v in row.items()})
        if self.is_root:
            self._hist_writer.writerow([_cell(row.get(k, "")) for k in self._hist_header])
            self._hist_file.flush()

    def restore_history(self, rows: list[Mapping[str, Any]]) -> None:
        """Resumed run: history.csv becomes exactly ``rows`` (the rows saved with the checkpoint;
        later rows of the killed run are dropped), written atomically, and later rows append."""
        self.close_history()
        self.history_rows = [dict(r) for r in rows]
        self._hist_header = list(rows[0]) if rows else None
        if self.is_root:
            path = self.history_path
            if rows:
                tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
                with open(tmp, "w", newline="", encoding="utf-8") as f:
                    w = csv.writer(f)
                    w.writerow(self._hist_header)
                    for r in rows:
                        w.writerow([_cell(r.get(k, "")) for k in self._hist_header])
                    f.flush()
                    os.fsync(f.fileno())
                os.replace(tmp, path)
                self._hist_file = open(path, "a", newline="", encoding="utf-8")
                self._hist_writer = csv.writer(self._hist_file)
            else:
                path.unlink(missing_ok=True)

    def close_history(self) -> None:
        if self._hist_file is not None:
            self._hist_file.close()
            self._hist_file = None

    def write_csv(self, name: str, columns: Mapping[str, Any]) -> Path:
        """Write ``name``(.csv) from equal-length 1-D columns. Returns the path."""
        path = self.out_dir / (name if name.endswith(".csv") else name + ".csv")
        cols = {k: np.asarray(v).ravel() for k, v in columns.items()}
        lengths = {k: len(v) for k, v in cols.items()}
        if len(set(lengths.values())) > 1:
            raise ValueError(f"write_csv({name!r}): columns differ in length: {lengths}")
        if self.is_root:
            n = next(iter(lengths.values()), 0)
            with open(path, "w", newline="", encoding="utf-8") as f:
                w = csv.writer(f)
                w.writerow(list(cols))
                for i in range(n):
                    w.writerow([_cell(c[i]) for c in cols.values()])
        return path

    # -- the end -------------------------------------------------------------------------------
    def finish(self, summary: Mapping[str, Any]) -> Path:
        """Write summary.json (last file of a run) atomically: tmp file then rename."""
        self.end_progress()
        self.close_history()
        path = self.summary_path
        if self.is_root:
            tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
            with open(tmp, "w", encoding="utf-8") as f:
                json.dump(to_jsonable(dict(summary)), f, indent=2, allow_nan=False)
                f.write("\n")
                f.flush()
                os.fsync(f.fileno())
            os.replace(tmp, path)
        if self.size > 1:
            self.comm.barrier()
        self.finished = True
        return path

    def __repr__(self) -> str:
        return f"RunOutput({str(self.out_dir)!r}, rank={self.rank}/{self.size})"


# ----------------------------------------------------------------------------------------------
# names that become file names, and the output folder of a run

#: longest scene, plot or output name (it becomes a file or folder name with a suffix)
NAME_MAX = 100
_UNSAFE = set('/\\:*?"<>|')


def file_name_problem(name: Any) -> str | None:
    """Why ``name`` cannot be used as a file name in a results folder (None: it can): empty, longer
    than :data:`NAME_MAX` characters, a leading dot (``.``, ``..``, hidden files), leading or trailing
    blanks, a path separator, NUL or another control character, or one of ``: * ? " < > |``."""
    if not isinstance(name, str) or not name.strip():
        return "must be a non-empty name"
    if len(name) > NAME_MAX:
        return f"is {len(name)} characters long: at most {NAME_MAX}"
    bad = sorted({c for c in name if c in _UNSAFE or ord(c) < 32 or ord(c) == 127})
    if bad:
        shown = " ".join(repr(c)[1:-1] for c in bad)
        return f"must not contain {shown} (no path separators or characters unsafe in a file name)"
    if name.startswith("."):
        return "must not start with a dot"
    if name != name.strip():
        return "must not start or end with a blank"
    return None


class OutputDirError(ValueError):
    """The output folder cannot be used (exit 2, nothing written)."""


#: marker of a results folder: JSON {"scene": name or null}, written when a run takes the folder
MARKER = ".fenics-plast"
#: a run's lock file in its folder: JSON {"pid", "host"}, created atomically, removed at the end
LOCK = ".fenics-plast.lock"


def results_folder_scene(path: str | os.PathLike) -> tuple[bool, str | None]:
    """``(is a fenics-plast results folder, its scene name or None)``: the folder has the marker
    :data:`MARKER` (a null scene: prepared for any scene, e.g. by ``study``), or was written by an older
    fenics-plast (summary.json with ``scene`` and ``scene_settings``, or a checkpoint manifest)."""
    path = Path(path)
    try:
        m = json.loads((path / MARKER).read_text(encoding="utf-8"))
        if isinstance(m, dict) and (m.get("scene") is None or isinstance(m.get("scene"), str)):
            return True, m.get("scene")
    except (OSError, ValueError):
        pass
    try:
        s = json.loads((path / "summary.json").read_text(encoding="utf-8"))
        if isinstance(s, dict) and isinstance(s.get("scene"), str) and isinstance(s.get("scene_settings"), dict):
            return True, s["scene"]
    except (OSError, ValueError):
        pass
    for manifest in sorted((path / "checkpoint").glob("ckpt_*.json")) if (path / "checkpoint").is_dir() else ():
        try:
            name = json.loads(manifest.read_text(encoding="utf-8"))["settings"]["scene"]["name"]
        except (OSError, ValueError, KeyError, TypeError):
            continue
        if isinstance(name, str):
            return True, name
    return False, None


def check_out_dir(out_dir: str | os.PathLike, scene: str, overwrite: bool = False, resume: bool = False) -> None:
    """Raise :class:`OutputDirError` unless a run of ``scene`` may write into ``out_dir`` (no side
    effect): a new folder whose nearest existing parent is a writable folder; an existing writable
    folder that is empty or a results folder of the same scene (of another scene: with
    ``overwrite``). A non-empty folder that is not a results folder is refused, ``overwrite`` or not.
    ``resume``: the folder of the killed run (checked by :func:`fenics_plast.checkpoint.check_resume`)."""
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise OutputDirError(f"--out {out}: is a file, not a folder: choose a folder for the results")
    if not out.exists():
        parent = out.absolute().parent
        while not parent.exists() and parent != parent.parent:
            parent = parent.parent
        if not parent.is_dir():
            raise OutputDirError(f"--out {out}: cannot create the folder: {parent} is a file, not a folder")
        if not os.access(parent, os.W_OK | os.X_OK):
            raise OutputDirError(f"--out {out}: cannot create the folder: {parent} is not writable")
        return
    if not os.access(out, os.W_OK | os.X_OK):
        raise OutputDirError(f"--out {out}: the folder is not writable")
    if resume:
        return
    try:
        entries = [e for e in os.listdir(out) if e != LOCK]
    except OSError as e:
        raise OutputDirError(f"--out {out}: cannot read the folder: {e.strerror or e}") from None
    if not entries:
        return
    is_results, name = results_folder_scene(out)
    if not is_results:
        raise OutputDirError(f"--out {out}: the folder is not empty and is not a fenics-plast results folder "
                             f"(no {MARKER} marker or summary.json of a run): nothing was written; choose an "
                             f"empty or new folder")
    if name is not None and name != scene and not overwrite:
        raise OutputDirError(f"--out {out}: the folder holds the results of scene {name!r}, not {scene!r}: "
                             f"choose another folder, or pass --overwrite to replace them")


def make_out_dir(out_dir: str | os.PathLike) -> list[Path]:
    """Create ``out_dir`` and its missing parents; returns the folders created (outermost first).
    OutputDirError (and nothing left behind) when the file system refuses."""
    out = Path(out_dir)
    missing = []
    p = out.absolute()
    while not p.exists():
        missing.append(p)
        if p == p.parent:
            break
        p = p.parent
    created: list[Path] = []
    try:
        for d in reversed(missing):
            d.mkdir()
            created.append(d)
    except OSError as e:
        remove_created(created)
        raise OutputDirError(f"--out {out}: cannot create the folder: {e.strerror or e}") from None
    return created


def remove_created(created: list[Path]) -> None:
    """Remove the folders :func:`make_out_dir` created (innermost first), each only if empty."""
    for d in reversed(created):
        try:
            d.rmdir()
        except OSError:
            break


def mark_results_folder(out_dir: str | os.PathLike, scene: str | None) -> None:
    """Write the marker :data:`MARKER` of a results folder of ``scene`` (None: any scene)."""
    path = Path(out_dir) / MARKER
    tmp = path.with_name(f"{path.name}.tmp{os.getpid()}")
    tmp.write_text(json.dumps({"scene": scene, "written_by": "fenics-plast"}) + "\n", encoding="utf-8")
    os.replace(tmp, path)

