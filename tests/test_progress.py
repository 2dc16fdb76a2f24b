"""Progress: plain periodic lines off a terminal, a redrawn line on one, rank 0 only, time left."""
import io
import re
import types
from pathlib import Path

import pytest

from fenics_plast.progress import Progress, format_duration


class FakeClock:
    def __init__(self, t=100.0):
        self.t = t

    def __call__(self):
        return self.t


def make(total=1.0, tty=False, rank=0, **kw):
    clock = FakeClock()
    out = io.StringIO()
    comm = types.SimpleNamespace(rank=rank) if rank is not None else None
    p = Progress(total, "scene", what="load", comm=comm, stream=out, is_tty=tty, clock=clock, **kw)
    return p, out, clock


LINE = re.compile(r"^scene +(\d+\.\d)%  load (\S+)/1  inc (\d+)  newton (\d+)  elapsed (\S+)(  left (\S+))?$")


def test_plain_lines_every_5_percent_and_complete():
    p, out, clock = make(every_s=1e9)
    for i in range(101):                 # 1 % per increment, 1 s each
        p.update(i / 100, inc=i, newton=3)
        clock.t += 1.0
    p.close()
    text = out.getvalue()
    assert "\r" not in text and text.endswith("\n")
    lines = text.splitlines()
    # 0 %, 5 %, ..., 100 %: one line per mark, the final state is not repeated by close()
    assert len(lines) == 21
    pct = []
    for ln in lines:
        m = LINE.match(ln)
        assert m, ln
        pct.append(float(m.group(1)))
        assert int(m.group(3)) == round(float(m.group(2)) * 100)     # fields of the same state
    assert pct == pytest.approx([5.0 * k for k in range(21)])
    # 5 % per 5 s: 1 s per % -> at 50 %, 50 s left
    m = LINE.match(lines[10])
    assert m.group(7) == "~50s" and m.group(5) == "50s"


def test_plain_line_after_every_s_when_slow_and_close_prints_final_state():
    p, out, clock = make(every_s=30.0)
    p.update(0.0, inc=0, newton=0)
    for i in range(1, 7):                 # 0.5 % per 10 s: only the time rule prints
        clock.t += 10.0
        p.update(0.005 * i, inc=i, newton=4)
    p.close()
    lines = out.getvalue().splitlines()
    # t = 0 (first update), 30 s, 60 s, then close() at 60 s has nothing new to say
    assert len(lines) == 3
    assert "load 0.015/1" in lines[1] and "load 0.03/1" in lines[2]
    p2, out2, clock2 = make()
    p2.update(0.0, inc=0, newton=0)
    clock2.t += 3.0
    p2.update(0.42, inc=7, newton=5)      # no 5 % mark crossed? 0.42 crosses 0.05: printed
    clock2.t += 1.0
    p2.update(0.43, inc=8, newton=2)      # not printed (next mark 0.45)
    p2.close()                            # stopped early: the final state is printed once
    lines2 = out2.getvalue().splitlines()
    assert len(lines2) == 3 and "load 0.43/1  inc 8  newton 2" in lines2[-1]
    assert "left" not in lines2[-1]


def test_tty_redraws_with_carriage_return_and_ends_with_newline():
    p, out, clock = make(tty=True, min_interval_s=0.5)
    for i in range(11):
        p.update(i / 10, inc=i, newton=2)
        clock.t += 0.3                    # throttled: not every update redraws
    p.close()
    text = out.getvalue()
    assert text.endswith("\n") and text.count("\n") == 1
    frames = text[:-1].split("\r")[1:]
    assert 3 <= len(frames) < 12
    assert all("[" in f and "]" in f for f in frames)
    assert "100.0%" in frames[-1] and "inc 10" in frames[-1]
    # a shorter frame is padded to erase the longer one before it
    lens = [len(f) for f in frames]
    assert lens == sorted(lens)


def test_tty_write_does_not_garble_the_bar():
    p, out, clock = make(tty=True)
    p.update(0.1, inc=1, newton=3)
    p.write("increment 1 converged")
    clock.t += 1.0
    p.update(0.2, inc=2, newton=3)
    p.close()
    lines = out.getvalue().split("\n")
    assert lines[0].startswith("\r") and "increment 1 converged" in lines[0].split("\r")[-1]
    assert lines[0].split("\r")[-1].rstrip() == "increment 1 converged"
    assert "inc 2" in lines[1] and lines[2] == ""


