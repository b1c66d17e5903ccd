"""Running episodes: the one episode loop, evaluation over seeds and their summary.

May import: every room below it (``core`` to ``bounds``).
"""
