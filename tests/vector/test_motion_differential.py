"""The vector motion env equals the one-site env, copy by copy (issue 31, part 2).

Every shipped scenario with every crane count from 1 to 4 (a count the one-site env refuses
is refused with the same message), and hypothesis drawing scenarios, crane counts, seeds,
reward options, step limits and the mix of actions (the greedy planner's, to claim, carry,
assemble and finish episodes; random legal ones; and any action at all, masked or not):
every step's observations, masks, rewards, terminations, truncations, event counts, reward
terms and each copy's generator equal those of ``MultiCraneEnv`` copies reset with the same
seeds, autoresets included (the one-site env is reset with ``reset()`` after an episode,
going on with its generator). The large runs are behind ``-m fuzz``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.vector.motion_vector_env import MotionVectorEnv
from multicrane.vector.pcg64 import state_of
from policies.greedy import GreedyPolicy

SCENARIOS = sorted(p.stem for p in Path("scenarios").glob("*.toml"))
CRANE_COUNTS = (1, 2, 3, 4)
# (scenario, cranes) pairs hypothesis draws from: small and large sites, reach, beams, panels.
DRAWN = [("e1s1", 1), ("e2s3", 2), ("e4s3", 3), ("hall-4c", 4), ("towers-3c", 3),
         ("precast-frame", 2), ("precast-house", 2), ("frame2-3c", 3)]  # fmt: skip
COPIES = 2


def _references(scenario: str, seeds: list[int], options: dict) -> list[MultiCraneEnv]:
    return [MultiCraneEnv(scenario, obs_format="flat", **options) for _ in seeds]


def _same_outputs(vec, envs, obs, step_out, ref_outs, done, seen=None) -> None:
    """Every copy's arrays equal its one-site env's dicts (``final_obs`` where it ended);
    with site events their counts too, added into ``seen`` when given."""
    agents = envs[0].possible_agents
    for b, ref in enumerate(ref_outs):
        ref_obs = ref[0]
        shown = vec.buffers.final_obs if done[b] else obs
        for k, a in enumerate(agents):
            assert np.array_equal(shown[b, k], ref_obs[a]), (b, a)
            if step_out is not None:
                rewards, terms, truncs, infos = step_out
                _, r, te, tr, inf = ref
                assert rewards[b, k] == r[a], (b, a)
                assert terms[b, k] == te[a] and truncs[b, k] == tr[a], (b, a)
                assert np.array_equal(infos["event_counts"][b, k], inf[a]["event_counts"])
                assert infos["reward_term"][b, k] == inf[a]["reward_term"]
                assert ("site_event_counts" in infos) == ("site_event_counts" in inf[a])
                if "site_event_counts" in infos:
                    counts = infos["site_event_counts"][b]
                    assert np.array_equal(counts, inf[a]["site_event_counts"]), (b, a)
                    if seen is not None and k == 0:
                        seen += counts


def _same_now(vec, envs) -> None:
    """Masks and generators equal after a step or reset (the one-site envs reset if done)."""
    masks = vec.action_masks()
    for b, env in enumerate(envs):
        ref = env.action_masks()
        for k, a in enumerate(env.possible_agents):
            assert np.array_equal(masks[b, k], ref[a]), (b, a)
        assert np.array_equal(vec.state.rng[b], state_of(env.np_random)), b


def _actions(vec, policies, rng, greedy: float, wild: float) -> np.ndarray:
    """Per copy and crane: the greedy planner's action with probability ``greedy``, else a
    random legal one, else (probability ``wild``) any action at all."""
    masks = vec.action_masks()
    out = np.zeros(masks.shape[:2], dtype=np.int64)
    for b, policy in enumerate(policies):
        planned = None
        if policy is not None and rng.random() < greedy:
            agents = policy.env.possible_agents
            planned = policy({a: {"action_mask": masks[b, k]} for k, a in enumerate(agents)})
        for k in range(masks.shape[1]):
            if rng.random() < wild:
                out[b, k] = rng.integers(masks.shape[2])
            elif planned is not None:
                out[b, k] = planned[f"crane_{k}"]
            else:
                out[b, k] = rng.choice(np.flatnonzero(masks[b, k]))
    return out


def play_both(scenario, n_cranes, seeds, steps, greedy=0.8, wild=0.05, seen=None,
              **options) -> int:  # fmt: skip
    """Step both sides ``steps`` times with the same joint actions; returns the episodes
    that ended (and adds the site events of every step and reset into ``seen``)."""
    options = dict(options, n_cranes=n_cranes)
    vec = MotionVectorEnv(len(seeds), scenario, **options)
    envs = _references(scenario, seeds, options)
    obs, infos = vec.reset(seed=seeds)
    starts = [env.reset(seed=s) for env, s in zip(envs, seeds, strict=True)]
    _same_outputs(vec, envs, obs, None, starts, np.zeros(len(seeds), dtype=bool))
    if "site_event_counts" in infos:
        for b, (_, ref_infos) in enumerate(starts):
            counts = ref_infos["crane_0"]["site_event_counts"]
            assert np.array_equal(infos["site_event_counts"][b], counts), ("reset", b)
            if seen is not None:
                seen += counts
    _same_now(vec, envs)
    rng = np.random.default_rng(seeds[0])
    policies = [GreedyPolicy(env, seed=s) for env, s in zip(envs, seeds, strict=True)]
    ended = 0
    for _ in range(steps):
        joint = _actions(vec, policies, rng, greedy, wild)
        obs, rewards, terms, truncs, infos = vec.step(joint)
        outs = [
            env.step({a: int(joint[b, k]) for k, a in enumerate(env.possible_agents)})
            for b, env in enumerate(envs)
        ]
        done = infos["_final_obs"]
        _same_outputs(vec, envs, obs, (rewards, terms, truncs, infos), outs, done, seen)
        for b in np.flatnonzero(done):
            ended += 1
            first, first_infos = envs[b].reset()
            if seen is not None and "site_event_counts" in first_infos["crane_0"]:
                seen += first_infos["crane_0"]["site_event_counts"]
            for k, a in enumerate(envs[b].possible_agents):
                assert np.array_equal(obs[b, k], first[a]), ("autoreset", b, a)
        _same_now(vec, envs)
    return ended


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_every_scenario_and_crane_count(scenario):
    """Each shipped scenario with 1 to 4 cranes: the same outputs for a short random run,
    or the one-site env's refusal."""
    for n in CRANE_COUNTS:
        try:
            MultiCraneEnv(scenario, n_cranes=n)
        except ValueError as refused:
            with pytest.raises(ValueError, match="cannot|at most|describes") as raised:
                MotionVectorEnv(1, scenario, n_cranes=n)
            assert str(raised.value) == str(refused)
            continue
        play_both(scenario, n, [n, n + 7], steps=12, greedy=0.5)


