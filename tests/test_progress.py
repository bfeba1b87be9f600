"""Stage timing, the terminal progress display and the first-run compiling notice."""
import time

import pytest
from click.testing import CliRunner
from conftest import compile_fresh_kernels

from rangeproc.cli import TerminalBars, _clock, main
from rangeproc.errors import DataError
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


def _compiling_run(*args, **kwargs):  # type: ignore[no-untyped-def]
    """Stands in for ``pipeline.run``: compiles two fresh kernels (as a first run does)."""
    compile_fresh_kernels()
    raise DataError("x.csv: stop here")


@pytest.mark.parametrize("quiet", [False, True])
def test_the_first_compilation_is_said_once_on_a_stderr_that_is_no_terminal(monkeypatch,
                                                                           quiet):
    """CliRunner's stderr is no terminal (as under make, CI or a notebook): the notice comes
    once, as a plain line (no terminal control codes), before the command's own lines;
    nothing under --quiet."""
    import rangeproc.pipeline

    monkeypatch.setattr(rangeproc.pipeline, "run", _compiling_run)
    res = CliRunner().invoke(main, ["run", "flight.toml", *(["--quiet"] if quiet else [])])
    assert res.exit_code == 2
    lines = res.stderr.splitlines()
    notices = [ln for ln in lines if "compiling the filter kernels" in ln]
    if quiet:
        assert notices == [] and lines == ["rangeproc: error: x.csv: stop here"]
        return
    assert len(notices) == 1, res.stderr
    assert notices[0].startswith("rangeproc: compiling the filter kernels for their first run")
    assert "\033" not in res.stderr and "\r" not in res.stderr
    assert lines[-1] == "rangeproc: error: x.csv: stop here"


def test_the_notice_listener_is_removed_after_the_command(monkeypatch):
    """A second command in the same process says it again for its own first compilation,
    and no listener of an earlier command is left behind to say it twice."""
    import rangeproc.pipeline

    monkeypatch.setattr(rangeproc.pipeline, "run", _compiling_run)
    for _ in range(2):
        res = CliRunner().invoke(main, ["run", "flight.toml"])
        assert res.stderr.count("compiling the filter kernels") == 1, res.stderr
