"""Measured time without numba's first-use work: timed(fn) runs fn again when its first run
acquired numba's compiler lock (a compile, or a load from numba's on-disk cache), so that no
measured figure holds a compile. The warm-up frames of playback and the study catch most of
the kernels; a code path first reached mid-run (an occluder case, a portal, a frame that sends
nothing) is caught here. The count comes from numba's event API ("numba:compiler_lock", fired
each time the global compiler lock is taken: compiles and cache loads, never a plain call)."""
from __future__ import annotations

import time

_COUNTS = {"numba:compiler_lock": 0, "numba:compile": 0}
_SECONDS = {"numba:compile": 0.0}  # wall seconds inside numba's compiles (outermost only)
_OPEN = {"numba:compile": []}
_LISTENING = []


def _listen() -> None:
    if _LISTENING:
        return
    try:
        from numba.core import event
    except ImportError:  # no numba: nothing compiles
        _LISTENING.append(None)
        return

    class Counter(event.Listener):
        def __init__(self, kind):
            self.kind = kind

        def on_start(self, _event):
            _COUNTS[self.kind] += 1
            if self.kind in _OPEN:
                _OPEN[self.kind].append(time.perf_counter())

        def on_end(self, _event):
            if self.kind in _OPEN and _OPEN[self.kind]:
                start = _OPEN[self.kind].pop()
                if not _OPEN[self.kind]:  # nested compiles count once, in the outermost
                    _SECONDS[self.kind] += time.perf_counter() - start

    for kind in _COUNTS:
        listener = Counter(kind)
        event.register(kind, listener)
        _LISTENING.append(listener)


def compiles() -> int:
    """Times numba's compiler lock was taken in this process since the first call (a compile
    or a load from numba's cache: anything a plain call would not do)."""
    _listen()
    return _COUNTS["numba:compiler_lock"]


def fresh_compiles() -> int:
    """Functions numba compiled (not loaded from its cache) in this process since the first
    call: what makes a first run slow."""
    _listen()
    return _COUNTS["numba:compile"]


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


def compile_seconds() -> float:
    """Wall seconds this process spent in numba's compiles since the first call of any
    function here (what a first run costs; a later run loads numba's cache instead)."""
    _listen()
    return _SECONDS["numba:compile"]
