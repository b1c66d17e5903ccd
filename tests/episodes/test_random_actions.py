"""The one random-legal sampler (``multicrane.episodes.random_actions``): only legal actions,
every legal action, the same draws for the same seed, and a clear refusal of an empty mask."""

from __future__ import annotations

import numpy as np
import pytest

import multicrane
from multicrane.episodes.random_actions import (
    random_legal_action,
    random_legal_actions,
    random_legal_policy,
    random_legal_rows,
)
from policies.random_policy import RandomPolicy

MASK = np.array([0, 1, 0, 0, 1, 0, 0, 1, 0], dtype=np.int8)
ROWS = np.array([[1, 0, 0, 1, 0], [0, 0, 1, 0, 0], [1, 1, 1, 1, 1]], dtype=np.int8)


def test_one_mask_draws_every_legal_action_and_nothing_else():
    rng = np.random.default_rng(0)
    drawn = [random_legal_action(MASK, rng) for _ in range(300)]
    assert set(drawn) == {1, 4, 7}
    assert all(isinstance(a, int) for a in drawn)


def test_one_mask_is_deterministic_by_seed_and_draws_as_rng_choice_did():
    def draws(seed):
        rng = np.random.default_rng(seed)
        return [random_legal_action(MASK, rng) for _ in range(50)]

    assert draws(3) == draws(3) != draws(4)
    rng = np.random.default_rng(3)  # the copies it replaced: rng.choice(np.flatnonzero(mask))
    assert draws(3) == [int(rng.choice(np.flatnonzero(MASK))) for _ in range(50)]


def test_a_dict_of_masks_draws_per_agent_in_order_as_one_mask_does():
    masks = {"crane_0": MASK, "crane_1": np.array([0, 0, 1]), "crane_2": np.ones(4)}
    a, b = np.random.default_rng(9), np.random.default_rng(9)
    for _ in range(20):
        joint = random_legal_actions(masks, a)
        assert list(joint) == list(masks)
        assert joint == {agent: random_legal_action(m, b) for agent, m in masks.items()}
        assert joint["crane_1"] == 2 and MASK[joint["crane_0"]]


def test_rows_draw_every_legal_action_of_each_row_and_nothing_else():
    rng = np.random.default_rng(0)
    drawn = np.array([random_legal_rows(ROWS, rng) for _ in range(400)])
    for row, mask in enumerate(ROWS):
        assert set(drawn[:, row].tolist()) == set(np.flatnonzero(mask).tolist())


def test_rows_are_deterministic_by_seed_and_draw_the_largest_legal_key():
    def draws(seed):
        rng = np.random.default_rng(seed)
        return [random_legal_rows(ROWS, rng).tolist() for _ in range(30)]

    assert draws(1) == draws(1) != draws(2)
    rng = np.random.default_rng(1)  # the inline draw the throughput programs made before
    assert draws(1) == [(rng.random(ROWS.shape) * ROWS).argmax(axis=1).tolist() for _ in range(30)]


def test_every_sampler_refuses_a_mask_that_allows_nothing():
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="allows no action"):
        random_legal_action(np.zeros(5, dtype=np.int8), rng)
    with pytest.raises(ValueError, match="crane_1: the action mask allows no action"):
        random_legal_actions({"crane_0": MASK, "crane_1": np.zeros(3)}, rng)
    empty_row = ROWS.copy()
    empty_row[1] = 0
    with pytest.raises(ValueError, match="row 1: the action mask allows no action"):
        random_legal_rows(empty_row, rng)


def test_the_policy_of_rows_sends_legal_actions_of_every_agent():
    env = multicrane.parallel_env("e2s2", n_cranes=2)
    policy = random_legal_policy(env.possible_agents, np.random.default_rng(0))
    obs, _ = env.reset(seed=0)
    for _ in range(20):
        joint = policy(obs)
        assert list(joint) == env.possible_agents
        assert all(obs[a]["action_mask"][x] for a, x in joint.items())
        obs, *_ = env.step(joint)


def test_the_random_policy_is_the_sampler_on_its_own_stream():
    env = multicrane.parallel_env("e2s2", n_cranes=2)
    obs, _ = env.reset(seed=0)
    rng = np.random.default_rng(5)
    policy = RandomPolicy(5)
    masks = {a: o["action_mask"] for a, o in obs.items()}
    assert [policy(obs) for _ in range(10)] == [random_legal_actions(masks, rng) for _ in range(10)]
