"""Scenario files: the strict loader and its checks, limits, solvability, the writer, the
catalog of shipped scenarios, named scenario sets and the generator.

May import: ``core`` and ``sim``.
"""
