"""The learned orders shipped with the library (``policies/scorers``): named, loaded, played."""

from __future__ import annotations

import numpy as np
import pytest

import multicrane
import policies
from multicrane.episodes.rollout import run_episode
from multicrane.scenario.named_sets import scenario_set
from multicrane.tasks.order_scorer import FEATURES, OrderScorer
from multicrane.training.seeding import evaluation_seeds
from policies.task_planners import SCORERS, TaskPrioritized, load_scorer, shipped_scorers

SHIPPED = "order-es21-s0"


def test_the_shipped_scorers_are_listed_and_load_as_their_files():
    assert SHIPPED in shipped_scorers()
    for name in shipped_scorers():
        scorer = load_scorer(name)
        on_disk = OrderScorer.load(SCORERS / f"{name}.json")
        assert np.array_equal(scorer.parameters(), on_disk.parameters())
        assert scorer.weights.shape == (len(FEATURES),)
        assert scorer.meta["rank"] == "chain" and scorer.meta["fit_set"] is None


def test_a_scorer_is_an_object_a_path_or_a_shipped_name(tmp_path, monkeypatch):
    mine = OrderScorer.list_order()
    assert load_scorer(mine) is mine
    mine.save(tmp_path / "scorer.json")
    assert np.array_equal(load_scorer(tmp_path).parameters(), mine.parameters())
    assert np.array_equal(load_scorer(str(tmp_path / "scorer.json")).parameters(),
                          mine.parameters())  # fmt: skip
    monkeypatch.chdir(tmp_path)  # a path of the shipped name, here, wins over the shipped one
    mine.save(tmp_path / SHIPPED)
    assert np.array_equal(load_scorer(SHIPPED).parameters(), mine.parameters())


@pytest.mark.parametrize(
    "scorer, words",
    [
        ("no-such-scorer", f"'no-such-scorer': no such file or run directory, and not a "
                           f"shipped scorer ({SHIPPED}"),
        (3, "scorer must be an OrderScorer, a path or a shipped scorer's name, got 3"),
        (["x"], "got ['x']"),
    ],
)  # fmt: skip
def test_a_bad_scorer_is_named(scorer, words):
    with pytest.raises(ValueError) as caught:
        load_scorer(scorer)
    assert words in str(caught.value)
    env = multicrane.parallel_env("hall-4c", decisions="task")
    with pytest.raises(ValueError, match="scorer"):
        policies.make("prioritized", env, seed=0, rank="chain", scorer=scorer)


# Golden episodes: the shipped order against the planner on sites it was not trained on
# (test-small's first members, the reset seed multicrane evaluate --episodes 1 plays).
GOLDEN = [
    # (test-small member, the planner's makespan, the shipped order's)
    (0, 169, 167),  # frame
    (1, 122, 111),  # hall
    (4, 137, 132),  # tower
    (5, 98, 83),  # frame
]


@pytest.mark.parametrize("member, planner, learned", GOLDEN)
def test_the_shipped_order_plays_its_golden_episodes(member, planner, learned):
    _, scenario = scenario_set("test-small")[member]
    env = multicrane.parallel_env(scenario, decisions="task")
    seed = evaluation_seeds(1)[0]
    assert run_episode(env, TaskPrioritized(env), seed)["makespan"] == planner
    by_name = policies.make(f"prioritized:rank=chain,scorer={SHIPPED}", env, seed=seed)
    assert run_episode(env, by_name, seed)["makespan"] == learned
    own_rank = policies.make(f"prioritized:scorer={SHIPPED}", env, seed=seed)  # its meta's
    assert own_rank.rank == "chain"
    assert run_episode(env, own_rank, seed)["makespan"] == learned


def test_a_scorer_plays_its_own_rank_unless_told_otherwise():
    env = multicrane.parallel_env("hall-4c", decisions="task")
    assert TaskPrioritized(env).rank == "list"
    assert TaskPrioritized(env, scorer=SHIPPED).rank == "chain"
    assert TaskPrioritized(env, scorer=SHIPPED, rank="list").rank == "list"
    assert TaskPrioritized(env, scorer=OrderScorer.list_order()).rank == "list"  # no meta
    odd = OrderScorer.list_order()
    odd.meta["rank"] = "sideways"
    with pytest.raises(ValueError, match="rank must be one of .*got 'sideways'"):
        TaskPrioritized(env, scorer=odd)
