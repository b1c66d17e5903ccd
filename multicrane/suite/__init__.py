"""The benchmark suite (multicrane-bench): frozen instances, bounds, evaluation, verification, page.

May import: every room below it (``core`` to ``replay``).
"""
