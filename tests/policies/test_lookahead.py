"""The look-ahead task planner (``policies.lookahead``): legal, deterministic, no later than
the prioritized planner on the shipped sites measured here, and refused where it would cheat."""

from __future__ import annotations

import gc
import time

import numpy as np
import pytest
from conftest import play_legal

import policies
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.envs.rollout_copy import rollout_copy
from multicrane.episodes.rollout import Stopwatch, run_episode
from policies.lookahead import TaskLookahead
from policies.task_planners import TaskPrioritized

# (scenario, cranes): the prioritized planner's and the look-ahead's makespans from reset(0)
# (measured; the look-ahead is not guaranteed shorter in general, see the module doc).
MAKESPANS = {("e2s2", 2): (30, 28), ("e3s2", 2): (63, 57), ("precast-house", 3): (64, 63)}


def task_env(name: str, n: int, **options) -> MultiCraneEnv:
    return MultiCraneEnv(name, n_cranes=n, decisions="task", **options)


@pytest.mark.parametrize(("name", "n"), list(MAKESPANS))
def test_lookahead_finishes_sooner_than_the_planner(name, n):
    env = task_env(name, n)
    planner = run_episode(env, policies.make("prioritized", env, seed=0), seed=0)
    look = run_episode(env, policies.make("lookahead", env, seed=0), seed=0)
    assert planner["success"] and look["success"]
    assert (planner["steps"], look["steps"]) == MAKESPANS[(name, n)]


def test_lookahead_is_legal_and_leaves_the_real_site_alone():
    env = task_env("e3s2", 2)
    policy = TaskLookahead(env)
    play_legal(env, policy, seed=3, steps=200, label="lookahead")
    assert policy.rollouts > 0
    obs, _ = env.reset(seed=4)
    policy = TaskLookahead(env)
    for _ in range(5):
        before = (env.sim.state.step_count, env.sim.state.n_assembled)
        actions = policy(obs)
        assert (env.sim.state.step_count, env.sim.state.n_assembled) == before
        obs, *_ = env.step(actions)


def test_a_rollout_copy_starts_its_trace_afresh_and_leaves_the_episode_recordable():
    """The copies share no trace with the episode (a rollout is never recorded), and the real
    episode's trace stays whole: one physical joint action per simulated step."""
    env = task_env("e3s2", 2)
    obs, _ = env.reset(seed=2)
    policy = TaskLookahead(env)
    for _ in range(4):
        obs, *_ = env.step(policy(obs))
    trace = [list(step) for step in env.mode.trace]
    copy = rollout_copy(env)
    assert copy.mode.trace == [] and copy.mode.decisions == []
    assert copy.mode.trace is not env.mode.trace
    copy.step(policy(obs))
    assert env.mode.trace == trace and len(copy.mode.trace) > 0
    episode = run_episode(env, TaskLookahead(env), seed=5)
    assert len(env.mode.trace) == episode["steps"]  # one physical joint action per step


@pytest.mark.parametrize(("name", "n", "seed"), [("hall-4c", 4, 1), ("precast-house", 3, 0)])
def test_a_rollout_copy_played_out_leaves_the_episode_as_it_was(name, n, seed):
    """The copy shares the simulator's fixed parts (the start, the pick-up poses, the cell
    lists a move replaces) and still changes nothing of the episode: its state, the cell
    lists' contents, the carrier's plans and the book stay as they were."""
    env = task_env(name, n)
    obs, _ = env.reset(seed=seed)
    planner = TaskPrioritized(env)
    for _ in range(6):
        obs, *_ = env.step(planner(obs))
    sim, book = env.sim, env.mode.task_book()
    state = sim.snapshot()
    cells = [list(c) for c in sim.state.cells]
    plans = {c: (p.t0, list(p.positions)) for c, p in book.carrier.plans.items()}
    tasks = (list(book.task), list(book.started))
    copy = rollout_copy(env)
    assert copy.sim.state.pickup is sim.state.pickup and copy.sim.start is sim.start
    assert copy.sim.state is not sim.state and copy.sim.state.cells is not sim.state.cells
    rule = TaskPrioritized(copy)
    while not any(copy.advance(rule({}))):
        pass
    assert copy.sim.state.n_assembled > sim.state.n_assembled
    assert sim.state.equals(state) and [list(c) for c in sim.state.cells] == cells
    assert {c: (p.t0, list(p.positions)) for c, p in book.carrier.plans.items()} == plans
    assert (list(book.task), list(book.started)) == tasks
    obs, *_ = env.step(planner(obs))  # the episode goes on from where it was


def test_lookahead_is_deterministic():
    runs = []
    for _ in range(2):
        env = task_env("e3s2", 2)
        runs.append(run_episode(env, policies.make("lookahead", env, seed=1), seed=1,
                                record=True)["actions"])  # fmt: skip
    assert runs[0] == runs[1]


