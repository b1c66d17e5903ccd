"""Conformance of ``MultiCraneEnv`` with the PettingZoo API and with its own spec card.

Every shipped scenario is run with one crane and with three: PettingZoo's own API checks on the
parallel and the AEC form, observations inside their declared spaces, same-seed determinism,
the registry, ANSI rendering, strict/non-strict handling of bad actions, and cloning by pickle.
"""

from __future__ import annotations

import copy
import pickle
import re
from pathlib import Path

import numpy as np
import pettingzoo
import pytest
from conftest import SCENARIOS, random_masked_actions, reach_skip, readable_env
from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test, seed_test

import multicrane
from multicrane.core.codes import ASSEMBLE, CLAIM_BASE, WAIT, EventType, Move, Status
from multicrane.scenario.loader import load_scenario

REPO = Path(__file__).resolve().parents[2]
SCENARIO_FILES = sorted((REPO / "scenarios").glob("*.toml"))
CRANE_COUNTS = (1, 3)
PARAMS = [
    pytest.param(
        name,
        n,
        id=f"{name}-{n}c",
        marks=[pytest.mark.skip(reason=why)] if (why := reach_skip(name, n)) else [],
    )
    for name in SCENARIOS
    for n in CRANE_COUNTS
]

# PettingZoo's generic advice for Dict observation spaces; not a conformance problem.
API_NOTES = [
    "ignore:Observation is not a NumPy array",
    "ignore:Observation space for each agent probably should be",
]


def _random_start_scenarios() -> list[str]:
    return [name for name in SCENARIOS if load_scenario(name).random_start is not None]


RANDOM_START = _random_start_scenarios()


# ---------------------------------------------------------------------------------------------
# Coverage guard


def test_every_scenario_file_is_covered():
    """Adding a scenario file without it being exercised here must fail."""
    stems = {p.stem for p in SCENARIO_FILES}
    assert len(SCENARIO_FILES) == 21, [p.name for p in SCENARIO_FILES]
    assert stems == set(multicrane.scenario_names())
    assert len(SCENARIOS) == len(SCENARIO_FILES)
    assert {p.values[0] for p in PARAMS} == stems
    assert len(PARAMS) == len(SCENARIO_FILES) * len(CRANE_COUNTS)
    # The scenarios with a [random_start] table: e?s1, e?s3 and hall-4c.
    expected = {f"e{e}s{s}" for e in range(1, 5) for s in (1, 3)} | {"hall-4c"}
    assert set(RANDOM_START) == expected


# ---------------------------------------------------------------------------------------------
# PettingZoo's own API tests


@pytest.mark.filterwarnings(*API_NOTES)
@pytest.mark.parametrize(("name", "n"), PARAMS)
def test_parallel_api(name, n):
    env = readable_env(name, n_cranes=n)
    # 120 cycles: the Env1/Env2 episodes (step limit 100) run to their end.
    parallel_api_test(env, num_cycles=120)


@pytest.mark.filterwarnings(*API_NOTES)
@pytest.mark.parametrize(("name", "n"), PARAMS)
def test_aec_api(name, n):
    api_test(multicrane.env(name, n_cranes=n), num_cycles=60, verbose_progress=False)


@pytest.mark.parametrize(("name", "n"), PARAMS)
def test_pettingzoo_seed_tests(name, n):
    """PettingZoo's determinism checks (the parallel one sends unmasked actions too)."""
    seed_test(lambda: multicrane.env(name, n_cranes=n), num_cycles=50)
    parallel_seed_test(lambda: readable_env(name, n_cranes=n), num_cycles=50)


# ---------------------------------------------------------------------------------------------
# Observations lie in the declared spaces (parallel_api_test does not check this)


def _check_observations(env, obs):
    assert set(obs) == set(env.possible_agents)
    for agent in env.possible_agents:
        space = env.observation_space(agent)
        o = obs[agent]
        assert set(o) == {"observation", "action_mask"}
        assert o["observation"].dtype == np.float32
        assert o["action_mask"].dtype == np.int8
        assert o["observation"].dtype == space["observation"].dtype
        assert o["action_mask"].dtype == space["action_mask"].dtype
        assert o["observation"].shape == space["observation"].shape
        assert o["action_mask"].shape == (env.action_space(agent).n,)
        assert space.contains(o), (
            f"{agent}: observation outside its space: "
            f"min {o['observation'].min()}, max {o['observation'].max()}, "
            f"mask values {np.unique(o['action_mask'])}"
        )


