"""The vector room: B copies of one scenario stepped together by compiled kernels (numba).

May import: every room below it (``core`` to ``envs``).
"""
