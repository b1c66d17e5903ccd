"""Adapters to other libraries' own entry points, each needing its extra (imported by name only).

``multicrane.integrations.rllib``: RLlib's new API stack (``pip install "multicrane[rllib]"``).
``multicrane.integrations.benchmarl``: BenchMARL tasks (``pip install "multicrane[benchmarl]"``,
in a venv of its own: it conflicts with the ``torchrl`` extra).
Importing this package imports nothing heavy.

May import: every room below it (``core`` to ``reports``) and the public face.
"""
