"""Potential-based shaping of the learner's reward in paper mode (``ShapedPaperEnv``)."""

from __future__ import annotations

import numpy as np
import pytest
from stable_baselines3.common.monitor import Monitor

from multicrane.bounds.paper_optimum import plan
from multicrane.envs.paper_env import PaperAssemblyEnv
from multicrane.training import ConfigError, TrainConfig
from multicrane.training.algorithms import algorithm, hyperparameters
from multicrane.training.shaping import ShapedPaperEnv, potential_from_scratch
from multicrane.training.trainer import make_vec_env, paper_env

W, GAMMA = 0.5, 0.9


def _shaped(config: str, w: float = W, gamma: float = GAMMA) -> ShapedPaperEnv:
    return ShapedPaperEnv(Monitor(PaperAssemblyEnv(config)), w, gamma)


def _optimal_actions(config: str, seed: int) -> tuple[int, ...]:
    env = PaperAssemblyEnv(config)
    env.reset(seed=seed)
    return plan(env=env).actions


def _episode_actions(config, seed, optimal: bool, n_random: int) -> list[int]:
    """The exact planner's actions, or ``n_random`` uniform random moves from ``seed``."""
    if optimal:
        return _optimal_actions(config, seed)
    return np.random.default_rng(seed).integers(0, 6, n_random).tolist()


@pytest.mark.parametrize("config", ["E1S1", "E2S2", "E3S1"])
def test_the_paper_env_and_its_returns_are_unchanged(config):
    """Same observations, paper reward, ends and Monitor return as the plain env."""
    rng = np.random.default_rng(7)
    actions = rng.integers(0, 6, 400).tolist()
    plain, shaped = PaperAssemblyEnv(config), _shaped(config)
    o1, _ = plain.reset(seed=3)
    o2, _ = shaped.reset(seed=3)
    assert np.array_equal(o1, o2)
    total, differs = 0.0, False
    for a in actions:
        o1, r1, t1, u1, _ = plain.step(a)
        o2, r2, t2, u2, info = shaped.step(a)
        assert np.array_equal(o1, o2) and (t1, u1) == (t2, u2)
        assert info["paper_reward"] == r1
        total += r1
        differs |= r2 != r1
        if t1 or u1:
            break
    assert differs, "the learner's reward is shaped"
    assert info["episode"]["r"] == pytest.approx(total), "Monitor records the paper's return"


@pytest.mark.parametrize("action", range(6))
def test_a_step_adds_w_times_gamma_phi_next_minus_phi(action):
    """Table over the six moves from one hand-reached state (E2S2, a few moves in)."""
    env = _shaped("E2S2")
    env.reset(seed=0)
    for a in (4, 0, 1):  # lift and move the first component
        env.step(a)
    sim = env.unwrapped.sim
    phi = potential_from_scratch(sim)
    assert env.phi == phi
    _, r, terminated, _, info = env.step(action)
    phi_next = 0.0 if terminated else potential_from_scratch(sim)
    assert r == pytest.approx(info["paper_reward"] + W * (GAMMA * phi_next - phi))


def test_the_potential_is_minus_the_distances_and_zero_at_the_end():
    env = _shaped("E1S1")
    env.reset(seed=0)
    assert env.phi == potential_from_scratch(env.unwrapped.sim) < 0
    for a in _optimal_actions("E1S1", 0):
        _, _, terminated, _, _ = env.step(a)
    assert terminated and env.phi == 0.0 == potential_from_scratch(env.unwrapped.sim)


@pytest.mark.parametrize(
    "config,seed,optimal", [("E1S1", 0, True), ("E2S2", 1, True), ("E2S2", 2, False)]
)
def test_the_shaping_terms_telescope_over_an_episode(config, seed, optimal):
    """sum_t gamma^t F_t = w (gamma^T phi(s_T) - phi(s_0)), phi(s_T) = 0 when terminated."""
    env = _shaped(config)
    env.reset(seed=seed)
    phi0 = env.phi
    actions = _episode_actions(config, seed, optimal, 1000)
    discounted_f, t = 0.0, 0
    for a in actions:
        _, r, terminated, truncated, info = env.step(a)
        discounted_f += GAMMA**t * (r - info["paper_reward"])
        t += 1
        if terminated or truncated:
            break
    assert terminated == optimal and (terminated or truncated)
    phi_end = 0.0 if terminated else potential_from_scratch(env.unwrapped.sim)
    assert discounted_f == pytest.approx(W * (GAMMA**t * phi_end - phi0))


