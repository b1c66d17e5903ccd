"""Bounds: the paper mode's exact optimum and the proven CP-SAT lower bound on a makespan.

May import: every room below it (``core`` to ``envs``).
"""
