"""Task-level decisions (``decisions="task"``): conformance, masks, hold/retry/drop, clock,
rewards, records, the task observation, and the task planners against the motion planner."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import SCENARIOS, reach_skip, readable_env
from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test, seed_test
from test_invariants import Checker

import multicrane
import policies
from multicrane.core.codes import Kind, Status
from multicrane.core.schema import CraneSpec
from multicrane.envs.task_observation import COMPONENT_FEATURES, CRANE_FEATURES, TASK_FEATURES
from multicrane.episodes.rollout import run_episode
from multicrane.replay.record import EpisodeRecord, record_episode, resimulate
from multicrane.scenario.loader import load_scenario

API_NOTES = [
    "ignore:Observation is not a NumPy array",
    "ignore:Observation space for each agent probably should be",
]

# Motion-mode prioritized makespans (seed 0, 1-4 cranes) before the carrier was split out of
# policies/prioritized.py: the refactoring and task mode must keep them exactly.
PRIORITIZED_SEED0 = {
    "e1s1": (27, 27, 27, 27), "e1s2": (25, 25, 25, 25), "e1s3": (27, 27, 27, 27),
    "e1s4": (25, 25, 25, 25), "e2s1": (39, 26, 26, 26), "e2s2": (40, 30, 30, 30),
    "e2s3": (39, 26, 26, 26), "e2s4": (40, 30, 30, 30), "e3s1": (115, 58, 45, 37),
    "e3s2": (112, 63, 48, 39), "e3s3": (115, 58, 45, 35), "e3s4": (119, 65, 50, 38),
    "e4s1": (191, 102, 70, 57), "e4s2": (175, 97, 64, 53), "e4s3": (175, 90, 65, 53),
    "e4s4": (175, 97, 64, 53), "frame2-3c": (518, 268, 182, 146),
    "hall-4c": (505, 258, 179, 140),
    "towers-3c": (None, None, 141, None),  # three tower cranes: runs with exactly 3
    "precast-frame": (395, 212, 155, 127), "precast-house": (154, 85, 64, 63),
}  # fmt: skip


def task_env(name="e3s2", n=2, **options):
    return readable_env(name, n_cranes=n, decisions="task", **options)


def random_tasks(obs, rng):
    """A random allowed task for each idle crane (wait when none)."""
    out = {}
    for a, o in obs.items():
        legal = np.flatnonzero(o["action_mask"][1:])
        out[a] = 1 + int(rng.choice(legal)) if legal.size else 0
    return out


# -- PettingZoo conformance ----------------------------------------------------------------


@pytest.mark.filterwarnings(*API_NOTES)
@pytest.mark.parametrize("name", SCENARIOS)
def test_pettingzoo_api_and_seed_tests(name):
    n = 3 if name in ("frame2-3c", "hall-4c", "e4s1", "towers-3c") else 2
    parallel_api_test(task_env(name, n), num_cycles=40)
    api_test(multicrane.env(name, n_cranes=n, decisions="task"), num_cycles=20,
             verbose_progress=False)  # fmt: skip
    seed_test(lambda: multicrane.env(name, n_cranes=n, decisions="task"), num_cycles=20)
    parallel_seed_test(lambda: task_env(name, n), num_cycles=20)


def test_spaces_and_layout():
    env = task_env("e3s2", 2)
    obs, infos = env.reset(seed=0)
    book = env.mode.task_book()
    P = len(book.tasks)
    assert env.action_space("crane_0").n == 1 + P
    # component-major: each component's compatible targets, in order
    site = env.sim.site
    pairs = [(c, t) for c in range(site.n_components) for t in site.compatible[c]]
    assert book.tasks.pairs == pairs
    for a in env.possible_agents:
        o = obs[a]
        assert env.observation_space(a).contains(o)
        parts = env.observation_layout.split(o["observation"])
        C, N = site.n_components, 2
        assert parts["components"].shape == (C, len(COMPONENT_FEATURES) + N)
        assert parts["cranes"].shape == (N, len(CRANE_FEATURES))
        assert parts["tasks"].shape == (P, len(TASK_FEATURES))
        assert np.array_equal(parts["tasks"][:, -1], o["action_mask"][1:])
    mine = env.observation_layout.split(obs["crane_1"]["observation"])["cranes"]
    assert mine[:, 0].tolist() == [0.0, 1.0]  # the "self" column
    planes = task_env("e3s2", 2, task_site_planes=True)
    o2, _ = planes.reset(seed=0)
    X, Y, _ = planes.scenario.size
    split = planes.observation_layout.split(o2["crane_0"]["observation"])
    assert split["planes"].shape == (X, Y, 9)


def test_same_seed_same_episode():
    def run(seed):
        env = task_env("hall-4c", 3)
        rng = np.random.default_rng(5)
        obs, _ = env.reset(seed=seed)
        trail = []
        while env.agents:
            obs, r, *_ = env.step(random_tasks(obs, rng))
            trail.append((env.sim.state.step_count, r["crane_0"], env.sim.state.status.tobytes()))
        return trail, env.mode.trace

    assert run(3) == run(3)
    assert run(3)[0] != run(4)[0]  # a random-start scenario: another seed, another episode


# -- invariants: every physical step of random task play, checked in motion mode ---------------


@pytest.mark.parametrize("name", ["e2s2", "e3s3", "e4s1", "frame2-3c", "hall-4c", "towers-3c"])
def test_random_task_play_keeps_the_invariants(name):
    rng = np.random.default_rng(7)
    for n in (3,) if name == "towers-3c" else (2, 4):
        env = task_env(name, n)
        for seed in (0, 1):
            obs, _ = env.reset(seed=seed)
            assembled = 0
            while env.agents:
                obs, _, _, _, infos = env.step(random_tasks(obs, rng))
                assert infos["crane_0"]["elapsed"] >= 1
                assert env.sim.state.n_assembled >= assembled
                assembled = env.sim.state.n_assembled
            # replay the physical steps in motion mode under the invariant checker
            motion = readable_env(name, n_cranes=n)
            obs2, infos2 = motion.reset(seed=seed)
            checker = Checker(motion)
            checker.reset(obs2, infos2)
            for joint in env.mode.trace:
                actions = dict(zip(motion.possible_agents, joint, strict=True))
                out = motion.step(actions)
                checker.step(actions, *out)
                bad = [e for a in motion.possible_agents for e in out[4][a]["events"]
                       if e.type.name in ("BLOCKED", "ILLEGAL", "CLAIM_CONFLICT")]  # fmt: skip
                assert not bad, bad
            assert np.array_equal(motion.sim.state.status, env.sim.state.status)
            assert motion.sim.state.step_count == env.sim.state.step_count


# -- masks on hand-built states -------------------------------------------------------------


def _beam_with_unready_target(sim):
    for c in range(sim.site.n_components):
        if (
            sim.site.kind[c] == int(Kind.BEAM)
            and sim.state.status[c] == int(Status.INITIAL)
            and not any(sim.target_ready[t] for t in sim.site.compatible[c])
        ):
            return c
    return None


def test_masks_table():
    env = task_env("e3s2", 2)
    obs, _ = env.reset(seed=0)
    book, sim = env.mode.task_book(), env.sim
    tasks = book.tasks
    m = book.masks()
    assert m[:, 0].all()
    # an unready beam (its supports are not built) is masked for everyone
    beam = _beam_with_unready_target(sim)
    assert beam is not None
    assert not m[:, 1:][:, tasks.comp == beam].any()
    # crane 0 takes task p: it is busy (only 0); crane 1 loses p's component and target
    p = int(np.flatnonzero(m[0, 1:])[0])
    c, t = tasks.pairs[p]
    book.task[0] = p
    m = book.masks()
    assert m[0].tolist() == [1] + [0] * len(tasks)
    assert not m[1, 1:][tasks.comp == c].any()
    assert not m[1, 1:][tasks.target == t].any()
    others = (tasks.comp != c) & (tasks.target != t)
    assert m[1, 1:][others].any()
    # a claimed component is masked (once claimed it is no longer claimable)
    book.task[0] = -1
    env.step({"crane_0": 1 + p, "crane_1": 0})
    m = book.masks()
    assert not m[:, 1:][:, tasks.comp == c].any()


def test_reach_masks_and_carrier():
    s = load_scenario("e3s2")
    X, Y, _ = s.size
    far = dataclasses.replace(
        s, crane_specs=(CraneSpec((X - 1, Y - 1), 1.0), CraneSpec((0, 0), float(X + Y)))
    )
    env = readable_env(far, n_cranes=2, decisions="task")
    env.reset(seed=0)
    book = env.mode.task_book()
    m = book.masks()
    assert not m[0, 1:].any()  # crane 0 reaches neither the yard nor the building
    assert m[1, 1:].any()
    p = int(np.flatnonzero(m[1, 1:])[0])
    c, t = book.tasks.pairs[p]
    assert not book.carrier.try_start(0, c, t)
    assert env.task_feasible(1, p)
    # the tower crane finishes the building alone
    planner = policies.make("prioritized", env, seed=0)
    m = run_episode(env, planner, seed=0)
    assert m["success"]
    assert all(d[0] == 0 for d in env.mode.decisions)  # crane 0 never takes a task


# -- hold, retry, drop ------------------------------------------------------------------------


@pytest.mark.parametrize(("fail_for", "expect"), [(2, "TASK_STARTED"), (99, "TASK_DROPPED")])
def test_hold_retry_and_drop(monkeypatch, fail_for, expect):
    env = task_env("e2s2", 1, task_patience=3)
    obs, _ = env.reset(seed=0)
    book = env.mode.task_book()
    real = book.carrier.try_start
    calls = []

    def flaky(crane, comp, target):
        calls.append(env.sim.state.step_count)
        return False if len(calls) <= fail_for else real(crane, comp, target)

    monkeypatch.setattr(book.carrier, "try_start", flaky)
    p = int(np.flatnonzero(obs["crane_0"]["action_mask"][1:])[0])
    _, _, _, _, infos = env.step({"crane_0": 1 + p})
    names = [e[0] for e in infos["crane_0"]["task_events"]]
    assert names[0] == "TASK_HELD"
    assert expect in names
    if expect == "TASK_DROPPED":
        assert not book.busy(0)
        assert env.sim.state.step_count == 3  # chosen at 0, dropped after step 3 (patience 3)
        assert calls == [0, 1, 2]  # tried when chosen, then before steps 2 and 3
        assert all(s == int(Status.INITIAL) or env.sim.state.prebuilt[i]
                   for i, s in enumerate(env.sim.state.status))  # fmt: skip
    else:
        assert calls[:3] == [0, 1, 2]  # chosen at 0 (fails), retried before steps 2 and 3


def test_refused_when_an_earlier_crane_takes_it():
    env = task_env("e3s2", 2)
    obs, _ = env.reset(seed=0)
    p = int(np.flatnonzero(obs["crane_0"]["action_mask"][1:])[0])
    _, _, _, _, infos = env.step({"crane_0": 1 + p, "crane_1": 1 + p})
    assert ("TASK_REFUSED", 1, p) in infos["crane_1"]["task_events"]
    assert env.mode.task_book().task[1] == -1


def test_busy_crane_may_only_continue_strict():
    env = task_env("e3s2", 2, strict=True)
    obs, _ = env.reset(seed=0)
    p = int(np.flatnonzero(obs["crane_0"]["action_mask"][1:])[0])
    obs, *_ = env.step({"crane_0": 1 + p, "crane_1": 0})
    assert obs["crane_0"]["action_mask"].tolist() == [1] + [0] * (env.n_actions - 1)
    q = 1 + int(np.flatnonzero(obs["crane_1"]["action_mask"][1:])[0])
    with pytest.raises(ValueError, match="crane_0 sent illegal action"):
        env.step({"crane_0": q, "crane_1": 0})


# -- clock, rewards, records ------------------------------------------------------------------


@pytest.mark.parametrize("decisions", ["motion", "task"])
def test_makespan_reward_sums_to_completion_minus_makespan(decisions):
    env = readable_env("e3s2", n_cranes=2, decisions=decisions, reward="makespan")
    m = run_episode(env, policies.make("prioritized", env, seed=0), seed=0)
    assert m["success"]
    completion = env.scenario.reward.completion
    assert m["return"] == pytest.approx(completion - m["makespan"])
    assert m["makespan"] == env.sim.state.step_count == m["steps"]


def test_paper_reward_sums_the_motion_rewards():
    motion = readable_env("e4s2", n_cranes=3)
    task = readable_env("e4s2", n_cranes=3, decisions="task")
    a = run_episode(motion, policies.make("prioritized", motion, seed=1), seed=1)
    b = run_episode(task, policies.make("prioritized", task, seed=1), seed=1)
    assert b["return"] == pytest.approx(a["return"])
    assert (b["makespan"], b["steps"]) == (a["makespan"], a["steps"])
    assert b["decision_rounds"] < b["steps"]
    assert b["crane_steps"] == a["crane_steps"]


@pytest.mark.parametrize("policy", ["prioritized", "greedy", "random"])
def test_record_and_resimulate_task_mode(policy, tmp_path):
    env = task_env("e4s3", 3)
    rec = record_episode(env, policies.make(policy, env, seed=2), seed=2, policy_name=policy)
    assert rec.decisions and len(rec.decisions) < rec.steps
    path = rec.save(tmp_path / "ep.json.gz")
    again = EpisodeRecord.load(path)
    replay, rewards, final = resimulate(again)
    assert final["step"] == env.sim.state.step_count == rec.steps
    assert np.array_equal(replay.sim.state.status, env.sim.state.status)
    assert sum(rewards) == pytest.approx(rec.metrics["return"])


# -- planners -----------------------------------------------------------------------------------


@pytest.mark.parametrize("name", SCENARIOS)
def test_task_prioritized_gives_the_motion_makespans(name):
    for n in (1, 2, 3, 4):
        if PRIORITIZED_SEED0[name][n - 1] is None:
            assert reach_skip(name, n), (name, n)  # too few (or too many) tower cranes
            continue
        spans = []
        for decisions in ("motion", "task"):
            env = readable_env(name, n_cranes=n, decisions=decisions)
            m = run_episode(env, policies.make("prioritized", env, seed=0), seed=0)
            spans.append(m["makespan"])
        assert spans == [PRIORITIZED_SEED0[name][n - 1]] * 2, (name, n, spans)


def test_registry_gives_task_planners():
    from policies.task_planners import TaskGreedy, TaskPrioritized, TaskRandom

    env = task_env()
    assert type(policies.make("prioritized", env, seed=0)) is TaskPrioritized
    assert type(policies.make("greedy", env, seed=0)) is TaskGreedy
    assert type(policies.make("random", env, seed=0)) is TaskRandom
    for name in ("greedy", "random"):
        m = run_episode(env, policies.make(name, env, seed=0), seed=0)
        assert m["success"], name


def test_bad_options():
    with pytest.raises(ValueError, match="decisions"):
        readable_env("e2s2", decisions="moves")
    with pytest.raises(ValueError, match="reward"):
        readable_env("e2s2", reward="fast")
    with pytest.raises(ValueError, match="auto"):
        readable_env("e2s2", decisions="task", auto=True)
    with pytest.raises(ValueError, match="task_patience"):
        readable_env("e2s2", decisions="task", task_patience=0)


def test_maskable_ppo_trains_in_task_mode(tmp_path):
    pytest.importorskip("sb3_contrib")
    from multicrane.training import TrainConfig, train

    cfg = TrainConfig(
        scenario="e3s2", paper=False, algo="maskable_ppo", n_cranes=2, n_envs=2,
        total_steps=2048, decisions="task", eval_episodes=2, checkpoint_every=0,
        hyperparams={"n_steps": 128, "batch_size": 64, "n_epochs": 2},
    )  # fmt: skip
    result = train(cfg, tmp_path / "run", log=lambda *a, **k: None)
    assert result is not None and result["steps"] >= 2048
    assert result["final"]["episodes"] == 2


@pytest.mark.parametrize("how", ["pickle", "deepcopy"])
def test_clone_mid_episode_continues_identically(how):
    import copy
    import pickle

    env = task_env("hall-4c", 3)
    obs, _ = env.reset(seed=5)
    rng = np.random.default_rng(5)
    for _ in range(4):
        obs, *_ = env.step(random_tasks(obs, rng))
    clone = pickle.loads(pickle.dumps(env)) if how == "pickle" else copy.deepcopy(env)
    obs_b = obs
    r1, r2 = np.random.default_rng(6), np.random.default_rng(6)
    while env.agents:
        obs, *_ = env.step(random_tasks(obs, r1))
        obs_b, *_ = clone.step(random_tasks(obs_b, r2))
        for a in obs:
            assert np.array_equal(obs[a]["observation"], obs_b[a]["observation"])
            assert np.array_equal(obs[a]["action_mask"], obs_b[a]["action_mask"])
    assert not clone.agents
    assert clone.mode.trace == env.mode.trace


def test_bench_task_mode(capsys):
    from multicrane.cli import main

    assert main(["bench", "--decisions", "task", "--scenario", "e3s2", "--cranes", "2",
                 "--steps", "10"]) == 0  # fmt: skip
    out = capsys.readouterr().out
    assert "rounds/s" in out and "p95 ms" in out
    assert "prioritized" in out and "random" in out


def test_a_probed_task_wins_over_a_plain_choice_of_the_same_component():
    env = task_env("e3s2", 2)
    obs, _ = env.reset(seed=0)
    p = int(np.flatnonzero(obs["crane_1"]["action_mask"][1:])[0])
    assert env.task_feasible(1, p)
    _, _, _, _, infos = env.step({"crane_0": 1 + p, "crane_1": 1 + p})
    assert ("TASK_REFUSED", 0, p) in infos["crane_0"]["task_events"]
    book = env.mode.task_book()
    assert book.task[0] == -1 or book.tasks.comp[book.task[0]] != book.tasks.comp[p]
