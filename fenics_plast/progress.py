"""Progress reporting for long runs: a redrawn bar on a terminal, plain periodic lines elsewhere.

    bar = Progress(1.0, "punch", what="load", comm=MPI.COMM_WORLD)
    bar.update(0.45, inc=12, newton=5)      # cheap: draws at most every min_interval_s
    bar.write("a log line")                 # a log line that does not garble the bar
    bar.close()                             # final state, newline

* On a terminal (``is_tty``): one line redrawn in place with ``\\r``, at most every
  ``min_interval_s`` seconds; :meth:`close` ends it with a newline.
* Not on a terminal (CI logs, files): complete lines, one each time the done fraction crosses a
  multiple of ``every_fraction`` (5 %) or when ``every_s`` seconds passed since the last line,
  and a last line from :meth:`close` if the final state was not printed yet.
* Only rank 0 of ``comm`` prints (``comm=None``: serial, prints). No collective calls: ranks
  may call :meth:`update` a different number of times.
* The environment variable ``FENICS_PLAST_PROGRESS`` = ``tty`` | ``plain`` | ``off`` overrides the
  automatic choice (Open MPI hands its ranks a pseudo-terminal even when mpirun's own output goes
  to a file: ``FENICS_PLAST_PROGRESS=plain mpirun ... > log``); ``TERM=dumb`` means plain.
* Time left = (total - done) / rate, with the rate measured from the first :meth:`update`
  (call ``update(start_value)`` before the work starts, so set-up time does not count).

Knows nothing of physics; ``done`` and ``total`` are in any unit (load factor, µs, steps).
"""
from __future__ import annotations

import math
import os
import sys
import time
from typing import Any, Callable, TextIO

__all__ = ["Progress", "format_duration", "ENV_VAR"]

ENV_VAR = "FENICS_PLAST_PROGRESS"


def format_duration(seconds: float | None) -> str:
    """``12s``, ``3m05s``, ``2h07m``; ``?`` for None or a non-finite value."""
    if seconds is None or not math.isfinite(seconds):
        return "?"
    s = max(0, int(round(seconds)))
    if s < 60:
        return f"{s}s"
    if s < 3600:
        return f"{s // 60}m{s % 60:02d}s"
    return f"{s // 3600}h{(s % 3600) // 60:02d}m"


def _fmt(v: Any) -> str:
    if isinstance(v, bool) or isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


