"""Measured time without numba's first-use work: timed(fn) runs fn again when its first run
acquired numba's compiler lock (a compile, or a load from numba's on-disk cache), so that no
measured figure holds a compile. The warm-up frames of playback and the study catch most of
the kernels; a code path first reached mid-run (an occluder case, a portal, a frame that sends
nothing) is caught here. The count comes from numba's event API ("numba:compiler_lock", fired
each time the global compiler lock is taken: compiles and cache loads, never a plain call)."""
from __future__ import annotations

import time

_COUNT = [0]
_LISTENING = []


def compiles() -> int:
    """Times numba's compiler lock was taken in this process since the first call."""
    if not _LISTENING:
        try:
            from numba.core import event
        except ImportError:  # no numba: nothing compiles
            _LISTENING.append(None)
            return 0

        class Counter(event.Listener):
            def on_start(self, _event):
                _COUNT[0] += 1

            def on_end(self, _event):
                pass

        listener = Counter()
        event.register("numba:compiler_lock", listener)
        _LISTENING.append(listener)
    return _COUNT[0]


def timed(fn, *args) -> tuple:
    """(fn(*args), ms, compile_ms): wall ms of one call; when that call compiled (or loaded from
    numba's cache), fn runs once more and ms is the second call's, compile_ms the first's
    (else 0.0). fn must be safe to call twice with the same arguments (a Culler is: the
    second cull of a camera sees the first as its last frame, as a paused viewer does)."""
    before = compiles()
    start = time.perf_counter()
    result = fn(*args)
    ms = (time.perf_counter() - start) * 1e3
    if compiles() == before:
        return result, ms, 0.0
    first = ms
    start = time.perf_counter()
    result = fn(*args)
    return result, (time.perf_counter() - start) * 1e3, first