def test_training_copies_are_shaped_and_evaluation_is_not():
    def venv(shaping):
        cfg = TrainConfig("E1S1", paper=True, algo="maskable_ppo", n_envs=2, shaping=shaping)
        algo = algorithm(cfg.algo, True)
        return cfg, algo, make_vec_env(cfg, algo, hyperparameters(algo, cfg.scenario, {}))

    cfg, algo, plain = venv(None)
    assert TrainConfig("E1S1", paper=True).shaping_weight == 0  # the paper's reward
    assert all(isinstance(e, Monitor) for e in plain.envs)
    cfg, algo, shaped = venv(0.5)
    assert all(isinstance(e, ShapedPaperEnv) for e in shaped.envs)
    assert {(e.weight, e.gamma) for e in shaped.envs} == {(0.5, 0.9)}  # PPO's gamma
    shaped.seed(0)
    shaped.reset()
    assert shaped.action_masks().shape == (2, 6)  # reaches the env through the wrappers
    assert isinstance(paper_env(cfg, algo), PaperAssemblyEnv)  # what evaluation builds


def test_bad_weights_are_refused():
    with pytest.raises(ConfigError, match="shaping=-1"):
        TrainConfig("E1S1", paper=True, shaping=-1)
    with pytest.raises(ValueError, match="weight"):
        ShapedPaperEnv(PaperAssemblyEnv("E1S1"), -0.1, 0.9)
    with pytest.raises(ValueError, match="gamma"):
        ShapedPaperEnv(PaperAssemblyEnv("E1S1"), 1.0, 1.5)


def test_a_profile_passes_its_shaping_weight_to_its_runs():
    from dataclasses import replace

    from multicrane.benchmark.profiles import PROFILES, make_sweep

    profile = replace(PROFILES["smoke"], algos=("dqn", "maskable_ppo"), shaping={"dqn": 2.0})
    runs = {r.algo: r.train for r in make_sweep(profile).runs() if r.config == "E1S1"}
    assert TrainConfig(**runs["dqn"]).shaping_weight == 2.0
    assert TrainConfig(**runs["maskable_ppo"]).shaping_weight == 0.0  # the paper's reward
    assert make_sweep(profile).to_dict()["shaping"] == {"dqn": 2.0}
    options = {"potential": "path", "shaping_gamma": 1.0}
    profile = replace(profile, options={"maskable_ppo": options})
    runs = {r.algo: r.train for r in make_sweep(profile).runs() if r.config == "E1S1"}
    cfg = TrainConfig(**runs["maskable_ppo"])
    assert (cfg.potential, cfg.shaping_gamma) == ("path", 1.0)
    assert TrainConfig(**runs["dqn"]).potential == "distance"
    assert make_sweep(profile, algos=["dqn"]).to_dict()["options"] == {}


def test_a_shaped_run_resumes_exactly(tmp_path):
    """The wrapper's phi and the potential's caches travel with the checkpointed copies."""
    import torch as th

    from multicrane.training import load_run, train

    cfg = TrainConfig("E1S1", paper=True, algo="maskable_ppo", total_steps=384, n_envs=2,
                      hyperparams={"n_steps": 64, "batch_size": 64, "n_epochs": 1},
                      eval_episodes=1, checkpoint_every=0, shaping=1.0)  # fmt: skip
    train(cfg, tmp_path / "whole", log=lambda *a: None)
    assert train(cfg, tmp_path / "cut", stop_at=150, log=lambda *a: None) is None
    train(cfg, tmp_path / "cut", log=lambda *a: None)
    a, b = (load_run(tmp_path / d)[0].policy.state_dict() for d in ("whole", "cut"))
    assert a.keys() == b.keys() and all(th.equal(a[k], b[k]) for k in a)


# -- the path potential (potential="path") ----------------------------------------------------


