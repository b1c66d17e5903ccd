"""The vector paper env equals the one-site env, copy by copy (issue 31: differential tests).

For all 16 paper configurations, with and without ``mask_blocked_moves``, hypothesis draws
seeds and the mix of actions (a greedy planner's moves, to finish components and episodes,
and uniform random moves), or the action sequences themselves: every step's observation,
mask, reward, termination, truncation, event counts, component index and ``is_success`` of
``PaperVectorEnv`` equal those of ``PaperAssemblyEnv`` copies reset with the same
generators, autoresets included (the one-site env is reset with ``reset()`` after each
episode, going on with its generator).
The starts alone are compared with ``multicrane.sim.start.draw_start`` over many draws, with
the generator's state after each. The large runs are behind ``-m fuzz``.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from multicrane.envs.paper_env import PAPER_CONFIGS, PaperAssemblyEnv
from multicrane.sim.start import draw_start
from multicrane.vector.paper_vector_env import PaperVectorEnv
from multicrane.vector.pcg64 import state_of
from policies.paper_greedy import PaperGreedyPolicy

COPIES = 3
STEPS = 160  # per configuration and mask option: about 15,000 steps of each env in all
RANDOM_STARTS = [c for c in PAPER_CONFIGS if c[-1] in "13"] + ["E1S2", "E1S4"]


def generators(seed: int, n: int) -> list[np.random.Generator]:
    """The generators ``reset(seed=seed)`` gives the copies."""
    return [np.random.Generator(np.random.PCG64(s)) for s in np.random.SeedSequence(seed).spawn(n)]


def references(config: str, mask: bool, seed: int | list[int]):
    """One-site envs reset as the vector env's copies are by ``reset(seed=seed)``, and the
    (observation, info) of each reset."""
    envs = [PaperAssemblyEnv(config, mask_blocked_moves=mask) for _ in range(COPIES)]
    if isinstance(seed, list):
        return envs, [env.reset(seed=s) for env, s in zip(envs, seed, strict=True)]
    for env, g in zip(envs, generators(seed, COPIES), strict=True):
        env.np_random = g
    return envs, [env.reset() for env in envs]


def play_both(
    config: str, mask: bool, seed, eps: float, steps: int, script: list[int] | None = None
) -> dict[str, int]:
    """Step both sides ``steps`` times with the same actions (``script``'s, shifted per copy,
    when given; else greedy moves, random ones with probability ``eps``); returns what
    happened."""
    vec = PaperVectorEnv(COPIES, config=config, mask_blocked_moves=mask)
    envs, starts = references(config, mask, seed)
    obs, infos = vec.reset(seed=seed)
    for b, (env, (ref_obs, info)) in enumerate(zip(envs, starts, strict=True)):
        assert obs.dtype == ref_obs.dtype
        assert np.array_equal(obs[b], ref_obs)
        assert np.array_equal(vec.action_masks()[b], env.action_masks())
        assert infos["component_index"][b] == info["component_index"]
    planners = [PaperGreedyPolicy(env) for env in envs]
    rng = np.random.default_rng(seed)
    seen = {"episodes": 0, "successes": 0, "arrivals": 0, "blocked": 0}
    for t in range(steps):
        if script is not None:
            actions = np.array([script[(t + 7 * b) % len(script)] for b in range(COPIES)])
        else:
            actions = np.array([
                int(rng.integers(6)) if rng.random() < eps else planners[b]()
                for b in range(COPIES)
            ])  # fmt: skip
        obs, rewards, terminated, truncated, infos = vec.step(actions)
        masks = vec.action_masks()
        for b, env in enumerate(envs):
            ref_obs, reward, term, trunc, info = env.step(int(actions[b]))
            assert rewards[b] == reward
            assert (terminated[b], truncated[b]) == (term, trunc)
            assert np.array_equal(infos["event_counts"][b], info["event_counts"])
            assert infos["_final_obs"][b] == infos["_is_success"][b] == (term or trunc)
            if term or trunc:
                assert infos["is_success"][b] == info["is_success"]
                assert np.array_equal(infos["final_obs"][b], ref_obs)
                ref_obs, info = env.reset()
                planners[b] = PaperGreedyPolicy(env)
                seen["episodes"] += 1
                seen["successes"] += term
            assert np.array_equal(obs[b], ref_obs), np.flatnonzero(obs[b] != ref_obs)
            assert np.array_equal(masks[b], env.action_masks())
            assert infos["component_index"][b] == info["component_index"]
        seen["arrivals"] += int(infos["event_counts"][:, 5].sum())
        seen["blocked"] += int(infos["event_counts"][:, 2].sum())
    return seen


@pytest.mark.parametrize("mask", [False, True], ids=["plain", "masked"])
@pytest.mark.parametrize("config", PAPER_CONFIGS)
@settings(max_examples=2, deadline=None, derandomize=True, database=None)
@given(seed=st.integers(0, 2**63 - 1), eps=st.sampled_from([0.05, 0.3, 1.0]))
def test_vector_env_equals_the_one_site_env(config, mask, seed, eps):
    seen = play_both(config, mask, seed, eps, STEPS)
    assert seen["blocked"] > 0 or eps < 1


@settings(max_examples=12, deadline=None, derandomize=True, database=None)
@given(
    config=st.sampled_from(PAPER_CONFIGS),
    mask=st.booleans(),
    seed=st.integers(0, 2**32 - 1),
    script=st.lists(st.integers(0, 5), min_size=1, max_size=60),
)
def test_drawn_action_sequences(config, mask, seed, script):
    """Hypothesis draws the actions themselves (a sequence, replayed cyclically)."""
    play_both(config, mask, seed, 0.0, 120, script)


@pytest.mark.parametrize("config", ["E1S1", "E2S3", "E3S4", "E4S1"])
def test_seeds_per_copy_and_autoresets(config):
    """``reset(seed=[...])`` seeds each copy as the one-site env's ``reset(seed=s)``; with
    mostly greedy moves episodes end (successes included) and the copies reset."""
    steps = 400 if config.startswith(("E3", "E4")) else 200
    seen = play_both(config, True, [11, 12, 13], 0.05, steps)
    assert seen["episodes"] >= COPIES and seen["successes"] >= 1 and seen["arrivals"] > 0


@pytest.mark.parametrize("config", RANDOM_STARTS)
def test_starts_are_drawn_as_draw_start_draws_them(config):
    """Many starts in a row from each copy's generator: the cells of every component and the
    generator's state after the draw equal ``draw_start`` with a numpy generator."""
    draws = 40
    vec = PaperVectorEnv(25, config=config)
    compare_starts(vec, seed=7, draws=draws)