class _SeeingPrioritized(TaskPrioritized):
    """The rule, saying it reads observations: the look-ahead's rollouts then ``step``."""

    reads_observations = True


@pytest.mark.parametrize(("name", "n", "seed"), [("e3s2", 2, 1), ("hall-4c", 3, 0)])
def test_rule_rollouts_by_advance_choose_as_rollouts_by_step(name, n, seed):
    """A base that reads no observations (the prioritized rule) finishes its copies with
    ``env.advance``; a round then chooses exactly as when the copies ``step``."""
    runs = []
    for base in (None, _SeeingPrioritized):
        env = task_env(name, n)
        look = TaskLookahead(env, base=base)
        runs.append(run_episode(env, look, seed=seed, record=True)["actions"])
        assert look.rollouts > 0
    assert runs[0] == runs[1]


def test_no_candidates_still_compares_waiting():
    env = task_env("e2s2", 2)
    episode = run_episode(env, policies.make("lookahead", env, seed=0, candidates=0), seed=0)
    assert episode["success"] and episode["steps"] <= MAKESPANS[("e2s2", 2)][0]


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"decisions": "motion"}, "drives task decisions"),
        ({"decisions": "task", "events": "low"}, "future site events"),
    ],
)
def test_lookahead_is_refused_where_it_cannot_play_fair(options, message):
    env = MultiCraneEnv("e3s2", n_cranes=2, **options)
    env.reset(seed=0)
    with pytest.raises(policies.PolicyError, match=message):
        policies.make("lookahead", env, seed=0)


def test_bad_candidates_are_refused():
    with pytest.raises(ValueError, match="candidates"):
        TaskLookahead(task_env("e2s2", 2), candidates=-1)


def test_a_budget_bounds_the_candidates_tried():
    env = task_env("e3s2", 2)
    planner = run_episode(env, policies.make("prioritized", env, seed=1), seed=1, record=True)
    free = run_episode(env, policies.make("lookahead", env, seed=1), seed=1, record=True)
    roomy = run_episode(env, policies.make("lookahead", env, seed=1, budget=1e6), seed=1,
                        record=True)  # fmt: skip
    tight = TaskLookahead(env, budget=1e-9)  # no time for anything but the planner's own
    none_tried = run_episode(env, tight, seed=1, record=True)
    assert roomy["actions"] == free["actions"] != planner["actions"]
    assert none_tried["actions"] == planner["actions"]
    # at most one rollout a round (the planner's joint action), against several without
    assert 0 < tight.rollouts <= none_tried["decision_rounds"]


def planner_calling(hook):
    """A base for ``TaskLookahead``: the prioritized planner, calling ``hook(env)`` (the env
    it plays: the round's own or a copy) before each of its calls."""

    def base(env):
        planner = TaskPrioritized(env)

        def policy(observations):
            hook(env)
            return planner(observations)

        return policy

    return base


def test_a_budget_bounds_each_round_even_when_the_bases_own_rollout_is_slower():
    """A base whose every call sleeps 10 ms finishes a copy in up to 99 ms, against a 30 ms
    budget: the rollouts stop at the deadline (27 ms), so each round ends within the budget
    plus the rollout step under way (a 10 ms call here; 33 ms measured), and the round plays
    the base's own joint action."""
    env = task_env("e3s2", 2)
    slow_base = planner_calling(lambda copy_env: time.sleep(0.01))
    look = TaskLookahead(env, base=slow_base, budget=0.03)
    watch = Stopwatch()
    result = run_episode(env, watch.timing(look), seed=1, record=True)
    planner = run_episode(env, TaskPrioritized(env), seed=1, record=True)
    assert result["actions"] == planner["actions"]  # no copy finished: the base's own
    assert len(watch.seconds) == result["decision_rounds"] > 5
    assert max(watch.seconds) < 0.03 + 0.02, max(watch.seconds)


@pytest.mark.parametrize("budget", [None, 10.0])
def test_the_collector_is_paused_in_a_budgeted_rounds_rollouts_only(budget):
    env = task_env("e3s2", 2)
    seen = []

    def probe(copy_env):
        if copy_env is not env:  # in a rollout, not the round's own call
            seen.append(gc.isenabled())

    look = TaskLookahead(env, base=planner_calling(probe), budget=budget)
    obs, _ = env.reset(seed=2)
    for _ in range(3):
        obs, *_ = env.step(look(obs))
        assert gc.isenabled()  # back on between rounds
    assert look.rollouts > 0 and seen
    assert not any(seen) if budget else all(seen)
    gc.disable()
    try:  # a collector the caller turned off stays off
        look(obs)
        assert not gc.isenabled()
    finally:
        gc.enable()


@pytest.mark.parametrize("budget", [0, -1.0, "1", float("nan")])
def test_a_bad_budget_is_refused(budget):
    with pytest.raises(ValueError, match="budget"):
        TaskLookahead(task_env("e2s2", 2), budget=budget)


