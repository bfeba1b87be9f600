"""Stage timing and the terminal progress display."""
import time

from rangeproc.cli import TerminalBars, _clock
from rangeproc.progress import SilentDisplay, StageClock


def test_stage_clock_accumulates_seconds_and_forwards_ticks():
    events = []

    class Recorder:
        def start(self, stage, total):
            events.append(("start", stage, total))

        def advance(self, stage, n=1, note=""):
            events.append(("advance", stage, n, note))

        def finish(self, stage, seconds):
            events.append(("finish", stage))

    clock = StageClock(display=Recorder())
    with clock.stage("read", 2) as tick:
        tick(1, "R1")
        time.sleep(0.01)
        tick(1, "G1")
    with clock.stage("read") as tick:
        pass
    assert clock.seconds["read"] >= 0.01
    assert events[0] == ("start", "read", 2)
    assert ("advance", "read", 1, "G1") in events
    assert events.count(("finish", "read")) == 2


def test_terminal_bars_draw_one_line_per_stage(capsys):
    bars = TerminalBars()
    bars.start("fuse", 3)
    bars.advance("fuse", 1, "T1 pass 1")
    bars.finish("fuse", 1.5)
    err = capsys.readouterr().err
    assert "fuse" in err and "#" in err and "1.50 s" in err
    assert err.endswith("\n") and err.count("\n") == 1


def test_quiet_or_not_a_terminal_is_silent():
    assert isinstance(_clock(True).display, SilentDisplay)
    assert isinstance(_clock(False).display, SilentDisplay)   # pytest's stderr is not a TTY