class Progress:
    """Progress of one long loop (see the module docstring).

    total : the value of ``done`` at the end (> 0), in the unit ``unit`` (e.g. 1.0 load factor,
        80.0 µs).
    label : printed first (scene name).
    what : name of the ``done`` quantity in the line ("load", "t").
    comm : mpi4py communicator (or anything with ``.rank``); None = serial.
    stream : text stream (default ``sys.stdout`` at construction).
    is_tty : force the terminal / plain-line mode (default: ``$FENICS_PLAST_PROGRESS``, else
        ``stream.isatty()`` unless ``TERM=dumb``). ``FENICS_PLAST_PROGRESS=off`` silences rank 0 too.
    min_interval_s : terminal redraw throttle [s].
    every_fraction : plain-line step as a fraction of ``total``.
    every_s : plain-line interval when the fraction moves slowly [s].
    clock : monotonic clock in seconds (tests pass a fake one).
    """

    def __init__(self, total: float, label: str = "", *, what: str = "", unit: str = "", comm=None,
                 stream: TextIO | None = None, is_tty: bool | None = None, min_interval_s: float = 0.1,
                 every_fraction: float = 0.05, every_s: float = 30.0, width: int = 24,
                 clock: Callable[[], float] = time.monotonic):
        total = float(total)
        if not (math.isfinite(total) and total > 0.0):
            raise ValueError(f"Progress total must be a positive finite number, got {total!r}")
        if not 0.0 < every_fraction <= 1.0:
            raise ValueError(f"every_fraction must lie in (0, 1], got {every_fraction!r}")
        self.total = total
        self.label, self.what, self.unit = label, what, unit
        self.rank = 0 if comm is None else int(comm.rank)
        mode = os.environ.get(ENV_VAR, "").strip().lower()
        if mode not in ("", "tty", "plain", "off"):
            raise ValueError(f"{ENV_VAR} must be tty, plain or off, got {mode!r}")
        self.enabled = self.rank == 0 and mode != "off"
        self.stream = stream if stream is not None else sys.stdout
        if is_tty is None and mode in ("tty", "plain"):
            is_tty = mode == "tty"
        if is_tty is None:
            try:
                is_tty = bool(self.stream.isatty()) and os.environ.get("TERM", "") != "dumb"
            except (AttributeError, ValueError):
                is_tty = False
        self.is_tty = is_tty
        self.min_interval_s = float(min_interval_s)
        self.every_fraction = float(every_fraction)
        self.every_s = float(every_s)
        self.width = int(width)
        self.clock = clock
        self.done = 0.0
        self.fields: dict[str, Any] = {}
        self.closed = False
        self._t_start = clock()          # elapsed time counts from here
        self._ref = None                 # (time, done) of the first update: rate reference
        self._last_draw = -math.inf      # terminal: time of the last redraw
        self._drawn_len = 0              # terminal: length of the bar now on screen (0: none)
        self._last_line = None           # plain: time of the last line
        self._next_mark = 0.0            # plain: next fraction that prints a line
        self._printed_state = None       # plain: (done, fields) of the last line

    # -- numbers -------------------------------------------------------------------------------
    @property
    def fraction(self) -> float:
        return min(max(self.done / self.total, 0.0), 1.0)

    @property
    def finished(self) -> bool:
        """done has reached total (to round-off: a load factor summed from steps)."""
        return self.done >= self.total * (1.0 - 1e-9)

    def elapsed(self) -> float:
        """Seconds since construction."""
        return self.clock() - self._t_start

    def time_left(self) -> float | None:
        """Seconds left at the mean rate since the first update; None before there is a rate."""
        if self._ref is None:
            return None
        t0, d0 = self._ref
        dt, dd = self.clock() - t0, self.done - d0
        if dd <= 0.0 or dt <= 0.0:
            return None
        return max(self.total - self.done, 0.0) * dt / dd

    def text(self, bar: bool | None = None) -> str:
        """The progress line (without ``\\r`` or newline)."""
        bar = self.is_tty if bar is None else bar
        parts = [self.label] if self.label else []
        if bar:
            n = int(round(self.fraction * self.width))
            parts.append("[" + "#" * n + "-" * (self.width - n) + "]")
        parts.append(f"{100.0 * self.fraction:5.1f}%")
        unit = f" {self.unit}" if self.unit else ""
        what = f"{self.what} " if self.what else ""
        parts.append(f"{what}{self.done:.4g}/{self.total:.4g}{unit}")
        parts += [f"{k.replace('_', ' ')} {_fmt(v)}" for k, v in self.fields.items()]
        parts.append(f"elapsed {format_duration(self.elapsed())}")
        if self.closed or self.finished:
            return "  ".join(parts)
        left = self.time_left()
        parts.append(f"left ~{format_duration(left)}" if left is not None else "left ?")
        return "  ".join(parts)

    # -- reporting -----------------------------------------------------------------------------
    def update(self, done: float, **fields: Any) -> None:
        """Record progress ``done`` (same unit as ``total``) and fields to show (merged with the
        earlier ones: key -> value, e.g. ``inc=12, newton=5``); prints when it is time to."""
        if self.closed:
            return
        now = self.clock()
        self.done = float(done)
        self.fields.update(fields)
        if self._ref is None:
            self._ref = (now, self.done)
        if not self.enabled:
            return
        if self.is_tty:
            if self._drawn_len == 0 or self.finished or now - self._last_draw >= self.min_interval_s:
                self._draw(now)
        else:
            frac = self.fraction
            due = frac >= self._next_mark - 1e-12
            if not due and self._last_line is not None and now - self._last_line >= self.every_s:
                due = True
            if due:
                self._line(now)

    def write(self, msg: str) -> None:
        """Print a log line (rank 0) without garbling the bar: on a terminal the bar line is
        overwritten by ``msg`` and comes back at the next update."""
        if not self.enabled:
            return
        if self.is_tty and self._drawn_len:
            pad = " " * max(self._drawn_len - len(msg), 0)
            self.stream.write("\r" + msg + pad + "\n")
            self._drawn_len = 0
            self._last_draw = -math.inf
        else:
            self.stream.write(msg + "\n")
        self.stream.flush()

    def close(self) -> None:
        """Final state: on a terminal the bar is drawn once more and ended with a newline; in plain
        mode a last line unless the final state was already printed. Idempotent."""
        if self.closed:
            return
        self.closed = True
        if not self.enabled:
            return
        now = self.clock()
        if self.is_tty:
            if self._drawn_len or self._ref is not None:
                self._draw(now)
                self.stream.write("\n")
                self.stream.flush()
                self._drawn_len = 0
        elif self._ref is not None and self._printed_state != self._state():
            self._line(now)

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- internals -----------------------------------------------------------------------------
    def _state(self):
        return (self.done, tuple(self.fields.items()))

    def _draw(self, now: float) -> None:
        s = self.text(bar=True)
        pad = " " * max(self._drawn_len - len(s), 0)
        self.stream.write("\r" + s + pad)
        self.stream.flush()
        self._drawn_len = len(s) + len(pad)     # what is on screen now
        self._last_draw = now

    def _line(self, now: float) -> None:
        self.stream.write(self.text(bar=False) + "\n")
        self.stream.flush()
        self._last_line = now
        step = self.every_fraction
        self._next_mark = (math.floor(self.fraction / step + 1e-9) + 1) * step
        self._printed_state = self._state()
