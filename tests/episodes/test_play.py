"""The one episode loop's own form (``multicrane.episodes.rollout.play``, ``play_seeds``) and
its timing hooks: a ``Stopwatch`` as ``step_watch`` times ``env.step`` and nothing else."""

from __future__ import annotations

import pytest

import multicrane
import policies
from multicrane.episodes.rollout import Stopwatch, play, play_seeds, run_episode


class Clock:
    """A clock that only the fake environment and the fake policy move."""

    def __init__(self):
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


class Ticking:
    """A single-agent environment of ``length`` steps: a step costs 1 tick of ``clock``, a
    reset 1000; it keeps the seeds it was reset with."""

    def __init__(self, clock: Clock, length: int):
        self.clock, self.length, self.t, self.seeds = clock, length, 0, []

    def reset(self, seed=None):
        self.clock.now += 1000
        self.t = 0
        self.seeds.append(seed)
        return 0, {}

    def step(self, action):
        self.clock.now += 1
        self.t += 1
        return self.t, 0.0, self.t >= self.length, False, {}


def test_the_step_watch_times_the_steps_only_and_a_timed_policy_its_calls_only():
    clock = Clock()
    env = Ticking(clock, length=3)
    steps, calls = Stopwatch(clock), Stopwatch(clock)

    def policy(observation):
        clock.now += 100
        return observation

    made = play(env, calls.timing(policy), 5, steps=7, repeat=True, step_watch=steps)
    assert made == 7
    assert steps.seconds == [1] * 7 and calls.seconds == [100] * 7
    assert env.seeds == [5, None, None]  # episodes end after steps 3 and 6: unseeded resets


def test_play_stops_at_the_end_of_the_episode_or_at_its_step_limit():
    clock = Clock()
    assert play(Ticking(clock, length=3), lambda o: 0) == 3
    assert play(Ticking(clock, length=3), lambda o: 0, steps=2) == 2
    assert play(Ticking(clock, length=3), lambda o: 0, steps=10) == 3
    with pytest.raises(ValueError, match="needs a number of steps"):
        play(Ticking(clock, length=3), lambda o: 0, repeat=True)


def test_the_hooks_see_every_reset_and_every_step_of_a_multi_agent_env():
    env = multicrane.parallel_env("e2s2", n_cranes=2, max_steps=4)
    resets, seen = [], []
    made = play(env, policies.make("random", env, 0), 0, steps=10, repeat=True,
                on_reset=lambda e: resets.append(e.sim.state.step_count),
                after_step=lambda action, out: seen.append((action, len(out))))  # fmt: skip
    assert made == 10 and resets == [0, 0, 0]  # episodes of 4 steps: resets after 4 and 8
    assert len(seen) == 10 and all(set(a) == set(env.possible_agents) for a, _ in seen)
    assert all(n == 5 for _, n in seen)


def test_play_plays_the_episode_run_episode_measures():
    env = multicrane.parallel_env("e1s1", n_cranes=2)
    m = run_episode(env, policies.make("prioritized", env, 0), seed=0)
    assert play(env, policies.make("prioritized", env, 0), 0) == m["steps"]
    assert not env.agents and env.sim.done
    paper = multicrane.PaperAssemblyEnv("E1S1")
    g = run_episode(paper, policies.make("greedy", paper, 2), seed=2)
    assert play(paper, policies.make("greedy", paper, 2), 2) == g["steps"]


def test_play_seeds_plays_episodes_on_seeds_0_1_2_until_the_steps_are_made():
    clock = Clock()
    env = Ticking(clock, length=3)
    made: list[int] = []

    def make_policy(env, seed):
        made.append(seed)
        return lambda observation: 0

    steps = Stopwatch(clock)
    assert play_seeds(env, make_policy, 7, step_watch=steps) == 3
    assert made == [0, 1, 2] and env.seeds == [0, 1, 2] and len(steps.seconds) == 7
