"""``tools/lns_episode.py``: a shipped scenario wrapped as a one-instance suite plays the same
episode as the plain environment, and the suite's search never ends longer than its start."""

from __future__ import annotations

from conftest import load_tool

import policies
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.episodes.rollout import run_episode
from multicrane.replay.record import record_episode
from multicrane.suite.lns import improve
from multicrane.suite.play import make_env, makespan_of


def test_one_instance_is_the_scenarios_episode_and_the_search_keeps_or_shortens_it():
    manifest, instance = load_tool("lns_episode").one_instance("e3s2", 2, 4)
    assert (instance.cranes, instance.seed, instance.events) == (2, 4, "none")
    env = make_env(manifest, instance, "task")
    start = record_episode(env, policies.make("greedy", env, 4), 4, "greedy")
    plain = MultiCraneEnv("e3s2", n_cranes=2, decisions="task")
    assert makespan_of(start) == run_episode(plain, policies.make("greedy", plain, 4), 4)["steps"]
    out = improve(manifest, instance, 3.0, start=start)
    assert out.makespan <= out.start and makespan_of(out.record) == out.makespan