@pytest.mark.parametrize(("name", "n"), PARAMS)
def test_observations_in_space(name, n):
    env = readable_env(name, n_cranes=n)
    assert env.possible_agents == [f"crane_{i}" for i in range(n)]
    space = env.observation_space("crane_0")
    assert space["observation"].dtype == np.float32
    assert space["action_mask"].dtype == np.int8
    assert space["observation"].shape == (env.observation_layout.size,)
    rng = np.random.default_rng(7)
    obs, infos = env.reset(seed=7)
    _check_observations(env, obs)
    assert set(infos) == set(env.possible_agents)
    for _ in range(200):
        obs, rewards, terminations, truncations, infos = env.step(random_masked_actions(obs, rng))
        _check_observations(env, obs)
        for agent in env.possible_agents:
            assert np.array_equal(infos[agent]["action_mask"], obs[agent]["action_mask"])
        if not env.agents:
            obs, infos = env.reset()
            _check_observations(env, obs)
    parts = env.observation_layout.split(obs["crane_0"]["observation"])
    X, Y, _ = env.scenario.size
    assert parts["planes"].shape == (X, Y, 9)
    assert parts["components"].shape == (env.scenario.n_components, 14)
    assert parts["crane"].shape == (9,)


# ---------------------------------------------------------------------------------------------
# Determinism


def _assert_same_step(step_a, step_b, where):
    obs_a, rew_a, term_a, trunc_a, info_a = step_a
    obs_b, rew_b, term_b, trunc_b, info_b = step_b
    assert obs_a.keys() == obs_b.keys(), where
    for agent in obs_a:
        for key in ("observation", "action_mask"):
            assert np.array_equal(obs_a[agent][key], obs_b[agent][key]), f"{where}: {agent} {key}"
    assert rew_a == rew_b, where
    assert term_a == term_b, where
    assert trunc_a == trunc_b, where
    assert info_a.keys() == info_b.keys(), where
    for agent in info_a:
        assert info_a[agent]["events"] == info_b[agent]["events"], f"{where}: {agent} events"
        assert info_a[agent]["reward_term"] == info_b[agent]["reward_term"], where
        assert np.array_equal(info_a[agent]["action_mask"], info_b[agent]["action_mask"]), where


@pytest.mark.parametrize(("name", "n"), PARAMS)
def test_same_seed_same_trajectory(name, n):
    env_a = readable_env(name, n_cranes=n)
    env_b = readable_env(name, n_cranes=n)
    obs_a, info_a = env_a.reset(seed=1234)
    obs_b, info_b = env_b.reset(seed=1234)
    _assert_same_step((obs_a, {}, {}, {}, info_a), (obs_b, {}, {}, {}, info_b), "reset")
    rng = np.random.default_rng(99)
    episodes = 0
    for t in range(500):
        actions = random_masked_actions(obs_a, rng)
        step_a = env_a.step(actions)
        step_b = env_b.step(dict(actions))
        _assert_same_step(step_a, step_b, f"step {t}")
        assert np.array_equal(env_a.state(), env_b.state()), f"step {t}"
        obs_a, obs_b = step_a[0], step_b[0]
        if not env_a.agents:
            assert not env_b.agents
            episodes += 1
            obs_a, info_a = env_a.reset()  # no seed: both continue their own generators
            obs_b, info_b = env_b.reset()
            _assert_same_step((obs_a, {}, {}, {}, info_a), (obs_b, {}, {}, {}, info_b), "reset")
    if env_a.step_limit <= 100:
        assert episodes >= 4  # the continued generators were exercised


@pytest.mark.parametrize("name", RANDOM_START)
def test_different_seed_different_start(name):
    """On a random-start scenario some seed gives another initial layout than seed 0."""
    env = readable_env(name)
    first, _ = env.reset(seed=0)
    first_state = env.state()
    differs = False
    for seed in range(1, 6):
        obs, _ = env.reset(seed=seed)
        if not np.array_equal(
            obs["crane_0"]["observation"], first["crane_0"]["observation"]
        ) and not np.array_equal(env.state(), first_state):
            differs = True
            break
    assert differs, f"{name}: seeds 0..5 all give the same initial layout"