@pytest.mark.parametrize("tty", [False, True])
def test_rank_other_than_0_prints_nothing(tty):
    p, out, clock = make(tty=tty, rank=1)
    for i in range(21):
        p.update(i / 20, inc=i, newton=1)
        clock.t += 5.0
    p.write("log line")
    p.close()
    assert out.getvalue() == ""
    assert p.done == 1.0                  # but it keeps the state (same calls on every rank)


def test_time_left_on_a_fake_clock():
    p, out, clock = make(total=80.0)
    assert p.time_left() is None
    clock.t += 7.0                        # set-up time before the first update does not count
    p.update(0.0)
    assert p.time_left() is None          # no rate yet
    clock.t += 10.0
    p.update(20.0)                        # 2 units/s, 60 left -> 30 s
    assert p.time_left() == pytest.approx(30.0)
    assert p.elapsed() == pytest.approx(17.0)
    clock.t += 30.0
    p.update(80.0)
    assert p.time_left() == pytest.approx(0.0)
    p2, _, clock2 = make()
    p2.update(0.5)
    clock2.t += 5.0
    p2.update(0.5)                        # no progress: unknown, not infinite or negative
    assert p2.time_left() is None


def test_format_duration_and_bad_total():
    assert [format_duration(s) for s in (4.4, 65, 3725, None, float("inf"))] == \
        ["4s", "1m05s", "1h02m", "?", "?"]
    with pytest.raises(ValueError, match="positive"):
        Progress(0.0)


class TtyStream(io.StringIO):
    def isatty(self):
        return True


@pytest.mark.parametrize("mode, expect", [("plain", "plain"), ("tty", "tty"), ("off", ""), ("", "tty")])
def test_environment_override(monkeypatch, mode, expect):
    monkeypatch.setenv("FENICS_PLAST_PROGRESS", mode)
    monkeypatch.setenv("TERM", "xterm")
    out = TtyStream()
    p = Progress(2.0, "x", stream=out)
    p.update(1.0)
    p.close()
    text = out.getvalue()
    if expect == "":
        assert text == ""
    elif expect == "tty":
        assert text.startswith("\r") and text.endswith("\n")
    else:
        assert "\r" not in text and len(text.splitlines()) == 1
    monkeypatch.setenv("FENICS_PLAST_PROGRESS", "fancy")
    with pytest.raises(ValueError, match="FENICS_PLAST_PROGRESS"):
        Progress(1.0)


def test_run_output_logs_through_the_bar(tmp_path):
    from fenics_plast.output import RunOutput
    out = TtyStream()
    ro = RunOutput(tmp_path)
    bar = ro.progress(1.0, "s", what="load", stream=out, is_tty=True)
    bar.update(0.5, inc=1)
    ro.log("increment 1 done")
    ro.finish({"converged": True})          # ends the bar: final frame and a newline
    assert ro._progress is None and bar.closed
    text = out.getvalue()
    assert text.endswith("\n") and "\rincrement 1 done" in text
    assert text.split("\n")[-2].split("\r")[-1].startswith("s  [############")


RING = Path(__file__).resolve().parent / "scenes" / "ring.toml"    # small thick cylinder


def test_static_run_reports_increments_and_newton_iterations(tmp_path, capsys, monkeypatch):
    """The quasi-static solver drives the ring: plain lines (captured output is not a terminal)
    whose last state agrees with summary.json."""
    import json
    from fenics_plast import cli
    monkeypatch.delenv("FENICS_PLAST_PROGRESS", raising=False)
    assert cli.main(["run", str(RING), "--out", str(tmp_path / "out"), "--set", "mesh.parameters.cells_radial=3",
                     "--set", "mesh.parameters.cells_circumferential=3", "--set", "output.plots=false"]) == 0
    lines = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("ring ")]
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert lines and all("\r" not in ln for ln in lines)
    pct = [float(re.search(r"(\d+\.\d)%", ln).group(1)) for ln in lines]
    assert pct[0] == 0.0 and pct[-1] == 100.0 and pct == sorted(pct)
    last = lines[-1]
    assert f"inc {summary['increments']} " in last
    assert f"newton total {summary['newton_iterations']} " in last
    assert "left" not in last and "elapsed" in last     # close(): the final line, no estimate