def compare_starts(vec: PaperVectorEnv, seed: int, draws: int) -> None:
    site = PaperAssemblyEnv(vec.config).sim.site
    gens = generators(seed, vec.num_envs)
    vec.reset(seed=seed)
    for _ in range(draws):
        for b, g in enumerate(gens):
            start = draw_start(vec.scenario, g)
            for i, pose in enumerate(start.initial):
                t = start.prebuilt_target[i]
                cells = site.target_cells[t] if t >= 0 else site.lin_pose(pose)
                assert vec.state.cells[b, i, : len(cells)].tolist() == list(cells)
            assert np.array_equal(vec.state.rng[b], state_of(g))
        vec.reset()


@pytest.mark.fuzz
@pytest.mark.parametrize("config", PAPER_CONFIGS)
def test_large_differential_run(request, config):
    """``-m fuzz`` (about 8 s per configuration): 8 seeds x 600 steps x 3 copies per mask
    option, and 300 starts per copy of 25."""
    if "fuzz" not in (request.config.getoption("-m") or ""):
        pytest.skip("the large run: python -m pytest -m fuzz tests/vector")
    for seed in range(8):
        for mask in (False, True):
            play_both(config, mask, seed, (0.05, 0.3, 1.0)[seed % 3], 600)
    compare_starts(PaperVectorEnv(25, config=config), seed=3, draws=300)