def test_the_first_crane_alone_searches_by_default():
    """``cranes=1`` is the default: the same episode, and the same rollouts, as before the
    option; with more cranes the first crane's search is unchanged and later ones add to it."""
    env = task_env("e3s2", 2)
    default = TaskLookahead(env)
    one = TaskLookahead(env, cranes=1)
    a = run_episode(env, default, seed=2, record=True)
    b = run_episode(env, one, seed=2, record=True)
    assert a["actions"] == b["actions"] and default.rollouts == one.rollouts


def test_each_idle_crane_searching_never_expects_longer_and_shortens_some_rounds():
    """Agent-by-agent rollout over the (sequentially consistent) prioritized planner: every
    round's pick finishes its copy no later than the first crane's best (the incumbent on
    ties), and replaying it gives that makespan again; so the expected finish never rises
    from round to round, and the episode ends no later than any round expected. Each
    episode is legal and the real site untouched by the copies; later cranes' searches
    shorten some rounds."""
    improved = 0
    for name, n, seed in [("e3s2", 3, 1), ("precast-house", 3, 0), ("e4s2", 3, 0)]:
        env = task_env(name, n)
        obs, _ = env.reset(seed=seed)
        look = TaskLookahead(env, candidates=2, cranes=n)
        expected = []
        while True:
            before = (env.sim.state.step_count, env.sim.state.n_assembled)
            joint = look(obs)
            assert (env.sim.state.step_count, env.sim.state.n_assembled) == before
            if look.values is not None:
                first = min(look.values[1].values())
                assert look.expected <= first
                assert look._finish(joint) == look.expected
                improved += look.expected < first
                expected.append(look.expected)
            obs, _, terms, truncs, _ = env.step(joint)
            if any(terms.values()) or any(truncs.values()):
                break
        assert all(terms.values()), (name, n, seed)
        assert expected == sorted(expected, reverse=True), (name, n, seed)
        assert env.sim.state.step_count <= expected[-1], (name, n, seed)
    assert improved > 0


def test_a_later_crane_keeps_the_earlier_cranes_choices():
    """A later crane's alternative that takes the component or target an earlier crane chose
    is not tried; one that takes a later crane's makes that crane wait."""
    env = task_env("e3s2", 3)
    obs, _ = env.reset(seed=0)
    look = TaskLookahead(env, cranes=3)
    book = env.mode.task_book()
    a0, a1, a2 = env.possible_agents
    p = int(np.flatnonzero(book.allowed()[0])[0])
    clashing = np.flatnonzero(book.tasks.conflicts(p) & book.allowed()[1])
    joint = {a0: 1 + p, a1: 0, a2: 1 + int(clashing[0])}
    assert look._with(joint, a1, 1 + int(clashing[0]), fixed={a0}) is None
    moved = look._with(joint, a1, 1 + int(clashing[0]), fixed=set())
    assert moved == {a0: 0, a1: 1 + int(clashing[0]), a2: 0}
    kept = look._with(joint, a1, 0, fixed={a0})
    assert kept == {a0: 1 + p, a1: 0, a2: 1 + int(clashing[0])}


@pytest.mark.parametrize("cranes", [0, -1, 1.5, "2", True])
def test_bad_cranes_are_refused(cranes):
    with pytest.raises(ValueError, match="cranes"):
        TaskLookahead(task_env("e2s2", 2), cranes=cranes)


@pytest.mark.parametrize(("name", "n", "seed"), [("e3s2", 2, 0), ("e4s2", 3, 1)])
def test_two_base_heuristics_finish_no_later_than_either(name, n, seed):
    """``planner=True`` over another base (here the greedy rule): each joint action's value
    is the shorter of the two finishes, the planner's own joint action is a candidate, and
    the episode ends no later than either base heuristic's own episode (rollout with several
    heuristics improves on each), its expected finish never rising."""
    from policies.task_planners import TaskGreedy

    env = task_env(name, n)
    alone = {label: run_episode(env, policies.make(label, env, seed=seed), seed=seed)["steps"]
             for label in ("greedy", "prioritized")}  # fmt: skip
    look = TaskLookahead(env, candidates=2, base=TaskGreedy, planner=True)
    assert len(look.bases) == 2
    obs, _ = env.reset(seed=seed)
    expected = []
    while True:
        joint = look(obs)
        if look.expected is not None:
            by = [look._finish_by(base, joint) for base in look.bases]
            assert look.expected == min(by)
            expected.append(look.expected)
        obs, _, terms, truncs, _ = env.step(joint)
        if any(terms.values()) or any(truncs.values()):
            break
    assert all(terms.values())
    assert expected == sorted(expected, reverse=True)
    assert env.sim.state.step_count <= min(alone.values())


def test_the_planner_option_needs_another_base_and_a_bool():
    assert len(TaskLookahead(task_env("e2s2", 2), planner=True).bases) == 1  # its own base
    with pytest.raises(ValueError, match="planner"):
        TaskLookahead(task_env("e2s2", 2), planner="yes")
