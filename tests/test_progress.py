"""Progress and status lines: nothing for short work, one redrawn line on a terminal, plain
lines (no carriage return) in a log, always the final state once anything was shown."""
import io
import sys

from vismobile.progress import LOG_INTERVAL, QUIET_SECONDS, Progress, Status


class Terminal(io.StringIO):
    def isatty(self):
        return True


class Clock:
    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


def test_short_work_prints_nothing_anywhere():
    for stream in (io.StringIO(), Terminal()):
        clock = Clock()
        bar = Progress("compare", stream=stream, total=500, clock=clock)
        for i in range(500):
            clock.now = i * 0.9 * QUIET_SECONDS / 500  # all of it inside the quiet time
            bar.step()
        bar.close()
        assert stream.getvalue() == ""


def test_a_log_gets_plain_lines_after_the_quiet_time_and_the_end():
    stream, clock = io.StringIO(), Clock()
    bar = Progress("compare", stream=stream, total=100, clock=clock)
    for i in range(100):
        clock.now = i * 0.5  # 50 s in all
        bar.step()
    bar.close()
    lines = stream.getvalue().splitlines()
    assert "\r" not in stream.getvalue() and stream.getvalue().endswith("\n")
    assert lines[0].startswith("compare: 5% (5 of 100), 2.0s")
    assert 4 <= len(lines) <= 2 + 50 / LOG_INTERVAL and lines[-1].startswith("compare: 100%")


def test_terminal_gets_few_redraws_and_the_end():
    stream, clock = Terminal(), Clock()
    bar = Progress("compare", stream=stream, total=500, clock=clock)
    for i in range(500):
        clock.now = QUIET_SECONDS + i * 0.001
        bar.step()
    bar.close()
    draws = stream.getvalue().split("\r")[1:]
    assert 1 <= len(draws) <= 3 and "100%" in draws[-1] and stream.getvalue().endswith("\n")


def test_disabled_bar_never_draws_even_on_a_terminal():
    stream, clock = Terminal(), Clock()
    bar = Progress("octree", stream=stream, enabled=False, clock=clock)
    clock.now = 100.0
    bar(1, 2)
    bar(2, 2)
    bar.close()
    assert stream.getvalue() == ""


def test_status_waits_for_the_quiet_time_then_writes_plain_lines_in_a_log():
    stream, clock = io.StringIO(), Clock()
    status = Status("tune w1", stream=stream, clock=clock, ticker=False)
    status("loading the world")
    assert stream.getvalue() == ""
    clock.now = 3.0
    status("probing")
    clock.now = 5.0
    status("probing")  # the same step again before the interval: not repeated
    clock.now = 3.0 + LOG_INTERVAL
    status("probing")  # still running after the interval: shown again
    status.done()
    assert stream.getvalue() == "tune w1: probing, 3 s\ntune w1: probing, 13 s\n"


def test_status_ticker_shows_a_long_step_without_a_call():
    # The step's time comes from the fake clock; the real wait is only for the ticker thread
    # to run once (it polls every 0.25 s), with room for a loaded machine.
    import time

    stream, clock = io.StringIO(), Clock()
    with Status("info w2", stream=stream, clock=clock) as status:
        status("loading the world")
        assert stream.getvalue() == ""
        clock.now = QUIET_SECONDS + 1.0  # past the quiet time, with no further call
        waited = time.perf_counter()
        while not stream.getvalue() and time.perf_counter() - waited < 60.0:
            time.sleep(0.05)
    assert stream.getvalue() == f"info w2: loading the world, {QUIET_SECONDS + 1.0:.0f} s\n"


def test_vismobile_status_off_silences_stderr_only(monkeypatch, capsys):
    monkeypatch.setenv("VISMOBILE_STATUS", "off")
    assert not Progress("compare", total=3).enabled and not Status("tune w1").enabled
    assert Status("tune w1", stream=io.StringIO()).enabled       # explicit streams still draw
    monkeypatch.setenv("VISMOBILE_STATUS", "on")
    bar = Progress("compare", total=3)
    assert bar.enabled and bar.stream is sys.stderr
