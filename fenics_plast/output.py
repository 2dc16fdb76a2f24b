"""Run output: history.csv, other CSV tables, PNG plots, fields.xdmf path, summary.json.

Knows nothing of physics. Rank 0 writes every file except fields.xdmf (written collectively by
dolfinx through :attr:`RunOutput.xdmf_path`). ``comm`` may be an mpi4py communicator or None
(serial, no MPI import).

The output folder (used by the CLI before a run starts, rank 0): :func:`check_out_dir` refuses a
folder a run must not write into (a file, not writable, a non-empty folder that is not a results
folder, another scene's results without ``--overwrite``); :func:`make_out_dir` creates it, the
marker :data:`MARKER` says it is a results folder and of which scene, and the lock :data:`LOCK`
(:mod:`fenics_plast.run_lock`) keeps a second run out while one runs. :func:`file_name_problem`
says why a scene, plot or output name cannot become a file name, :func:`reserved_name_problem` why
it would name a file of the run itself.

Links: every file is written and deleted through :mod:`fenics_plast.out_files` (no symbolic link is
followed, a link where the run writes is refused); :func:`check_out_dir` refuses up front a folder with
a link at a name the run writes. The marker lists the files the run wrote (:meth:`RunOutput.claim`, before
each is created), and a new run (not ``--resume``) first removes exactly those (:func:`remove_listed`):
no field or figure of an earlier run stays beside a new summary.
"""
from __future__ import annotations

import csv
import json
import math
import os
import re
from pathlib import Path
from typing import Any, Iterable, Mapping

import numpy as np

from .out_files import LinkRefused, link_at, open_write, remove_file, write_atomic

__all__ = ["RunOutput", "to_jsonable", "file_name_problem", "NAME_MAX", "OutputDirError", "MARKER", "LOCK",
           "results_folder_scene", "check_out_dir", "make_out_dir", "remove_created", "mark_results_folder",
           "LinkRefused", "RUN_FILES", "RESERVED_NAMES", "reserved_name_problem", "run_file_names",
           "remove_listed", "listed_files", "results_folder_kind", "STUDY_FILES"]


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
    * ``claim(*names)``: the files about to be written, added to the marker's list (rank 0) so that
      the next run removes them (:func:`remove_listed`).
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
        self._claimed: set[str] = set()
        if self.is_root:
            self.out_dir.mkdir(parents=True, exist_ok=True)
            # a summary.json of an earlier run must not make this one look complete if it is killed
            remove_file(self.summary_path)
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
        for p in (xdmf, h5):
            if os.path.islink(p):
                raise LinkRefused(f"{p}: is a symbolic link: a resumed run does not follow it; remove it")
        if not xdmf.is_file():
            return
        k = 1
        while any(os.path.lexists(self.out_dir / f"fields_part{k}{x}") for x in (".xdmf", ".h5")):
            k += 1
        new = self.out_dir / f"fields_part{k}.xdmf"
        self.claim(new.name, new.with_suffix(".h5").name)
        text = xdmf.read_text(encoding="utf-8", errors="replace")
        if h5.is_file():
            os.replace(h5, new.with_suffix(".h5"))      # a name of the folder to another: no link followed
            text = text.replace(f"{h5.name}:", f"{new.with_suffix('.h5').name}:")
        write_atomic(new, text)
        xdmf.unlink()

    def claim(self, *names: str) -> None:
        """Rank 0: ``names`` (files of the folder this run is about to write) join the marker's list of
        the run's files, which the next run removes before it starts (:func:`remove_listed`). No-op
        without a marker (a RunOutput used outside the CLI)."""
        new = [n for n in names if n not in self._claimed]
        if not new or not self.is_root:
            return
        self._claimed.update(new)
        marker = _read_marker(self.out_dir)
        if marker is None:
            return
        files = [f for f in marker.get("files") or [] if isinstance(f, str)]
        marker["files"] = files + [n for n in new if n not in files]
        write_atomic(self.out_dir / MARKER, json.dumps(marker) + "\n", fsync=False)

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
                self.claim(self.history_path.name)
                self._hist_file = open_write(self.history_path, newline="", encoding="utf-8")
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
                import io
                buf = io.StringIO(newline="")
                w = csv.writer(buf)
                w.writerow(self._hist_header)
                for r in rows:
                    w.writerow([_cell(r.get(k, "")) for k in self._hist_header])
                self.claim(path.name)
                write_atomic(path, buf.getvalue())
                self._hist_file = open_write(path, mode="a", append=True, newline="", encoding="utf-8")
                self._hist_writer = csv.writer(self._hist_file)
            else:
                remove_file(path)

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
            self.claim(path.name)
            with open_write(path, newline="", encoding="utf-8") as f:
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
            self.claim(path.name)
            write_atomic(path, json.dumps(to_jsonable(dict(summary)), indent=2, allow_nan=False) + "\n")
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


