"""Progress on stderr for long work (no dependency): a bar with a known total, status lines
without one. On a terminal both redraw one line (carriage return); in a log (stderr not a
terminal) they write plain lines: nothing for work under QUIET_SECONDS, then a line every
LOG_INTERVAL seconds and the final state, so a redirected run still says what it is doing.
VISMOBILE_STATUS=off in the environment silences both on stderr (scripts that parse stderr)."""
from __future__ import annotations

import os
import sys
import threading
import time

# Redraw at most this often on a terminal (seconds): a bar fed thousands of steps stays cheap.
REDRAW_INTERVAL = 0.5
# Work shorter than this prints nothing (seconds).
QUIET_SECONDS = 2.0
# Plain lines in a log at most this often (seconds).
LOG_INTERVAL = 10.0
# perf_counter() when the running CLI command started (cli.main sets it, then clears it): the
# quiet time counts from there, so a command whose steps are each short but add up to more
# than QUIET_SECONDS still shows its later steps. None outside a command.
COMMAND_START = None


def _silenced(stream) -> bool:
    """True when drawing would go to stderr and VISMOBILE_STATUS=off asks for silence."""
    return stream is None and os.environ.get("VISMOBILE_STATUS", "").lower() == "off"


def _running(start, now) -> float:
    """Seconds the work (or the command around it) has been running."""
    begun = start if COMMAND_START is None else min(start, COMMAND_START)
    return now - begun


class Progress:
    """Callable(done, total) drawing `label [#####.....]  50%  12.3s, eta 12s` on stderr.

    Partition builders call it with (done, total); counting loops call step() after each item
    of `total`. On a terminal it redraws one line at most every REDRAW_INTERVAL seconds; in a
    log it writes a plain line after QUIET_SECONDS and then every LOG_INTERVAL seconds, and
    its final state if it wrote any. Nothing for work shorter than QUIET_SECONDS either way.
    enabled : None draws (in the stream's mode); False never draws
    clock   : seconds counter (tests pass a fake one)
    """

    def __init__(self, label: str, stream=None, enabled=None, width: int = 30, total: int = 0,
                 clock=time.perf_counter):
        self.label, self.width, self.total = label, width, int(total)
        self.enabled = (True if enabled is None else bool(enabled)) and not _silenced(stream)
        self.stream = sys.stderr if stream is None else stream
        self.tty = _isatty(self.stream)
        self.clock = clock
        self.start = clock()
        self.shown = None
        self.done = 0
        self.drawn = False
        self.final = False
        self.last = None

    def step(self, count: int = 1) -> None:
        """Count `count` more items of `total` done and redraw."""
        self.done += count
        self(self.done, self.total)

    def __call__(self, done, total) -> None:
        if not self.enabled:
            return
        now = self.clock()
        self.last = (done, total)
        finished = not total or done >= total
        elapsed = now - self.start
        if _running(self.start, now) < QUIET_SECONDS and not (finished and self.drawn):
            return
        interval = REDRAW_INTERVAL if self.tty else LOG_INTERVAL
        if self.shown is not None and now - self.shown < interval and not finished:
            return
        if finished and self.final:
            return
        self.shown, self.final = now, finished
        self._draw(done, total, elapsed)

    def _draw(self, done, total, elapsed) -> None:
        fraction = min(max(done / total, 0.0), 1.0) if total else 1.0
        eta = f", eta {elapsed / fraction - elapsed:.0f}s" if 0.0 < fraction < 1.0 else ""
        if self.tty:
            filled = int(round(fraction * self.width))
            bar = "#" * filled + "." * (self.width - filled)
            self.stream.write(f"\r{self.label} [{bar}] {fraction:4.0%} {elapsed:6.1f}s{eta} ")
        else:
            count = f" ({done:,} of {total:,})" if total else ""
            self.stream.write(f"{self.label}: {fraction:.0%}{count}, {elapsed:.1f}s{eta}\n")
        self.stream.flush()
        self.drawn = True

    def close(self) -> None:
        """End the bar: its final state in a log (if it drew before), the line on a terminal."""
        if not self.drawn:
            return
        if not self.tty and self.last is not None:
            done, total = self.last
            if total and done < total:  # ended early (an error): say where
                self._draw(done, total, self.clock() - self.start)
        if self.tty:
            self.stream.write("\n")
            self.stream.flush()
        self.drawn = False


class Status:
    """Status lines on stderr for long work without a known total ("tune w1: 3 structure(s)
    probed, 12 s"). Each call sets the current step; it is shown once the work has run
    QUIET_SECONDS (a background ticker shows a step that is still running then, and again
    every LOG_INTERVAL seconds), so work shorter than that prints nothing. On a terminal each
    line overwrites the last; in a log each is a plain line.
    """

    def __init__(self, label: str, enabled: bool = True, stream=None, quiet: float = QUIET_SECONDS,
                 interval: float = LOG_INTERVAL, clock=time.perf_counter, ticker: bool = True):
        self.label, self.enabled = label, enabled and not _silenced(stream)
        self.stream = sys.stderr if stream is None else stream
        self.clock, self.quiet, self.interval = clock, quiet, interval
        self.start = clock()
        self.tty = _isatty(self.stream)
        self.text, self.shown_text, self.shown_at = None, None, None
        self.lock = threading.Lock()
        self.stop = threading.Event()
        self.thread = None
        if self.enabled and ticker:
            self.thread = threading.Thread(target=self._tick, daemon=True)
            self.thread.start()

    def __call__(self, text: str) -> None:
        if self.enabled:
            with self.lock:
                self.text = text
                self._maybe_show(self.clock())

    def _tick(self) -> None:
        while not self.stop.wait(0.25):
            with self.lock:
                self._maybe_show(self.clock())

    def _maybe_show(self, now) -> None:
        """Show the current step when the work is past `quiet` and the step is new, or the same
        step has run `interval` since it was last shown."""
        if self.text is None or _running(self.start, now) < self.quiet:
            return
        if self.text == self.shown_text and now - self.shown_at < self.interval:
            return
        line = f"{self.label}: {self.text}, {now - self.start:.0f} s"
        self.stream.write(f"\r{line:<78}" if self.tty else line + "\n")
        self.stream.flush()
        self.shown_text, self.shown_at = self.text, now

    def done(self) -> None:
        """Stop the ticker; end the overwritten line on a terminal."""
        self.stop.set()
        if self.thread is not None:
            self.thread.join()
        if self.enabled and self.tty and self.shown_text is not None:
            self.stream.write("\n")
            self.stream.flush()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.done()


def _isatty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False