@pytest.mark.parametrize("name", [s for s in SCENARIOS if s not in RANDOM_START])
def test_fixed_start_scenarios_ignore_the_seed_for_the_yard(name):
    """Without [random_start] the yard poses are the file's: the seed does not move them."""
    env = readable_env(name)
    env.reset(seed=0)
    sim = env.sim
    initial = {
        c: list(sim.state.cells[c])
        for c in range(sim.site.n_components)
        if not sim.state.prebuilt[c]
    }
    for seed in range(1, 4):
        env.reset(seed=seed)
        for c, cells in initial.items():
            if not env.sim.state.prebuilt[c]:
                assert env.sim.state.cells[c] == cells, (name, seed, c)


# ---------------------------------------------------------------------------------------------
# Registry


def test_every_scenario_is_registered():
    for name in SCENARIOS:
        assert f"multicrane/{name}-v0" in pettingzoo.parallel_registry
        assert f"multicrane/{name}-v0" in pettingzoo.aec_registry


def test_make_parallel_from_registry():
    env = pettingzoo.make("parallel", "multicrane/e2s2-v0")
    assert isinstance(env, pettingzoo.ParallelEnv)
    assert env.unwrapped.scenario.name == "e2s2"
    rng = np.random.default_rng(0)
    obs, _ = env.reset(seed=0)
    for _ in range(20):
        obs, rewards, *_ = env.step(random_masked_actions(obs, rng))
        assert set(rewards) == set(env.possible_agents)
    env.close()


def test_make_aec_from_registry():
    env = pettingzoo.make("aec", "multicrane/e2s2-v0", n_cranes=2)
    assert isinstance(env, pettingzoo.AECEnv)
    assert env.unwrapped.scenario.name == "e2s2"
    assert env.possible_agents == ["crane_0", "crane_1"]
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    steps = 0
    for _agent in env.agent_iter(max_iter=40):
        obs, reward, terminated, truncated, info = env.last()
        if terminated or truncated:
            action = None
        else:
            legal = np.flatnonzero(obs["action_mask"])
            action = int(legal[rng.integers(legal.size)])
        env.step(action)
        steps += 1
    assert steps == 40
    env.close()


# ---------------------------------------------------------------------------------------------
# Rendering


def _expected_layers(sim) -> list[int]:
    """The layers render_ansi must show: those with anything but empty cells."""
    X, Y, H = sim.scenario.size
    grid = sim.state.occ.reshape(sim.site.shape)[1 : X + 1, 1 : Y + 1, :]
    target_at = sim.site.target_at.reshape(sim.site.shape)[1 : X + 1, 1 : Y + 1, :]
    free_target = np.isin(target_at, np.flatnonzero(sim.state.filled_by < 0))
    busy = (grid != 0) | free_target
    layers = [z for z in range(H, 0, -1) if busy[:, :, z].any()]
    if sim.scenario.foundations and 1 not in layers:
        layers.append(1)
    return layers


@pytest.mark.parametrize("name", SCENARIOS)
def test_render_ansi(name):
    env = readable_env(name, render_mode="ansi")
    obs, _ = env.reset(seed=0)
    rng = np.random.default_rng(0)
    for steps in (0, 5):
        for _ in range(steps):
            obs, *_ = env.step(random_masked_actions(obs, rng))
        text = env.render()
        assert isinstance(text, str)
        lines = text.splitlines()
        assert lines[0].startswith(f"step {steps}:"), lines[0]
        sim = env.sim
        layers = _expected_layers(sim)
        assert 1 in layers
        markers = [int(line[4:]) for line in lines if re.fullmatch(r"z = \d+", line)]
        assert markers == layers, (markers, layers)
        X, Y, _ = sim.scenario.size
        rows = [line for line in lines[2:] if not line.startswith("z = ")]
        assert len(rows) == Y * len(layers)
        assert all(len(row) == X for row in rows)
        # Every component cell is drawn exactly once, as its state letter.
        drawn = sum(row.lower().count(ch) for row in rows for ch in "itab")
        assert drawn == sum(len(cells) for cells in sim.state.cells)


def test_render_none_and_bad_mode():
    env = readable_env("e2s2")
    env.reset(seed=0)
    assert env.render() is None
    with pytest.raises(ValueError, match="render_mode"):
        readable_env("e2s2", render_mode="bogus")


