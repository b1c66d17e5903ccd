"""The task-level vector env equals the one-site task env, copy by copy (issue 31, part 3).

Every shipped scenario with every crane count from 1 to 4 (a count the one-site env refuses
is refused with the same message), generated sites never shipped, and hypothesis drawing
scenarios, crane counts, seeds, options and the mix of choices (random allowed tasks, waits,
and tasks the mask does not allow, which the env refuses): every round's observations, masks,
rewards, terminations, truncations, physical and task event counts, elapsed steps, busy
crane-steps and each copy's generator equal those of ``MultiCraneEnv(decisions="task")``
copies reset with the same seeds, autoresets included. The compiled prioritized rule
(``TaskVectorEnv.propose``) sends what ``TaskPrioritized`` sends, round for round, with the
same carrier counters. The large runs are behind ``-m fuzz``.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import policies
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.scenario.named_sets import resolve_set
from multicrane.vector.pcg64 import state_of
from multicrane.vector.task_site import lifted_shape
from multicrane.vector.task_vector_env import TaskVectorEnv

SCENARIOS = sorted(p.stem for p in Path("scenarios").glob("*.toml"))
DRAWN = [("e1s1", 1), ("e2s3", 2), ("e4s3", 3), ("hall-4c", 4), ("towers-3c", 3),
         ("precast-frame", 2), ("precast-house", 3), ("frame2-3c", 3)]  # fmt: skip


def _references(scenario, cranes, seeds, options):
    envs = [MultiCraneEnv(scenario, cranes, decisions="task", obs_format="flat", **options)
            for _ in seeds]  # fmt: skip
    return envs, [env.reset(seed=s)[0] for env, s in zip(envs, seeds, strict=True)]


def _choices(vec, rng, wild: float) -> np.ndarray:
    """Per copy and idle crane: a random allowed task (else wait); with probability ``wild``
    any task at all (the env refuses one not allowed)."""
    masks = vec.action_masks()
    out = np.zeros(masks.shape[:2], dtype=np.int64)
    for b, k in np.ndindex(*masks.shape[:2]):
        allowed = np.flatnonzero(masks[b, k, 1:])
        if rng.random() < wild:
            out[b, k] = rng.integers(0, vec.n_actions)
        elif len(allowed) and rng.random() < 0.9:
            out[b, k] = 1 + rng.choice(allowed)
    return out


def _same_round(vec, envs, ref_obs, actions, step) -> int:
    """Step both with ``actions``; every output equal. Returns the episodes that ended."""
    obs, rewards, terms, truncs, infos = step
    agents = envs[0].possible_agents
    ended = 0
    for b, env in enumerate(envs):
        o, r, te, tr, inf = env.step({a: int(actions[b, k]) for k, a in enumerate(agents)})
        for k, a in enumerate(agents):
            assert rewards[b, k] == r[a] and terms[b, k] == te[a] and truncs[b, k] == tr[a]
            for name in ("event_counts", "task_event_counts"):
                assert np.array_equal(infos[name][b, k], inf[a][name]), (b, a, name)
            assert infos["reward_term"][b, k] == inf[a]["reward_term"]
            assert infos["elapsed"][b] == inf[a]["elapsed"]
            assert infos["crane_steps"][b] == inf[a]["crane_steps"]
        if te[agents[0]] or tr[agents[0]]:
            ended += 1
            assert np.array_equal(infos["final_obs"][b], np.stack([o[a] for a in agents]))
            o, _ = env.reset()  # goes on with its generator, as the copy's autoreset
        ref_obs[b] = o
    _same_now(vec, envs, ref_obs, obs)
    return ended


def _same_now(vec, envs, ref_obs, obs) -> None:
    masks = vec.action_masks()
    for b, env in enumerate(envs):
        agents = env.possible_agents
        assert np.array_equal(obs[b], np.stack([ref_obs[b][a] for a in agents])), b
        ref = env.action_masks()
        assert np.array_equal(masks[b], np.stack([ref[a] for a in agents])), b
        assert np.array_equal(vec.state.rng[b], state_of(env.np_random)), b


def _play(scenario, cranes, seeds, options, rounds, wild=0.1, rule=None, seed=0) -> int:
    """``rounds`` rounds of both envs (random choices, or the prioritized rule ``rule``, a
    dict of its options); every output equal. Returns the episodes that ended."""
    vec = TaskVectorEnv(len(seeds), scenario, cranes, **options)
    envs, ref_obs = _references(scenario, cranes, seeds, options)
    obs, _ = vec.reset(seed=seeds)
    _same_now(vec, envs, ref_obs, obs)
    planners = None
    if rule is not None:
        planners = [policies.make("prioritized", env, seed=0, **rule) for env in envs]
    rng = np.random.default_rng(seed)
    ended = 0
    for _ in range(rounds):
        if planners is None:
            actions = _choices(vec, rng, wild)
        else:
            actions = vec.propose(**rule)
            for b, (env, planner) in enumerate(zip(envs, planners, strict=True)):
                sent = planner(ref_obs[b])
                assert [sent[a] for a in env.possible_agents] == actions[b].tolist(), b
        ended += _same_round(vec, envs, ref_obs, actions, vec.step(actions))
        if planners is not None:
            for b, env in enumerate(envs):
                assert vec.carrier_stats(b) == env.mode.carrier_stats(), b
    return ended


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_every_shipped_scenario_and_crane_count_is_the_one_site_env(scenario):
    for cranes in (1, 2, 3, 4):
        try:
            MultiCraneEnv(scenario, cranes, decisions="task")
        except ValueError as refused:
            with pytest.raises(ValueError, match=re.escape(str(refused))):
                TaskVectorEnv(2, scenario, cranes)
            continue
        _play(scenario, cranes, [cranes, 10 + cranes], {}, rounds=40)


@pytest.mark.parametrize(("scenario", "cranes"), [("hall-4c", 4), ("towers-3c", 3),
                                                  ("precast-house", 2), ("e3s2", 1)])
def test_the_compiled_prioritized_rule_is_task_prioritized(scenario, cranes):
    """Whole episodes (autoresets included) of the rule in each rank, with its search cap."""
    ended = 0
    for rule in ({}, {"rank": "nearest", "max_searches": 2}, {"rank": "chain"}):
        ended += _play(scenario, cranes, [3, 4], {}, rounds=60, rule=rule)
    assert ended > 0


@pytest.mark.parametrize("name", ["test-small", "test-large", "test-other"])
def test_generated_sites_never_shipped(name):
    """Held-out generated sites (reach, random yards, interchangeable targets), random
    choices and the rule."""
    for _, scenario in resolve_set(f"set:{name}")[:2]:
        _play(scenario, None, [5, 6], {}, rounds=25)
        _play(scenario, None, [7], {}, rounds=25, rule={})


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.sampled_from(DRAWN), st.lists(st.integers(0, 2**31), min_size=1, max_size=3),
    st.sampled_from(["paper", "makespan"]), st.sampled_from(["team", "split"]),
    st.sampled_from([None, 25, 80]), st.sampled_from([None, 3]), st.sampled_from([20, 1, 4]),
    st.floats(0, 0.5), st.integers(0, 2**16),
)  # fmt: skip
def test_drawn_sites_seeds_options_and_choices(site, seeds, reward, mode, steps, cycles,
                                               patience, wild, seed):  # fmt: skip
    options = {"reward": reward, "reward_mode": mode, "max_steps": steps, "max_cycles": cycles,
               "task_patience": patience}  # fmt: skip
    _play(*site, seeds, options, rounds=25, wild=wild, seed=seed)


@pytest.mark.fuzz
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(DRAWN), st.lists(st.integers(0, 2**31), min_size=1, max_size=4),
       st.floats(0, 0.5), st.booleans(), st.integers(0, 2**16))  # fmt: skip
def test_long_play_fuzz(site, seeds, wild, rule, seed):
    _play(*site, seeds, {}, rounds=300, wild=wild, rule={} if rule else None, seed=seed)


def test_lifted_shapes_are_the_pickup_poses():
    """The shape the compiler gives each component is its pick-up pose's, as the one-site
    state has it, over starts drawn at random."""
    for scenario in SCENARIOS:
        env = MultiCraneEnv(scenario, decisions="task")
        for seed in range(3):
            env.reset(seed=seed)
            for c, pick in enumerate(env.sim.state.pickup):
                if pick:
                    assert lifted_shape(env, c) == tuple(j - pick[0] for j in pick), scenario
