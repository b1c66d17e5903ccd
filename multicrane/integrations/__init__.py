"""Adapters to other libraries' own entry points, each needing its extra (imported by name only).

``multicrane.integrations.rllib``: RLlib's new API stack (``pip install "multicrane[rllib]"``).
Importing this package imports nothing heavy.
"""