# ---------------------------------------------------------------------------------------------
# Bad actions: strict and non-strict


def _illegal_action(env, agent: str) -> int:
    mask = env.action_masks()[agent]
    illegal = np.flatnonzero(mask == 0)
    assert illegal.size
    return int(illegal[0])


def _sim_state(env):
    sim = env.sim
    return (
        sim.state.occ.copy(),
        sim.state.status.copy(),
        sim.state.holder.copy(),
        list(sim.state.held),
        [list(c) for c in sim.state.cells],
    )


def _assert_state_equal(before, after):
    for a, b in zip(before, after, strict=True):
        if isinstance(a, np.ndarray):
            assert np.array_equal(a, b)
        else:
            assert a == b


def test_strict_rejects_masked_action():
    env = readable_env("e2s2", strict=True)
    env.reset(seed=0)
    action = _illegal_action(env, "crane_0")
    before = _sim_state(env)
    with pytest.raises(ValueError, match=rf"crane_0\b.*\b{action}\b"):
        env.step({"crane_0": action})
    _assert_state_equal(before, _sim_state(env))
    assert env.sim.state.step_count == 0
    # The environment is still usable with a legal action.
    env.step({"crane_0": WAIT})
    assert env.sim.state.step_count == 1


def test_strict_names_the_offending_agent_and_applies_nothing():
    env = readable_env("e2s2", n_cranes=3, strict=True)
    env.reset(seed=0)
    claims = np.flatnonzero(env.action_masks()["crane_0"][CLAIM_BASE:])
    assert claims.size
    action = ASSEMBLE  # nobody holds anything: assemble is masked out
    assert not env.action_masks()["crane_2"][action]
    before = _sim_state(env)
    joint = {"crane_0": CLAIM_BASE + int(claims[0]), "crane_1": WAIT, "crane_2": action}
    with pytest.raises(ValueError) as info:
        env.step(joint)
    message = str(info.value)
    assert "crane_2" in message and str(action) in message
    assert "crane_0" not in message
    _assert_state_equal(before, _sim_state(env))  # crane_0's legal claim was not applied


def test_non_strict_masked_action_is_a_recorded_no_op():
    env = readable_env("e2s2")
    env.reset(seed=0)
    for action in (Move.X_MINUS, Move.UP, ASSEMBLE):
        assert not env.action_masks()["crane_0"][action]
        before = _sim_state(env)
        step_before = env.sim.state.step_count
        _, _, _, _, infos = env.step({"crane_0": int(action)})
        _assert_state_equal(before, _sim_state(env))
        events = infos["crane_0"]["events"]
        assert len(events) == 1, events
        (event,) = events
        assert event.type in (EventType.ILLEGAL, EventType.BLOCKED)
        assert event.type == EventType.ILLEGAL  # nothing is held: nothing could be blocked
        assert event.crane == 0
        assert event.step == step_before + 1


def test_non_strict_blocked_move_is_a_recorded_no_op():
    env = readable_env("e2s2")
    env.reset(seed=0)
    claims = np.flatnonzero(env.action_masks()["crane_0"][CLAIM_BASE:])
    assert claims.size
    comp = int(claims[0])
    _, _, _, _, infos = env.step({"crane_0": CLAIM_BASE + comp})
    assert env.sim.state.held[0] == comp
    assert env.sim.state.status[comp] == Status.IN_TRANSIT
    # Lower the component until the ground (or something else) stops it.
    for _ in range(env.sim.scenario.size[2] + 1):
        if not env.action_masks()["crane_0"][Move.DOWN]:
            break
        env.step({"crane_0": int(Move.DOWN)})
    assert not env.action_masks()["crane_0"][Move.DOWN]
    assert env.sim.state.status[comp] == Status.IN_TRANSIT
    before = _sim_state(env)
    moves_before = int(env.sim.state.moves[comp])
    _, _, _, _, infos = env.step({"crane_0": int(Move.DOWN)})
    _assert_state_equal(before, _sim_state(env))
    assert int(env.sim.state.moves[comp]) == moves_before
    types = [e.type for e in infos["crane_0"]["events"]]
    assert types == [EventType.BLOCKED]
    # The same move in strict mode raises.
    strict = readable_env("e2s2", strict=True)
    strict.reset(seed=0)
    strict.step({"crane_0": CLAIM_BASE + comp})
    while strict.action_masks()["crane_0"][Move.DOWN]:
        strict.step({"crane_0": int(Move.DOWN)})
    with pytest.raises(ValueError, match=r"crane_0.*\b5\b"):
        strict.step({"crane_0": int(Move.DOWN)})