def _path_length(sim, comp: int) -> int:
    """Moves of a shortest path of ``comp`` from where it is to a goal pose of a free
    compatible target, every component not in transit fixed (a forward search over anchor
    positions, independent of the backward fields of PathPotential); Manhattan if none."""
    from collections import deque

    from multicrane.core.codes import Status
    from multicrane.sim.shortest_paths import current_cells, goal_positions
    from multicrane.sim.simulator import FREE, NOBODY

    st, site = sim.state, sim.site
    free_targets = [t for t in site.compatible[comp] if st.filled_by[t] == NOBODY]
    goals = set(goal_positions(sim, comp, free_targets))
    cells = current_cells(sim, comp)
    offsets = [c - cells[0] for c in cells]
    passable = {0, comp + 1} | {c + 1 for c in np.flatnonzero(st.status == Status.IN_TRANSIT)}
    passable = {FREE if v == 0 else v for v in passable}

    def fits(p: int) -> bool:
        return all(0 <= p + o < st.occ.size and int(st.occ[p + o]) in passable for o in offsets)

    start, seen, queue = cells[0], {cells[0]}, deque([(cells[0], 0)])
    while queue:
        p, d = queue.popleft()
        if p in goals:
            return d
        for delta in site.move_delta:
            q = p + delta
            if q not in seen and fits(q):
                seen.add(q)
                queue.append((q, d + 1))
    x, y, z = site.cell(start)
    return min((abs(gx - x) + abs(gy - y) + abs(gz - z)
                for gx, gy, gz in map(site.cell, goals)), default=0)  # fmt: skip


def _path_phi(sim, at_reset: dict[int, int]) -> float:
    """phi of the path potential from scratch: components in the yard count their path
    length at reset (``at_reset``), the one in transit its path length now."""
    from multicrane.core.codes import Status

    total = 0
    for comp in range(sim.site.n_components):
        status = sim.state.status[comp]
        if status in (Status.ASSEMBLED, Status.ARRIVED) or sim.state.prebuilt[comp]:
            continue
        total += at_reset[comp] if status == Status.INITIAL else _path_length(sim, comp)
    return -float(total)


@pytest.mark.parametrize(
    "config,seed,optimal", [("E1S1", 0, True), ("E2S2", 1, True), ("E2S2", 2, False),
                            ("E3S1", 0, False)]
)  # fmt: skip
def test_the_path_potential_equals_a_forward_search_and_telescopes(config, seed, optimal):
    """At every step of an optimal or random episode: phi equals the from-scratch search,
    the step adds w (gamma phi' - phi), and the discounted terms sum to w (gamma^T phi_T -
    phi_0)."""
    env = ShapedPaperEnv(Monitor(PaperAssemblyEnv(config)), W, GAMMA, potential="path")
    env.reset(seed=seed)
    sim = env.unwrapped.sim
    at_reset = {c: _path_length(sim, c) for c in range(sim.site.n_components)}
    phi0 = env.phi
    assert phi0 == _path_phi(sim, at_reset) < 0
    actions = _episode_actions(config, seed, optimal, 300)
    discounted_f, t = 0.0, 0
    for a in actions:
        phi = env.phi
        _, r, terminated, truncated, info = env.step(a)
        phi_next = 0.0 if terminated else _path_phi(sim, at_reset)
        assert env.phi == phi_next
        assert r - info["paper_reward"] == pytest.approx(W * (GAMMA * phi_next - phi))
        discounted_f += GAMMA**t * (r - info["paper_reward"])
        t += 1
        if terminated or truncated:
            break
    assert terminated == optimal
    assert discounted_f == pytest.approx(W * (GAMMA**t * env.phi - phi0))


def test_the_potential_and_its_discount_are_run_settings():
    """TrainConfig.potential / shaping_gamma reach the training copies; bad values named."""

    def copies(**kw):
        cfg = TrainConfig("E1S1", paper=True, algo="maskable_ppo", n_envs=2, shaping=1, **kw)
        algo = algorithm(cfg.algo, True)
        return make_vec_env(cfg, algo, hyperparameters(algo, cfg.scenario, {})).envs

    from multicrane.training.shaping import DistancePotential, PathPotential

    plain = copies()
    assert {type(e.potential) for e in plain} == {DistancePotential}
    assert {e.gamma for e in plain} == {0.9}  # the learner's: the policy-invariant form
    shaped = copies(potential="path", shaping_gamma=1.0)
    assert {type(e.potential) for e in shaped} == {PathPotential}
    assert {e.gamma for e in shaped} == {1.0}
    with pytest.raises(ConfigError, match="potential='manhattan'"):
        TrainConfig("E1S1", paper=True, potential="manhattan")
    with pytest.raises(ConfigError, match="potential='path': a paper-mode option"):
        TrainConfig("hall", paper=False, potential="path")
    with pytest.raises(ConfigError, match="shaping_gamma=1.5"):
        TrainConfig("E1S1", paper=True, shaping_gamma=1.5)
    with pytest.raises(ValueError, match="potential='x'"):
        ShapedPaperEnv(PaperAssemblyEnv("E1S1"), 1.0, 0.9, potential="x")
