"""The prioritized rule with a list order of its own (``TaskPrioritized(order=...)``) and
``tools/order_probe.py``: the rule's own start order replayed is a fixed point, a bad order is
refused by name, and the class-wise permutation moves components only inside their class."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import load_tool

import multicrane
from multicrane.episodes.rollout import run_episode
from multicrane.tasks.order_scorer import FEATURES
from multicrane.tasks.priority_rule import list_ranks
from policies.task_planners import TaskPrioritized

probe = load_tool("order_probe")


@pytest.mark.parametrize(("scenario", "cranes", "seed"),
                         [("e3s2", 2, 0), ("hall-4c", 4, 1), ("frame2-3c", 3, 2)])  # fmt: skip
def test_the_rules_own_start_order_replayed_plays_the_same_episode(scenario, cranes, seed):
    env = multicrane.parallel_env(scenario, n_cranes=cranes, decisions="task")
    first = run_episode(env, TaskPrioritized(env), seed, record=True)
    order = probe.start_order(env, first["actions"])
    assert sorted(order) == list(range(env.unwrapped.scenario.n_components))
    again = run_episode(env, TaskPrioritized(env, order=order), seed, record=True)
    assert again["actions"] == first["actions"]
    assert again["makespan"] == first["makespan"] is not None


def test_another_order_changes_which_component_starts_first():
    env = multicrane.parallel_env("hall-4c", n_cranes=4, decisions="task")
    plain = run_episode(env, TaskPrioritized(env), 0, record=True)
    plain_order = probe.start_order(env, plain["actions"])
    # The same cohort of ready components, the first and second swapped.
    swapped = [plain_order[1], plain_order[0], *plain_order[2:]]
    other = run_episode(env, TaskPrioritized(env, order=swapped), 0, record=True)
    assert probe.start_order(env, other["actions"])[:2] == swapped[:2]


@pytest.mark.parametrize(("order", "words"), [
    ([0, 1, 2], "missing"),
    (list(range(28)) + [0], "missing [28], out of range or repeated [0]"),
    (list(range(28)) + [99], "missing [28], out of range or repeated [99]"),
    ([*range(28), 28.0], "indices (integers), got [28.0]"),
    ([*range(28), True], "indices (integers), got [True]"),
])  # fmt: skip
def test_a_bad_order_is_refused_by_name(order, words):
    scenario = multicrane.parallel_env("hall-4c", decisions="task").unwrapped.scenario
    assert scenario.n_components == 29
    with pytest.raises(ValueError, match="order must list") as err:
        list_ranks(scenario, order)
    assert words in str(err.value)


def test_the_class_wise_order_permutes_only_inside_each_class():
    env = multicrane.parallel_env("hall-4c", n_cranes=4, decisions="task")
    scenario, compatible = env.unwrapped.scenario, env.unwrapped.sim.site.compatible
    reverse = list(reversed(scenario.order))
    mixed = probe.within_classes(env, reverse)
    assert sorted(mixed) == sorted(scenario.order) and mixed != list(scenario.order)
    for slot, c in enumerate(mixed):  # each place keeps a component of its own class
        assert compatible[c] == compatible[scenario.order[slot]]
    for a in mixed:  # inside a class, the given order
        for b in mixed:
            if compatible[a] == compatible[b] and mixed.index(a) < mixed.index(b):
                assert reverse.index(a) < reverse.index(b)


def test_the_order_scorer_learns_a_sites_start_order_and_plays_it():
    fitter = load_tool("order_fit")
    sites = [("hall-4c", "hall-4c")]
    data = fitter.collect(sites, "prioritized:rank=chain", 3)
    features, order = data[0]
    assert features.shape == (29, len(FEATURES)) and sorted(order) == list(range(29))
    assert np.isfinite(features).all()
    score = fitter.fit(data, epochs=300, seed=0)
    assert fitter.agreement(score, data) > 0.95  # a wrong sign in the loss gives about 0
    assert fitter.play(score, sites, 3)[0] is not None