@pytest.mark.parametrize("strict", [False, True])
def test_out_of_range_action_raises(strict):
    env = readable_env("e2s2", n_cranes=2, strict=strict)
    env.reset(seed=0)
    n_actions = env.action_space("crane_0").n
    for bad in (n_actions, n_actions + 5, -1):
        with pytest.raises(ValueError, match="crane_1"):
            env.step({"crane_0": WAIT, "crane_1": bad})
    assert env.sim.state.step_count == 0


def test_missing_agent_raises_key_error():
    env = readable_env("e2s2", n_cranes=3)
    env.reset(seed=0)
    with pytest.raises(KeyError, match="crane_1"):
        env.step({"crane_0": WAIT, "crane_2": WAIT})
    with pytest.raises(KeyError):
        env.step({})
    assert env.sim.state.step_count == 0


def test_step_after_episode_end_raises():
    env = readable_env("e2s2", max_steps=3)
    env.reset(seed=0)
    for t in range(3):
        _, _, terminations, truncations, _ = env.step({"crane_0": WAIT})
        assert truncations["crane_0"] == (t == 2)
        assert not terminations["crane_0"]
    assert env.agents == []
    with pytest.raises(RuntimeError):
        env.step({"crane_0": WAIT})
    env.reset()
    env.step({"crane_0": WAIT})  # a reset makes it usable again


def test_step_before_reset_raises():
    env = readable_env("e2s2")
    with pytest.raises(RuntimeError):
        env.step({"crane_0": WAIT})


def test_bad_constructor_arguments():
    with pytest.raises(ValueError):
        readable_env("e2s2", max_steps=0)
    with pytest.raises(ValueError):
        readable_env("e2s2", n_cranes=0)


# ---------------------------------------------------------------------------------------------
# Pickling (SuperSuit clones environments by pickling them)


def _drive_pair(original, clone, obs, steps, seed):
    rng = np.random.default_rng(seed)
    for t in range(steps):
        actions = random_masked_actions(obs, rng)
        step_a = original.step(actions)
        step_b = clone.step(dict(actions))
        _assert_same_step(step_a, step_b, f"step {t} after cloning")
        assert np.array_equal(original.state(), clone.state())
        obs = step_a[0]
        if not original.agents:
            assert not clone.agents
            obs, info_a = original.reset()
            obs_b, info_b = clone.reset()
            _assert_same_step((obs, {}, {}, {}, info_a), (obs_b, {}, {}, {}, info_b), "reset")


CLONE_CASES = [
    pytest.param("e1s3", 1, id="e1s3-1c"),
    pytest.param("e3s2", 3, id="e3s2-3c"),
    pytest.param("hall-4c", None, id="hall-4c"),
]
CLONERS = {
    "pickle": lambda env: pickle.loads(pickle.dumps(env)),
    "deepcopy": copy.deepcopy,
}


@pytest.mark.parametrize("how", sorted(CLONERS))
@pytest.mark.parametrize(("name", "n"), CLONE_CASES)
def test_clone_after_reset_continues_identically(name, n, how):
    env = readable_env(name, n_cranes=n)
    obs, _ = env.reset(seed=5)
    rng = np.random.default_rng(5)
    for _ in range(10):
        obs, *_ = env.step(random_masked_actions(obs, rng))
    clone = CLONERS[how](env)
    assert clone is not env
    assert np.array_equal(clone.state(), env.state())
    _drive_pair(env, clone, obs, 100, seed=6)


@pytest.mark.parametrize("how", sorted(CLONERS))
def test_clone_before_reset(how):
    env = readable_env("e2s3", n_cranes=2)
    clone = CLONERS[how](env)
    obs, _ = env.reset(seed=11)
    obs_b, _ = clone.reset(seed=11)
    for agent in obs:
        assert np.array_equal(obs[agent]["observation"], obs_b[agent]["observation"])
    _drive_pair(env, clone, obs, 100, seed=12)
