"""Uniform random choice among the legal actions: the floor every planner must beat."""

from __future__ import annotations

import numpy as np


class RandomPolicy:
    """Picks uniformly among the actions an ``action_mask`` allows, from its own seed."""

    def __init__(self, seed: int | None = None):
        self.rng = np.random.default_rng(seed)

    def act(self, mask: np.ndarray) -> int:
        legal = np.flatnonzero(mask)
        return int(legal[self.rng.integers(len(legal))])

    def __call__(self, observations: dict) -> dict:
        """Joint action for a PettingZoo parallel env's observations."""
        return {a: self.act(o["action_mask"]) for a, o in observations.items()}


class RandomMoves(RandomPolicy):
    """The single-agent mode's random policy: uniform over all six moves, ignoring any mask
    (the paper's random baseline): ``policy(observation) -> action``."""

    def __init__(self, seed=None, n_actions: int = 6):
        super().__init__(seed)
        self._all = np.ones(n_actions, dtype=np.int8)

    def __call__(self, observation) -> int:
        return self.act(self._all)
