"""Uniform random choice among the legal actions: the floor every planner must beat."""

from __future__ import annotations

import numpy as np

from multicrane.episodes.random_actions import random_legal_action, random_legal_actions


class RandomPolicy:
    """Picks uniformly among the actions an ``action_mask`` allows, from its own seed
    (``multicrane.episodes.random_actions``)."""

    def __init__(self, seed: int | None = None):
        self.rng = np.random.default_rng(seed)

    def act(self, mask: np.ndarray) -> int:
        return random_legal_action(mask, self.rng)

    def __call__(self, observations: dict) -> dict:
        """Joint action for a PettingZoo parallel env's observations."""
        masks = {agent: o["action_mask"] for agent, o in observations.items()}
        return random_legal_actions(masks, self.rng)


class RandomMoves(RandomPolicy):
    """The single-agent mode's random policy: uniform over all six moves, ignoring any mask
    (the paper's random baseline): ``policy(observation) -> action``."""

    def __init__(self, seed=None, n_actions: int = 6):
        super().__init__(seed)
        self._all = np.ones(n_actions, dtype=np.int8)

    def __call__(self, observation) -> int:
        return self.act(self._all)
