"""timing.timed: a call that compiled numba code is timed again; other calls once."""
import numpy as np
from numba import njit

from vismobile.timing import compiles, timed


def test_a_call_that_compiles_is_timed_again():
    calls = []

    @njit
    def total(values):
        return values.sum()

    def work(values):
        calls.append(1)
        return total(values)

    before = compiles()
    result, ms, compile_ms = timed(work, np.arange(5.0))
    assert result == 10.0 and len(calls) == 2 and compiles() > before
    assert compile_ms > 0.0 and ms >= 0.0
    result, ms, compile_ms = timed(work, np.arange(4.0))  # same signature: compiled already
    assert result == 6.0 and len(calls) == 3 and compile_ms == 0.0
    timed(work, np.arange(4, dtype=np.int64))  # a new signature compiles again
    assert len(calls) == 5


def test_fresh_compiles_count_compiles_not_calls():
    from vismobile.timing import fresh_compiles

    @njit
    def double(x):
        return 2 * x

    before = fresh_compiles()
    double(1.5)
    assert fresh_compiles() == before + 1
    double(2.5)
    assert fresh_compiles() == before + 1


def test_compile_seconds_grow_with_a_compile_only():
    from vismobile.timing import compile_seconds

    @njit
    def triple(x):
        return 3 * x

    before = compile_seconds()
    triple(1.0)
    compiled = compile_seconds()
    assert compiled > before
    triple(2.0)
    assert compile_seconds() == compiled
