"""Running episodes: the one episode loop, evaluation over seeds, their summary, random actions.

May import: every room below it (``core`` to ``bounds``).
"""