#: files every run may write in its folder besides those named after plots and outputs (the marker and
#: lock: :data:`MARKER`, :data:`LOCK`; the folder checkpoint/ of :mod:`fenics_plast.checkpoint`)
RUN_FILES = ("history.csv", "summary.json", "fields.xdmf", "fields.h5", "final_shape.csv", ".fenics-plast",
             ".fenics-plast.lock", "checkpoint")
#: what a study writes in its folder (``runs/<run>/`` holds each run, with run.log and study_run.json)
STUDY_FILES = ("study.csv", "study.md", "study.png", "runs", "run.log", "study_run.json")
#: names a plot (<name>.png) or an output (<name>.csv) may not take: they name files of the run itself,
#: of ``fenics-plast point`` (point_<path>.csv in results/<scene>/) or of a study (compared casefolded)
RESERVED_NAMES = ("history", "summary", "fields", "final_shape", "checkpoint", "point_uniaxial", "point_shear",
                  "point_table", "study", "study_run", "run", "runs", "accuracy")
_RESERVED_RE = re.compile(r"^(fields_part\d+|fields_remesh\d+)$", re.IGNORECASE)


def reserved_name_problem(name: Any) -> str | None:
    """Why ``name`` may not name a plot or an output: it maps onto a file the run writes itself (history,
    summary, fields, final_shape, checkpoint, ...; :data:`RESERVED_NAMES`). None: it may."""
    if not isinstance(name, str):
        return None
    stem = name.casefold()
    if stem in RESERVED_NAMES or _RESERVED_RE.match(name):
        return (f"is reserved: it names a file that fenics-plast writes itself ({name}.csv/.png beside "
                f"{', '.join(RUN_FILES[:5])}); choose another name")
    return None


def run_file_names(problem) -> list[str]:
    """The names a run of ``problem`` writes in its folder (:data:`RUN_FILES`, ``<plot>.png``,
    ``<output>.csv``), for the up-front check of links (:func:`check_out_dir`)."""
    names = list(RUN_FILES)
    names += [f"{n}.png" for n in problem.plots]
    names += [f"{n}.csv" for n in problem.outputs]
    return names


#: marker of a results folder: JSON {"scene": name or null}, written when a run takes the folder
MARKER = ".fenics-plast"
#: a run's lock file in its folder: JSON {"pid", "host"}, created atomically, removed at the end
LOCK = ".fenics-plast.lock"


def _read_marker(path) -> dict | None:
    """The marker of folder ``path`` as a dict (None: none, or unreadable, or a link)."""
    p = Path(path) / MARKER
    if os.path.islink(p):
        return None
    try:
        m = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return m if isinstance(m, dict) else None


def results_folder_kind(path: str | os.PathLike) -> str | None:
    """``"run"``, ``"study"`` or ``"accuracy"`` (``run --accuracy``) for a results folder (what its marker
    says; older folders: run), None for another folder."""
    m = _read_marker(path)
    if m is not None and (m.get("scene") is None or isinstance(m.get("scene"), str)):
        return m["kind"] if m.get("kind") in ("study", "accuracy") else "run"
    return "run" if results_folder_scene(path)[0] else None


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


