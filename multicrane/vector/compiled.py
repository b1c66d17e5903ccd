"""The compile options of every vector kernel: ``kernel``, numba's ``njit``, cached, no refcounts.

``cache=True`` keeps the machine code beside the modules (``__pycache__``), so a second process
loads it instead of compiling. ``_nrt=False`` compiles without numba's reference counting:
the kernels pass named tuples of a few dozen arrays to small helpers, and counting every
array in and out of every call cost more than the step itself (about 300 ns per call against
6 ns). The price: a kernel never allocates (scratch space comes in ``PaperBuffers``); every
array it touches is owned by Python. numba checks the cache against the source file of the
function it compiled only, so ``multicrane.vector`` drops this folder's caches when a kernel
source is newer (``multicrane.core.kernel_cache``). ``inlined`` kernels are also inlined into
the kernels that call them (numba's ``inline="always"``). ``DirectCalls`` calls a kernel
without numba's per-call typing of its arguments.
"""

from __future__ import annotations

import numba

kernel = numba.njit(cache=True, _nrt=False)
# The step's helpers, inlined into their callers by numba: a call passes every array of the
# named tuples it takes as separate arguments (hundreds of words), which cost more than the
# helpers' work.
inlined = numba.njit(cache=True, _nrt=False, inline="always")


class DirectCalls:
    """Calls of compiled kernels that skip numba's dispatch after the first.

    numba's dispatcher finds the machine code for a call by typing every argument, and a
    kernel here takes named tuples of a few dozen arrays each: typing them costs about 20 us a
    call, more than a task-level round of one copy. An env whose arguments keep their types
    (the same arrays, written in place) calls each kernel once through the dispatcher (which
    compiles or loads it) and then its compiled entry point for those argument types
    directly; where numba does not expose it, every call goes through the dispatcher."""

    def __init__(self):
        self._entries: dict = {}

    def __call__(self, dispatcher, *args):
        entry = self._entries.get(dispatcher)
        if entry is not None:
            return entry(*args)
        result = dispatcher(*args)
        try:
            types = tuple(dispatcher.typeof_pyval(a) for a in args)
            self._entries[dispatcher] = dispatcher.overloads[types].entry_point
        except (AttributeError, KeyError):
            self._entries[dispatcher] = dispatcher
        return result