@settings(max_examples=12, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(
    case=st.sampled_from(DRAWN),
    seed=st.integers(0, 2**32 - 1),
    greedy=st.sampled_from([0.0, 0.7, 0.95]),
    reward=st.sampled_from(["paper", "makespan"]),
    reward_mode=st.sampled_from(["team", "split"]),
    max_steps=st.sampled_from([None, 25, 60]),
)
def test_random_runs_equal(case, seed, greedy, reward, reward_mode, max_steps):
    scenario, n = case
    play_both(scenario, n, [seed, seed + 1], steps=40, greedy=greedy, reward=reward,
              reward_mode=reward_mode, max_steps=max_steps)  # fmt: skip


def test_small_site_finishes_episodes():
    """Episodes end by completion and by truncation, and the autoresets stay equal."""
    assert play_both("e1s1", 1, [3, 4], steps=150, greedy=0.97, wild=0.0) >= 2
    assert play_both("e2s2", 2, [5, 6], steps=120, max_steps=30, greedy=0.9) >= 6


@pytest.mark.fuzz
@settings(max_examples=200, deadline=None)
@given(
    case=st.sampled_from(DRAWN),
    seed=st.integers(0, 2**32 - 1),
    greedy=st.floats(0.0, 1.0),
    wild=st.sampled_from([0.0, 0.05, 0.3]),
    reward_mode=st.sampled_from(["team", "split"]),
    max_cycles=st.sampled_from([None, 40, 300]),
)
def test_long_random_runs_equal(case, seed, greedy, wild, reward_mode, max_cycles):
    scenario, n = case
    play_both(scenario, n, [seed, seed + 1, seed + 2], steps=400, greedy=greedy, wild=wild,
              reward_mode=reward_mode, max_cycles=max_cycles)  # fmt: skip