def check_out_dir(out_dir: str | os.PathLike, scene: str, overwrite: bool = False, resume: bool = False,
                  names: Iterable[str] = (), kind: str = "run") -> None:
    """Raise :class:`OutputDirError` unless a run of ``scene`` may write into ``out_dir`` (no side
    effect): a new folder whose nearest existing parent is a writable folder; an existing writable
    folder that is empty or a results folder of the same scene (of another scene: with
    ``overwrite``). A non-empty folder that is not a results folder is refused, ``overwrite`` or not.
    ``resume``: the folder of the killed run (checked by :func:`fenics_plast.checkpoint.check_resume`).
    A symbolic link (or a FIFO, a device) at a name the run writes (:data:`RUN_FILES`, ``names``:
    :func:`run_file_names`) or among checkpoint/'s files is refused. ``kind``: ``"study"`` for a
    study's folder (:data:`STUDY_FILES`; a run's folder is refused as a study's and the other way
    round, unless ``overwrite``)."""
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
    link = link_at(out, [*RUN_FILES, *(STUDY_FILES if kind == "study" else ()), *names])
    ck = out / "checkpoint"
    if link is None and ck.is_dir() and not ck.is_symlink():
        try:
            link = link_at(ck, sorted(n for n in os.listdir(ck) if re.match(r"^\.?ckpt_", n)))
        except OSError:
            pass
    if link is not None:
        raise OutputDirError(f"--out {out}: {link} is a symbolic link (or not a regular file or folder) where "
                             f"fenics-plast writes: it does not write through links, out of the folder; nothing "
                             f"was written: remove it, or choose another folder")
    if resume:
        return
    try:
        entries = [e for e in os.listdir(out) if e != LOCK]
    except OSError as e:
        raise OutputDirError(f"--out {out}: cannot read the folder: {e.strerror or e}") from None
    if not entries:
        return
    is_results, name = results_folder_scene(out)
    if (not is_results and kind == "study" and _is_file(out / "study.csv") and _is_file(out / "study.md")
            and (out / "runs").is_dir() and not (out / "runs").is_symlink()):
        return                              # a study's folder of an older fenics-plast (no marker)
    if not is_results:
        raise OutputDirError(f"--out {out}: the folder is not empty and is not a fenics-plast results folder "
                             f"(no {MARKER} marker or summary.json of a run): nothing was written; choose an "
                             f"empty or new folder")
    if name is not None and name != scene and not overwrite:
        raise OutputDirError(f"--out {out}: the folder holds the results of scene {name!r}, not {scene!r}: "
                             f"choose another folder, or pass --overwrite to replace them")
    has = results_folder_kind(out)
    if has != kind and not overwrite:
        raise OutputDirError(f"--out {out}: the folder holds the results of a {has}, not of a {kind}: choose "
                             f"another folder, or pass --overwrite to replace them")


def _is_file(p: Path) -> bool:
    return not p.is_symlink() and p.is_file()


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


def mark_results_folder(out_dir: str | os.PathLike, scene: str | None, kind: str = "run") -> None:
    """Write the marker :data:`MARKER` of a results folder of ``scene`` (None: any scene); ``kind``:
    ``"study"`` for a study's folder. The list of the files earlier runs wrote (``files``) is kept:
    :func:`remove_listed` removes them. A link at the marker's name is refused (:class:`LinkRefused`)."""
    marker = {"scene": scene, "written_by": "fenics-plast"}
    if kind != "run":
        marker["kind"] = kind
    marker["files"] = listed_files(out_dir)
    write_atomic(Path(out_dir) / MARKER, json.dumps(marker) + "\n")


def _plain_name(name: Any) -> bool:
    return (isinstance(name, str) and name not in (MARKER, LOCK, "", ".", "..") and "/" not in name
            and "\0" not in name and len(name) <= 255)


def listed_files(out_dir: str | os.PathLike) -> list[str]:
    """The files an earlier run wrote in ``out_dir``: the marker's list, or for a folder of an older
    fenics-plast (no list) the files a run writes (history.csv, summary.json, fields*.xdmf/.h5,
    final_shape.csv) and those its summary.json's plots and outputs name."""
    out = Path(out_dir)
    m = _read_marker(out)
    if m is not None and isinstance(m.get("files"), list):
        return [f for f in m["files"] if _plain_name(f)]
    if not results_folder_scene(out)[0]:
        return []
    names = list(RUN_FILES[:5])
    try:
        names += sorted(n for n in os.listdir(out) if re.match(r"^fields_part\d+\.(xdmf|h5)$", n))
    except OSError:
        pass
    try:
        settings = json.loads((out / "summary.json").read_text(encoding="utf-8")).get("scene_settings") or {}
    except (OSError, ValueError, AttributeError):
        settings = {}
    if isinstance(settings, dict):
        for key, suffix in (("plots", ".png"), ("outputs", ".csv")):
            table = settings.get(key)
            if isinstance(table, dict):
                names += [f"{n}{suffix}" for n in table if file_name_problem(n) is None]
    return [n for n in dict.fromkeys(names) if _plain_name(n)]


def remove_listed(out_dir: str | os.PathLike) -> list[str]:
    """Rank 0, a new run (not ``--resume``) into a results folder: remove the files the earlier run wrote
    (:func:`listed_files`): only regular files directly in the folder, never through a link, nothing
    else; the marker's list is emptied. Returns the names removed."""
    out = Path(out_dir)
    removed = [n for n in listed_files(out) if remove_file(out / n)]
    m = _read_marker(out)
    if m is not None:
        m["files"] = []
        write_atomic(out / MARKER, json.dumps(m) + "\n")
    return removed

