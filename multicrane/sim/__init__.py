"""The rules of one site: geometry, the static site, episode state, legality, transitions,
reach, site events and the simulator's step, with the grid searches they need.

May import: ``multicrane.core`` and the root helpers.
"""
