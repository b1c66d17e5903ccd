"""The vector room: B copies of one scenario stepped together by compiled kernels (numba).

May import: every room below it (``core`` to ``envs``).
"""

from multicrane.core.kernel_cache import drop_stale_caches

drop_stale_caches(__file__)  # kernels here call kernels of other files: numba checks one file
