"""The lean PPO's shaped reward (``lean_ppo_shaping``) against the SB3 path's ``ShapedPaperEnv``:
the same shaped rewards episode by episode, truncation and termination, resume, training."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import torch as th  # noqa: E402

from multicrane.bounds.paper_optimum import plan  # noqa: E402
from multicrane.envs.paper_env import PaperAssemblyEnv  # noqa: E402
from multicrane.sim.shortest_paths import distance_field, next_move  # noqa: E402
from multicrane.training import ConfigError, TrainConfig, train  # noqa: E402
from multicrane.training.lean_ppo_env import LeanVecEnv  # noqa: E402
from multicrane.training.lean_ppo_shaping import ShapedCopies, start_all  # noqa: E402
from multicrane.training.model_policy import load_run  # noqa: E402
from multicrane.training.shaping import ShapedPaperEnv  # noqa: E402
from multicrane.vector.paper_vector_env import PaperVectorEnv  # noqa: E402

SEEDS = [3, 11, 29]
RANDOM = [1.0, 0.25, 0.1]  # per copy: the odds of a random move (copy 0 runs out of steps)


def _towards_target(env: PaperAssemblyEnv, comp: int, odds: float, rng) -> int:
    """A move down the current component's shortest path (random with ``odds``, or when
    there is none): episodes that finish, others that run out of steps."""
    if comp >= 0 and rng.random() >= odds:
        sim = env.sim
        free = [t for t in sim.site.compatible[comp] if sim.state.filled_by[t] < 0]
        move = next_move(sim, comp, distance_field(sim, comp, free))
        if move is not None:
            return int(move)
    return int(rng.integers(6))


def _compare(config, kind, gamma, steps, weight=0.5):
    """Step ``len(SEEDS)`` vector copies and as many one-site shaped envs with the same
    actions; the shaped rewards and ends must agree exactly. Returns the ends seen."""
    singles = [ShapedPaperEnv(PaperAssemblyEnv(config), weight, gamma, kind) for _ in SEEDS]
    envs = PaperVectorEnv(len(SEEDS), config=config, obs_dtype=np.uint8)
    shaped = ShapedCopies(envs, weight, gamma, kind)
    envs.reset(seed=SEEDS)  # each copy the generator of its one-site env
    start_all(envs.site, envs.state, shaped.potentials, shaped.kind)
    infos = [s.reset(seed=seed)[1] for s, seed in zip(singles, SEEDS, strict=True)]
    comps = [info["component_index"] for info in infos]
    assert shaped.potentials.phi.tolist() == [s.phi for s in singles]
    rng = np.random.default_rng(0)
    ends = {"terminated": 0, "truncated": 0}
    for _ in range(steps):
        actions = np.array([_towards_target(s.unwrapped, c, odds, rng)
                            for s, c, odds in zip(singles, comps, RANDOM, strict=True)])
        rewards = shaped.step(actions).copy()
        for i, single in enumerate(singles):
            _, r, terminated, truncated, info = single.step(int(actions[i]))
            assert r == rewards[i], (i, r, rewards[i])
            assert (terminated, truncated) == (envs.buffers.terminated[i],
                                               envs.buffers.truncated[i])  # fmt: skip
            comps[i] = info["component_index"]
            if terminated or truncated:
                ends["terminated" if terminated else "truncated"] += 1
                comps[i] = single.reset()[1]["component_index"]
            assert shaped.potentials.phi[i] == single.phi
    return ends


@pytest.mark.parametrize("kind", ["distance", "path"])
@pytest.mark.parametrize("config", ["E1S1", "E2S4", "E3S3"])
def test_the_shaped_rewards_equal_the_sb3_paths(config, kind):
    """Episode after episode (autoresets included), both potentials, both discounts."""
    for gamma in (0.9, 1.0):
        ends = _compare(config, kind, gamma, 700 if config.startswith("E3") else 400)
        assert ends["terminated"] and ends["truncated"], ends


@pytest.mark.long
@pytest.mark.parametrize("kind", ["distance", "path"])
@pytest.mark.parametrize("config", [f"E{e}S{s}" for e in range(1, 5) for s in range(1, 5)])
def test_the_shaped_rewards_equal_the_sb3_paths_everywhere(config, kind):
    _compare(config, kind, 1.0, 600)


def test_truncation_pays_the_final_states_potential():
    """A tiny case: E1S1's column lifted and raised to the sky, then blocked until the step
    limit. phi stays put, so every shaped reward is the paper's, the truncating one too
    (with phi(s') = 0 it would be the paper's minus w phi)."""
    envs = PaperVectorEnv(1, config="E1S1", obs_dtype=np.uint8)
    shaped = ShapedCopies(envs, 2.0, 1.0, "distance")
    shaped.reset(0)
    for _ in range(5):  # lift, then up to z = 8
        shaped.step(np.array([4]))
    phi = shaped.potentials.phi[0]
    assert phi < 0
    for _ in range(94):
        assert shaped.step(np.array([4]))[0] == envs.buffers.rewards[0]
        assert not envs.buffers.truncated[0]
    reward = shaped.step(np.array([4]))[0]
    assert envs.buffers.truncated[0] and reward == envs.buffers.rewards[0]
    assert shaped.potentials.phi[0] < 0  # the new episode's potential


def test_termination_uses_phi_zero():
    envs = PaperVectorEnv(1, config="E2S2", obs_dtype=np.uint8)
    shaped = ShapedCopies(envs, 1.0, 1.0, "path")
    shaped.reset(0)
    for a in plan("E2S2", 0).actions:
        before = shaped.potentials.phi[0]
        reward = shaped.step(np.array([a]))[0]
    assert envs.buffers.terminated[0] and before < 0
    assert reward == envs.buffers.rewards[0] + 1.0 * (0.0 - before)


def test_checkpoints_keep_the_potentials_and_runs_repeat():
    """get_state/set_state resume the same shaped rewards; the same seed, the same run."""
    a = LeanVecEnv("E3S1", 4, True, (1.0, 1.0, "path"))
    b = LeanVecEnv("E3S1", 4, True, (1.0, 1.0, "path"))
    a.reset(seed=5)
    b.reset(seed=5)
    rng = np.random.default_rng(1)
    for _ in range(50):
        actions = rng.integers(6, size=4)
        assert np.array_equal(a.step(actions)[2], b.step(actions)[2])
    saved = a.get_state()
    steps = [rng.integers(6, size=4) for _ in range(400)]
    first = [a.step(x)[2].copy() for x in steps]
    c = LeanVecEnv("E3S1", 4, True, (1.0, 1.0, "path"))
    c.reset(seed=99)
    c.set_state(saved)
    assert all(np.array_equal(r, c.step(x)[2]) for r, x in zip(first, steps, strict=True))


def _run(**changes) -> TrainConfig:
    kw = dict(scenario="E1S1", paper=True, algo="lean_ppo", total_steps=512, n_envs=8,
              shaping=1.0, potential="path", shaping_gamma=1.0, eval_episodes=2,
              hyperparams={"n_steps": 16, "batch_size": 64, "n_epochs": 1},
              checkpoint_every=128)  # fmt: skip
    return TrainConfig(**{**kw, **changes})


def test_a_shaped_run_resumes_exactly(tmp_path):
    """A shaped lean PPO run cut at a checkpoint and resumed ends with the weights and the
    final returns (the paper's reward) of an uninterrupted one."""
    quiet = lambda *_: None  # noqa: E731
    whole = train(_run(), tmp_path / "whole", log=quiet)
    assert train(_run(), tmp_path / "cut", stop_at=200, log=quiet) is None
    resumed = train(_run(), tmp_path / "cut", log=quiet)
    a, _ = load_run(tmp_path / "whole")
    b, _ = load_run(tmp_path / "cut")
    state_a, state_b = a.policy.state_dict(), b.policy.state_dict()
    assert all(th.equal(state_a[k], state_b[k]) for k in state_a)
    returns = [e["return"] for e in whole["final_episodes"]]
    assert returns == [e["return"] for e in resumed["final_episodes"]]


def test_the_command_takes_shaping(tmp_path):
    from multicrane.cli import main

    out = tmp_path / "run"
    assert main(["train", "--paper", "E1S1", "--algo", "lean_ppo", "--steps", "128",
                 "--envs", "8", "--set", "n_steps=8", "--set", "batch_size=32",
                 "--shaping", "1", "--potential", "path", "--shaping-gamma", "1",
                 "--eval-episodes", "2", "--no-progress", "--out", str(out)]) == 0  # fmt: skip
    config = json.loads((out / "config.json").read_text())
    assert (config["shaping"], config["potential"], config["shaping_gamma"]) == (1.0, "path", 1.0)


def test_the_learner_gamma_is_the_default_shaping_discount():
    from multicrane.training.algorithms import algorithm
    from multicrane.training.run_envs import make_vec_env

    cfg = TrainConfig(scenario="E1S1", paper=True, algo="lean_ppo", shaping=1.0, n_envs=2)
    venv = make_vec_env(cfg, algorithm("lean_ppo", True), {"gamma": 0.9})
    assert venv.shaped.gamma == 0.9 and venv.shaped.weight == 1.0
    with pytest.raises(ConfigError):
        TrainConfig(scenario="E1S1", paper=True, algo="lean_ppo", potential="nope")
