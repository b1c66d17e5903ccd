"""The library-facing options: numeric infos, the flat observation, split rewards, the global
state, ``max_cycles``, ``np_random``, the human render mode and ``gymnasium.make`` masks."""

from __future__ import annotations

import builtins
import re

import gymnasium
import numpy as np
import pytest
from conftest import random_masked_actions

import multicrane
from multicrane.core.codes import EventType
from multicrane.envs.infos import TASK_EVENTS, event_counts
from multicrane.episodes.random_actions import random_legal_action


def _masked(env, rng):
    return {
        a: random_legal_action(m, rng) for a, m in env.action_masks().items()
    }


def _signature(info: dict) -> dict:
    out = {}
    for k, v in info.items():
        assert isinstance(v, int | float | np.ndarray), f"{k}: {type(v).__name__} is not numeric"
        if isinstance(v, np.ndarray):
            assert v.dtype.kind in "iuf", f"{k}: dtype {v.dtype}"
            out[k] = (v.dtype, v.shape)
        else:
            out[k] = type(v)
    return out


@pytest.mark.parametrize("decisions", ["motion", "task"])
def test_default_infos_are_numeric_with_fixed_keys_and_shapes(decisions):
    env = multicrane.parallel_env("frame2-3c", decisions=decisions)
    rng = np.random.default_rng(0)
    _, infos = env.reset(seed=0)
    expected = {"event_counts", "reward_term"}
    if decisions == "task":
        expected |= {"task_event_counts", "elapsed", "crane_steps"}
    first = _signature(infos["crane_0"])
    assert set(first) == expected
    seen = np.zeros(len(EventType), dtype=np.int64)
    while env.agents:
        _, _, _, _, infos = env.step(_masked(env, rng))
        for i, a in enumerate(env.possible_agents):
            assert _signature(infos[a]) == first
            assert np.array_equal(infos[a]["event_counts"], event_counts(env.last_events[i]))
            seen += infos[a]["event_counts"]
    assert seen.sum() > 0


def test_readable_infos_on_request_match_the_counts():
    env = multicrane.parallel_env("e3s2", decisions="task", info_events=True, info_mask=True)
    obs, infos = env.reset(seed=1)
    assert infos["crane_0"]["events"] == () and infos["crane_0"]["task_events"] == ()
    rng = np.random.default_rng(1)
    for _ in range(20):
        obs, _, _, _, infos = env.step(random_masked_actions(obs, rng))
        for a in env.possible_agents:
            info = infos[a]
            assert np.array_equal(info["event_counts"], event_counts(info["events"]))
            names = [TASK_EVENTS.index(e[0]) for e in info["task_events"]]
            assert np.array_equal(
                info["task_event_counts"], np.bincount(names, minlength=len(TASK_EVENTS))
            )
            assert np.array_equal(info["action_mask"], obs[a]["action_mask"])
        if not env.agents:
            break


def test_paper_env_infos_are_numeric_by_default():
    env = gymnasium.make("multicrane/PaperAssembly-E2S2-v0")
    _, info = env.reset(seed=0)
    assert set(info) == {"event_counts", "component_index"}
    _, _, _, _, info = env.step(0)
    assert info["component_index"] >= 0 and info["event_counts"][EventType.LIFTED] == 1
    readable = multicrane.PaperAssemblyEnv("E2S2", info_events=True, info_mask=True)
    readable.reset(seed=0)
    _, _, _, _, info = readable.step(0)
    assert isinstance(info["component"], str) and info["events"] == readable.last_events
    assert info["action_mask"].shape == (6,)


def test_gymnasium_make_exposes_action_masks_and_render_fps():
    env = gymnasium.make("multicrane/PaperAssembly-E1S1-v0", mask_blocked_moves=True)
    env.reset(seed=0)
    assert env.action_masks().shape == (6,)
    assert env.metadata["render_fps"] > 0
    assert multicrane.MultiCraneEnv.metadata["render_fps"] > 0


@pytest.mark.parametrize("decisions", ["motion", "task"])
def test_flat_observation_is_the_dict_vector_and_the_mask_comes_in_infos(decisions):
    flat = multicrane.parallel_env("e3s2", n_cranes=2, decisions=decisions, obs_format="flat")
    plain = multicrane.parallel_env("e3s2", n_cranes=2, decisions=decisions)
    assert isinstance(flat.observation_space("crane_0"), gymnasium.spaces.Box)
    fo, fi = flat.reset(seed=3)
    po, _ = plain.reset(seed=3)
    rng = np.random.default_rng(3)
    for _ in range(15):
        for a in flat.possible_agents:
            assert np.array_equal(fo[a], po[a]["observation"])
            assert flat.observation_space(a).contains(fo[a])
            assert np.array_equal(fi[a]["action_mask"], po[a]["action_mask"])
        actions = random_masked_actions(po, rng)
        fo, _, _, _, fi = flat.step(actions)
        po, *_ = plain.step(actions)
        if not flat.agents:
            break


@pytest.mark.parametrize("decisions", ["motion", "task"])
def test_split_rewards_add_up_to_the_team_reward(decisions):
    team = multicrane.parallel_env("frame2-3c", decisions=decisions)
    split = multicrane.parallel_env("frame2-3c", decisions=decisions, reward_mode="split")
    obs, _ = team.reset(seed=5)
    split.reset(seed=5)
    rng = np.random.default_rng(5)
    while team.agents:
        actions = random_masked_actions(obs, rng)
        obs, tr, *_ = team.step(actions)
        _, sr, *_ = split.step(actions)
        assert len(set(tr.values())) == 1
        assert sum(sr.values()) == pytest.approx(tr["crane_0"])
    with pytest.raises(ValueError, match="reward_mode"):
        multicrane.parallel_env("e2s2", reward_mode="once")


