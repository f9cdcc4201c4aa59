"""A one-line stderr progress bar for long offline work (no dependency; silent off a terminal)."""
from __future__ import annotations

import sys
import time

# Redraw at most this often (seconds): a bar fed thousands of steps stays cheap and readable.
REDRAW_INTERVAL = 0.5


class Progress:
    """Callable(done, total) drawing `label [#####.....]  50%  12.3s, eta 12s` on one stderr line.

    Partition builders call it with (done, total); counting loops call step() after each item
    of `total`. Draws at most every REDRAW_INTERVAL seconds, and always at the end.
    enabled : None draws only when the stream is a terminal (a redirected log gets nothing)
    """

    def __init__(self, label: str, stream=None, enabled=None, width: int = 30, total: int = 0):
        self.label, self.width, self.total = label, width, int(total)
        self.stream = sys.stderr if stream is None else stream
        self.enabled = self.stream.isatty() if enabled is None else bool(enabled)
        self.start = time.perf_counter()
        self.shown = -REDRAW_INTERVAL
        self.done = 0
        self.drawn = False

    def step(self, count: int = 1) -> None:
        """Count `count` more items of `total` done and redraw."""
        self.done += count
        self(self.done, self.total)

    def __call__(self, done, total) -> None:
        if not self.enabled:
            return
        now = time.perf_counter()
        finished = not total or done >= total
        if now - self.shown < REDRAW_INTERVAL and not finished:
            return
        self.shown = now
        fraction = min(max(done / total, 0.0), 1.0) if total else 1.0
        filled = int(round(fraction * self.width))
        bar = "#" * filled + "." * (self.width - filled)
        elapsed = now - self.start
        eta = f", eta {elapsed / fraction - elapsed:.0f}s" if 0.0 < fraction < 1.0 else ""
        self.stream.write(f"\r{self.label} [{bar}] {fraction:4.0%} {elapsed:6.1f}s{eta} ")
        self.stream.flush()
        self.drawn = True

    def close(self) -> None:
        """End the bar's line (only if one was drawn)."""
        if self.drawn:
            self.stream.write("\n")
            self.stream.flush()
            self.drawn = False


class Status:
    """Status lines on stderr for long work without a known total ("tune w1: 3 structure(s)
    probed, 12 s"): on a terminal each overwrites the last; in a log each is one line."""

    def __init__(self, label: str, enabled: bool = True, stream=None):
        self.label, self.enabled = label, enabled
        self.stream = sys.stderr if stream is None else stream
        self.start = time.perf_counter()
        self.tty = self.stream.isatty()

    def __call__(self, text: str) -> None:
        if self.enabled:
            line = f"{self.label}: {text}, {time.perf_counter() - self.start:.0f} s"
            self.stream.write(f"\r{line:<78}" if self.tty else line + "\n")
            self.stream.flush()

    def done(self) -> None:
        """End the overwritten line on a terminal."""
        if self.enabled and self.tty:
            self.stream.write("\n")
            self.stream.flush()
