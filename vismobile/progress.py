"""A one-line stderr progress bar for long offline builds (no dependency; silent off a terminal)."""
from __future__ import annotations

import sys
import time


class Progress:
    """Callable(done, total) drawing `label [#####.....] 50%` on one stderr line.

    enabled : None draws only when the stream is a terminal
    """

    def __init__(self, label: str, stream=None, enabled=None, width: int = 30):
        self.label, self.width = label, width
        self.stream = sys.stderr if stream is None else stream
        self.enabled = self.stream.isatty() if enabled is None else bool(enabled)
        self.start = time.perf_counter()
        self.drawn = False

    def __call__(self, done, total) -> None:
        if not self.enabled:
            return
        fraction = min(max(done / total, 0.0), 1.0) if total else 1.0
        filled = int(round(fraction * self.width))
        bar = "#" * filled + "." * (self.width - filled)
        elapsed = time.perf_counter() - self.start
        self.stream.write(f"\r{self.label} [{bar}] {fraction:4.0%} {elapsed:6.1f}s")
        self.stream.flush()
        self.drawn = True

    def close(self) -> None:
        """End the bar's line (only if one was drawn)."""
        if self.drawn:
            self.stream.write("\n")
            self.stream.flush()
            self.drawn = False
