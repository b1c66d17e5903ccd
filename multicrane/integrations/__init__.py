"""Adapters to other libraries' own entry points, each needing its extra (imported by name only).

``multicrane.integrations.rllib``: RLlib's new API stack (``pip install "multicrane[rllib]"``).
``multicrane.integrations.benchmarl``: BenchMARL tasks (``pip install "multicrane[benchmarl]"``,
in a venv of its own: it conflicts with the ``torchrl`` extra).
``multicrane.integrations.pufferlib_env``: native PufferLib 3 envs over the vector envs
(PufferLib in a venv of its own: ``tools/test_pufferlib.sh``).
Importing this package imports nothing heavy.

May import: every room below it (``core`` to ``reports``) and the public face.
"""
