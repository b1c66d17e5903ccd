"""Replays: episode records that re-simulate exactly, their files, and 3D replays in rerun.

May import: every room below it (``core`` to ``episodes``).
"""
