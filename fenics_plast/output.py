"""Run output: history.csv, other CSV tables, PNG plots, fields.xdmf path, summary.json.

Knows nothing of physics. Rank 0 writes every file except fields.xdmf (written collectively by
dolfinx through :attr:`RunOutput.xdmf_path`). ``comm`` may be an mpi4py communicator or None
(serial, no MPI import).
"""
from __future__ import annotations

import csv
import json
import math
import os
from pathlib import Path
from typing import Any, Mapping

import numpy as np

__all__ = ["RunOutput", "to_jsonable"]


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