@pytest.mark.parametrize(
    ("decisions", "options"),
    [("motion", {}), ("task", {}), ("task", {"task_site_planes": True, "events": "high"})],
    ids=["motion", "task", "task-planes-events"],
)
def test_state_is_every_observation_concatenated(decisions, options):
    env = multicrane.parallel_env("e3s2", n_cranes=2, decisions=decisions, **options)
    with pytest.raises(RuntimeError, match="reset"):
        env.state()
    obs, _ = env.reset(seed=2)
    rng = np.random.default_rng(2)
    for t in range(40):
        want = np.concatenate([obs[a]["observation"] for a in env.possible_agents])
        if t % 2:  # the caller writes into its observations: the state is the env's own
            for a in env.possible_agents:
                obs[a]["observation"][:] = 0.5
        s = env.state()
        assert env.state_space.contains(s)
        assert np.array_equal(s, want), f"step {t}"
        s[:] = 7  # a copy: the caller cannot change the environment's state
        assert np.array_equal(env.state(), want)
        if not env.agents:
            break
        obs, *_ = env.step(random_masked_actions(obs, rng))


@pytest.mark.parametrize("decisions", ["motion", "task"])
def test_max_cycles_truncates_after_that_many_steps(decisions):
    env = multicrane.parallel_env("e3s2", decisions=decisions, max_cycles=3)
    obs, _ = env.reset(seed=0)
    rng = np.random.default_rng(0)
    for t in range(1, 4):
        obs, _, term, trunc, _ = env.step(random_masked_actions(obs, rng))
        assert trunc["crane_0"] == (t == 3) and not term["crane_0"]
    assert env.agents == []
    for bad in (0, -1):
        with pytest.raises(ValueError, match="max_cycles"):
            multicrane.parallel_env("e2s2", max_cycles=bad)
    with pytest.raises(TypeError, match="max_cycles"):
        multicrane.parallel_env("e2s2", max_cycles=2.5)


def test_np_random_is_the_episode_generator():
    a, b = multicrane.parallel_env("e3s2"), multicrane.parallel_env("e3s2")
    a.reset(seed=4)
    b.reset(seed=4)
    assert a.np_random.integers(1 << 30) == b.np_random.integers(1 << 30)
    assert isinstance(multicrane.parallel_env("e2s2").np_random, np.random.Generator)


def test_human_render_mode_streams_to_rerun(monkeypatch):
    pytest.importorskip("rerun")
    monkeypatch.setenv("MULTICRANE_RERUN_SINK", "memory")
    env = multicrane.parallel_env("e2s2", render_mode="human")
    env.reset(seed=0)
    env.step({"crane_0": 6})
    assert env.render() is None
    assert env._human is not None and env._human.sink == "memory"
    env.close()


def test_human_render_mode_without_rerun_names_the_extra(monkeypatch):
    real = builtins.__import__

    def no_rerun(name, *args, **kwargs):
        if name == "rerun" or name.startswith("rerun."):
            raise ImportError("No module named 'rerun'")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_rerun)
    env = multicrane.parallel_env("e2s2", render_mode="human")
    with pytest.raises(ImportError, match=r"multicrane\[replay\]"):
        env.reset(seed=0)


def test_supersuit_observation_wrappers_take_the_flat_observation():
    ss = pytest.importorskip("supersuit")
    env = multicrane.parallel_env("e3s2", obs_format="flat")
    env = ss.dtype_v0(env, np.float32)
    env = ss.normalize_obs_v0(env, env_min=0.0, env_max=1.0)
    env = ss.frame_stack_v1(env, 3)
    obs, _ = env.reset(seed=0)
    size = multicrane.parallel_env("e3s2").observation_layout.size
    assert obs["crane_0"].shape == (3 * size,)
    for _ in range(5):
        obs, *_ = env.step({a: 6 for a in env.agents})
        assert env.observation_space("crane_0").contains(obs["crane_0"])


def test_supersuit_frame_skip_uses_np_random():
    ss = pytest.importorskip("supersuit")
    env = ss.frame_skip_v0(multicrane.parallel_env("e3s2", obs_format="flat"), 2)
    env.reset(seed=0)
    _, rewards, *_ = env.step({a: 6 for a in env.agents})
    assert rewards["crane_0"] < 0  # two waiting steps' costs
    aec = ss.frame_skip_v0(multicrane.env("e3s2", obs_format="flat"), 2)
    aec.reset(seed=0)
    for _agent in aec.agent_iter(6):
        _, _, term, trunc, _ = aec.last()
        aec.step(None if term or trunc else 6)


@pytest.mark.parametrize(("option", "value"), [
    ("reward_mode", "once"), ("obs_format", "image"), ("render_mode", "video"),
    ("obs_format", None), ("reward_mode", ["team"]),
])  # fmt: skip
def test_a_choice_outside_its_list_is_named_with_the_list(option, value):
    expected = f"{option} must be one of .*, got {re.escape(repr(value))}"
    with pytest.raises(ValueError, match=expected):
        multicrane.parallel_env("e2s2", **{option: value})
