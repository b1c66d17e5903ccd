"""``MultiCraneEnv.advance``: ``step`` for rollouts, without observations. It must move the
episode exactly as ``step`` does (state, clock, rewards, ends), build the masks and the state
when they are next asked for, keep the strict mode's check, and refuse a finished episode."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import same

import multicrane
import policies


def _env(scenario, decisions, **options):
    return multicrane.parallel_env(scenario, decisions=decisions, **options)


def _play(env, seed, advance_from, advance_to):
    """An episode of the prioritized planner, shown no observations (the rule for which
    ``advance`` is made), with ``advance`` in rounds ``advance_from`` up to ``advance_to``
    and ``step`` in the others: (rounds, the last step's outputs, every mask and state asked
    for after an advance)."""
    env.reset(seed=seed)
    planner = policies.make("prioritized", env, seed=seed)
    seen, last, rounds = [], None, 0
    while env.agents:
        actions = planner({})
        if advance_from <= rounds < advance_to:
            terminated, truncated = env.advance(actions)
            assert terminated == env.unwrapped.sim.done
            if env.agents:
                seen.append((env.action_masks(), env.state()))
        else:
            last = env.step(actions)
        rounds += 1
    return rounds, last, seen


@pytest.mark.parametrize(("scenario", "decisions"), [("hall-4c", "task"),
                                                     ("frame2-3c", "task"),
                                                     ("e3s2", "motion")])  # fmt: skip
def test_advance_moves_the_episode_as_step_does(scenario, decisions):
    plain = _env(scenario, decisions, n_cranes=3)
    mixed = _env(scenario, decisions, n_cranes=3)
    rounds, last, _ = _play(plain, 4, 0, 0)
    assert rounds > 12
    again, mixed_last, seen = _play(mixed, 4, 3, rounds - 3)  # the last 3 rounds step
    assert again == rounds and seen
    assert same(last, mixed_last)  # the final step's outputs, infos included
    assert mixed.unwrapped.total_reward == plain.unwrapped.total_reward
    assert mixed.unwrapped.sim.state.step_count == plain.unwrapped.sim.state.step_count


def test_masks_and_state_after_advance_are_those_step_would_return():
    env, twin = _env("hall-4c", "task"), _env("hall-4c", "task")
    obs, _ = env.reset(seed=2)
    twin.reset(seed=2)
    planner, twin_planner = policies.make("prioritized", env), policies.make("prioritized", twin)
    for _ in range(6):
        env.advance(planner(obs))
        obs, *_ = twin.step(twin_planner(obs))
        masks = env.action_masks()
        for agent in env.possible_agents:
            assert np.array_equal(masks[agent], obs[agent]["action_mask"])
        assert np.array_equal(env.state(), twin.state())


def test_strict_advance_checks_the_masks_of_the_state_it_left():
    env = _env("hall-4c", "task", strict=True)
    obs, _ = env.reset(seed=0)
    env.advance(policies.make("prioritized", env)(obs))
    masks = env.action_masks()
    agent = next(a for a in env.possible_agents if not masks[a].all())
    illegal = int(np.flatnonzero(masks[agent] == 0)[0])
    actions = {a: 0 for a in env.possible_agents} | {agent: illegal}
    with pytest.raises(ValueError, match=f"{agent} sent illegal action {illegal}"):
        env.advance(actions)


def test_advance_refuses_a_finished_episode():
    env = _env("e1s1", "task", n_cranes=1)
    obs, _ = env.reset(seed=0)
    planner = policies.make("prioritized", env)
    ends = (False, False)
    while env.agents:
        ends = env.advance(planner(obs))
    assert ends == (True, False)
    with pytest.raises(RuntimeError, match="advance\\(\\) called on a finished episode"):
        env.advance({a: 0 for a in env.possible_agents})
