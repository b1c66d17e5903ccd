"""Task-level machinery: the task book (each crane's (component, target) task), the carrier
that moves components along reserved space-time paths, and the reservations.

May import: ``core``, ``sim`` and ``scenario``.
"""

from multicrane.core.kernel_cache import drop_stale_caches

drop_stale_caches(__file__)  # kernels here call kernels of other files: numba checks one file
