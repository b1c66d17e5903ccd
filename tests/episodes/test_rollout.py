"""The one episode loop (``multicrane.episodes.rollout``) in both modes, and ``policies.make``'s
seeding rule: same seed, same episode; a policy's stream is ``default_rng([seed, 1])``."""

from __future__ import annotations

import numpy as np
import pytest

import multicrane
import multicrane.training
import policies
from multicrane.bounds.paper_optimum import plan
from multicrane.episodes.rollout import evaluate, run_episode, summarise
from multicrane.replay.record import record_episode

KEYS = {
    "scenario", "n_cranes", "seed", "success", "makespan", "steps", "return", "crane_steps",
    "idle_crane_steps", "utilisation", "blocked_moves", "failed_actions", "events",
    "plan_seconds", "plan_ms_per_step", "plan_ms_per_crane", "plan_ms_max",
}  # fmt: skip


def outcome(m: dict) -> tuple:
    """The deterministic part of an episode (everything but the timings)."""
    return tuple((k, str(v)) for k, v in sorted(m.items()) if not k.startswith("plan_"))


def test_multi_agent_episode_has_every_metric_and_records_its_actions():
    env = multicrane.parallel_env("e1s1", n_cranes=2)
    m = run_episode(env, policies.make("prioritized", env, 0), seed=0, record=True)
    assert set(m) >= KEYS and m["n_cranes"] == 2 and m["seed"] == 0
    assert m["success"] and m["makespan"] == m["steps"] == len(m["actions"])
    assert all(len(joint) == 2 for joint in m["actions"])
    assert m["crane_steps"] + m["idle_crane_steps"] == 2 * m["steps"]
    # Replay recording runs the same loop: the same actions and outcome.
    rec = record_episode(env, policies.make("prioritized", env, 0), 0, "prioritized")
    assert rec.actions == m["actions"]
    assert (rec.metrics["return"], rec.metrics["steps"]) == (m["return"], m["steps"])


def test_single_agent_episode_has_every_metric_and_the_optimal_return():
    env = multicrane.PaperAssemblyEnv("E1S1")
    m = run_episode(env, policies.make("optimal", env, 3), seed=3, record=True)
    assert set(m) >= KEYS and m["n_cranes"] == 1 and m["scenario"] == env.scenario.name
    best = plan("E1S1", seed=3)
    assert m["return"] == pytest.approx(best.episode_return, abs=1e-9)
    assert tuple(m["actions"]) == best.actions and m["success"] == best.success
    seen = []
    g = run_episode(env, policies.make("greedy", env, 3), 3, on_step=lambda *a: seen.append(a))
    assert len(seen) == g["steps"] and g["return"] <= m["return"] + 1e-9


@pytest.mark.parametrize("name", ["random", "greedy"])
def test_same_seed_same_episode_in_both_modes(name):
    for env in (multicrane.parallel_env("e2s1", n_cranes=2), multicrane.PaperAssemblyEnv("E2S1")):
        a = run_episode(env, policies.make(name, env, 4), seed=4, record=True)
        b = run_episode(env, policies.make(name, env, 4), seed=4, record=True)
        assert outcome(a) == outcome(b)


def test_different_seeds_give_random_different_episodes():
    env = multicrane.parallel_env("e1s1", n_cranes=2, max_steps=40)
    runs = [run_episode(env, policies.make("random", env, s), seed=s, record=True) for s in (0, 1)]
    assert runs[0]["actions"] != runs[1]["actions"]
    paper = multicrane.PaperAssemblyEnv("E1S1")
    moves = [run_episode(paper, policies.make("random", paper, s), s, record=True) for s in (0, 1)]
    assert moves[0]["actions"] != moves[1]["actions"]


def test_a_policy_draws_from_its_own_stream_not_the_environments():
    env = multicrane.parallel_env("e1s1", n_cranes=2)
    for name in ("random", "greedy"):
        p = policies.make(name, env, seed=7)
        own = np.random.default_rng([7, policies.registry.POLICY_STREAM])
        assert p.rng.bit_generator.state == own.bit_generator.state
        assert p.rng.bit_generator.state != np.random.default_rng(7).bit_generator.state


def test_names_and_mode_checks():
    assert set(policies.names(True)) | set(policies.names(False)) == set(policies.NAMES)
    paper = multicrane.PaperAssemblyEnv("E1S1")
    with pytest.raises(policies.PolicyError, match="prioritized"):
        policies.make("prioritized", paper)
    with pytest.raises(policies.PolicyError, match="optimal"):
        policies.factory("optimal", paper=False)
    with pytest.raises(policies.PolicyError, match="no such run directory"):
        policies.factory("no/such/run")


def test_a_trained_model_without_the_train_extra_names_the_extra(tmp_path, monkeypatch):
    def missing() -> None:
        raise ImportError("no stable_baselines3")

    monkeypatch.setattr(multicrane.training, "require_extra", missing)
    with pytest.raises(policies.PolicyError, match=r"'train' extra.*multicrane\[train\]"):
        policies.factory(str(tmp_path))


def test_evaluate_makes_a_fresh_policy_per_seed_and_summarises():
    env = multicrane.parallel_env("e1s1", n_cranes=2)
    made = []

    def make(env, seed):
        made.append(seed)
        return policies.make("prioritized", env, seed)

    episodes, summary = evaluate(env, make, [2, 5], progress=lambda seeds: iter(seeds))
    assert made == [2, 5] and [e["seed"] for e in episodes] == [2, 5]
    assert summary["episodes"] == 2 and summary["success_rate"] == 1.0
    assert summary["makespan_mean"] == pytest.approx(np.mean([e["makespan"] for e in episodes]))
    assert summarise(episodes[:1])["return_sem"] is None  # one episode: no standard error
