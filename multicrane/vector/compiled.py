"""The compile options of every vector kernel: ``kernel``, numba's ``njit``, cached, no refcounts.

``cache=True`` keeps the machine code beside the modules (``__pycache__``), so a second process
loads it instead of compiling. ``_nrt=False`` compiles without numba's reference counting:
the kernels pass named tuples of a few dozen arrays to small helpers, and counting every
array in and out of every call cost more than the step itself (about 300 ns per call against
6 ns). The price: a kernel never allocates (scratch space comes in ``PaperBuffers``); every
array it touches is owned by Python. numba checks the cache against the source file of the
function it compiled only, so ``multicrane.vector`` drops this folder's caches when a kernel
source is newer (``multicrane.core.kernel_cache``). ``inlined`` kernels are also inlined into
the kernels that call them (numba's ``inline="always"``).
"""

from __future__ import annotations

import numba

kernel = numba.njit(cache=True, _nrt=False)
# The step's helpers, inlined into their callers by numba: a call passes every array of the
# named tuples it takes as separate arguments (hundreds of words), which cost more than the
# helpers' work.
inlined = numba.njit(cache=True, _nrt=False, inline="always")
