"""Uniformly random legal actions from action masks: the one random-legal sampler.

    from multicrane.episodes.random_actions import random_legal_action, random_legal_actions
    a = random_legal_action(obs["crane_0"]["action_mask"], rng)           # one mask
    joint = random_legal_actions({a: o["action_mask"] for a, o in obs.items()}, rng)
    choice = random_legal_rows(np.stack(masks), rng)                      # [N, A] at once
    policy = random_legal_policy(env.possible_agents, rng)                # for play()

``random_legal_action`` draws ``legal[rng.integers(len(legal))]`` (the same draw as
``rng.choice(np.flatnonzero(mask))``), and ``random_legal_actions`` draws it for each agent in
the dict's order: the random policy (``policies.random_policy``) and the tests' helper use
these, so their episodes stay seed for seed what they were. ``random_legal_rows`` draws for
every row of an ``[N, A]`` mask at once, as a vectorised masked policy samples: the legal
action with the largest of ``N x A`` uniform keys (one ``rng.random`` call), so the same
distribution from a different stream; ``random_legal_policy`` wraps it as the
``policy(observations) -> {agent: action}`` the throughput measurements (``multicrane
bench``, ``multicrane.reports.scaling``, ``tools/cpu_costs.py``) play. Every sampler refuses
a mask that allows nothing (``ValueError``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np


def random_legal_action(mask, rng: np.random.Generator) -> int:
    """One action drawn uniformly among those ``mask`` allows (nonzero entries)."""
    legal = np.flatnonzero(mask)
    if not legal.size:
        raise ValueError("the action mask allows no action")
    return int(legal[rng.integers(legal.size)])


def random_legal_actions(masks: Mapping[str, object], rng: np.random.Generator) -> dict:
    """``{agent: random_legal_action(mask, rng)}``, drawn in the order of ``masks``."""
    out = {}
    for agent, mask in masks.items():
        try:
            out[agent] = random_legal_action(mask, rng)
        except ValueError:
            raise ValueError(f"{agent}: the action mask allows no action") from None
    return out


def random_legal_rows(masks: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """One legal action per row of the ``[N, A]`` 0/1 ``masks``, all drawn at once (the
    largest uniform key among the row's legal actions)."""
    allowed = masks.any(axis=1)
    if not allowed.all():
        raise ValueError(f"row {int(allowed.argmin())}: the action mask allows no action")
    return (rng.random(masks.shape) * masks).argmax(axis=1)


def random_legal_policy(agents: Sequence[str], rng: np.random.Generator) -> Callable:
    """A ``policy(observations) -> {agent: action}`` of ``random_legal_rows`` over the
    ``action_mask`` of each of ``agents`` (in that order)."""

    def policy(observations: dict) -> dict:
        masks = np.stack([observations[a]["action_mask"] for a in agents])
        choice = random_legal_rows(masks, rng).tolist()
        return dict(zip(agents, choice, strict=True))

    return policy
