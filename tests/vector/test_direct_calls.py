"""``compiled.DirectCalls``: a kernel called through its compiled entry point answers as
through numba's dispatcher, and anything without one is called as it is."""

from __future__ import annotations

import numba
import numpy as np

from multicrane.vector.compiled import DirectCalls


@numba.njit(_nrt=False)
def _total(a, k):
    s = 0
    for v in a:
        s += v * k
    return s


def test_the_entry_point_answers_as_the_dispatcher():
    call = DirectCalls()
    a = np.arange(5, dtype=np.int64)
    assert call(_total, a, 2) == 20  # through the dispatcher (compiles), entry point kept
    entry = call._entries[_total]
    assert entry is not _total
    a[:] = 1  # the same array written in place: the entry point reads it
    assert call(_total, a, 3) == 15 == _total(a, 3)


def test_a_plain_function_is_called_as_it_is():
    call = DirectCalls()
    assert call(max, 3, 4) == 4
    assert call._entries[max] is max and call(max, 5, 1) == 5
