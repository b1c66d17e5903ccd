"""The vector room: B copies of one scenario stepped together by compiled kernels (numba).

May import: every room below it (``core`` to ``envs``).
"""

import multicrane.envs
import multicrane.tasks
from multicrane.core.kernel_cache import drop_stale_caches

# Kernels here call kernels of other files, here and in ``tasks`` and ``envs`` (the searches,
# the task observation): numba checks one file.
drop_stale_caches(__file__, multicrane.tasks.__file__, multicrane.envs.__file__)
