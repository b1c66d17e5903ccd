"""A learned list order for the prioritized rule (``multicrane.tasks.order_scorer``,
``TaskPrioritized(scorer=...)``) and its trainer ``tools/order_es.py``: the list-order scorer
plays the plain rule's episodes action for action, a scorer's order is its scores', a scorer
file round-trips and a bad one is refused by name, and the trainer is a function of its seed."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import load_tool

import multicrane
import policies
from multicrane.episodes.rollout import run_episode
from multicrane.scenario.named_sets import members, train_member, train_scenario
from multicrane.tasks.order_scorer import (
    FEATURES,
    OrderScorer,
    component_features,
    yard_neighbours,
)
from policies.task_planners import TaskPrioritized

es = load_tool("order_es")


def _reset(scenario, cranes, seed):
    env = multicrane.parallel_env(scenario, n_cranes=cranes, decisions="task")
    env.reset(seed=seed)
    return env, env.unwrapped


@pytest.mark.parametrize("rank", ["list", "chain"])
@pytest.mark.parametrize(("scenario", "cranes", "seed"),
                         [("e3s2", 2, 0), ("hall-4c", 4, 1), ("frame2-3c", 3, 2)])  # fmt: skip
def test_the_list_order_scorer_plays_the_plain_rule(scenario, cranes, seed, rank):
    env = multicrane.parallel_env(scenario, n_cranes=cranes, decisions="task")
    plain = run_episode(env, TaskPrioritized(env, rank=rank), seed, record=True)
    scored = TaskPrioritized(env, rank=rank, scorer=OrderScorer.list_order())
    again = run_episode(env, scored, seed, record=True)
    assert again["actions"] == plain["actions"]
    assert again["makespan"] == plain["makespan"] is not None


def test_features_are_finite_static_and_name_the_list_place():
    env, base = _reset("hall-4c", 4, 3)
    features = component_features(base.mode.task_book(), base.scenario)
    n = base.scenario.n_components
    assert features.shape == (n, len(FEATURES)) and np.isfinite(features).all()
    place = {c: i for i, c in enumerate(base.scenario.order)}
    assert np.allclose(features[:, 0], [place[c] / n for c in range(n)])
    assert np.allclose(features[:, FEATURES.index("cranes")], 4 / 16)
    ranks = features[:, FEATURES.index("distance_rank")] * n  # each component's place, once
    assert sorted(np.rint(ranks).astype(int).tolist()) == list(range(n))
    shortest = features[:, FEATURES.index("shortest_distance")]
    assert (np.diff(shortest[np.argsort(ranks)]) >= 0).all()  # ranked by the shortest distance
    env.step({a: 0 for a in env.agents})  # the features are the reset's, not the step's
    assert np.array_equal(component_features(base.mode.task_book(), base.scenario), features)


class _Grid:
    """A stand-in site: cell ``i`` of a 10 x 10 x 5 grid, x fastest."""

    @staticmethod
    def cell(i):
        return (i % 10, i // 10 % 10, i // 100)


def _at(*cells):
    return [x + 10 * y + 100 * z for x, y, z in cells]


@pytest.mark.parametrize(("pickup", "expected"), [
    ([_at((0, 0, 0)), _at((5, 5, 0))], [0, 0]),  # far apart
    ([_at((0, 0, 0)), _at((1, 1, 0))], [1, 1]),  # diagonal neighbours
    ([_at((0, 0, 0)), _at((2, 0, 0))], [0, 0]),  # two cells apart
    ([_at((3, 3, 0)), _at((3, 3, 2))], [1, 1]),  # one above the other
    ([_at((0, 0, 0), (1, 0, 0), (2, 0, 0)), _at((3, 0, 0)), _at((0, 1, 0)), []], [2, 1, 1, 0]),
])  # fmt: skip
def test_yard_neighbours_counts_the_components_next_to_each(pickup, expected):
    assert yard_neighbours(_Grid, pickup) == expected


def _yard_neighbours_reference(site, pickup) -> list[int]:
    """The definition, with sets: the other components with a pick-up column within one
    column of one of this component's."""
    columns = [{tuple(site.cell(x)[:2]) for x in cells} for cells in pickup]
    around = [{(x + dx, y + dy) for x, y in cols for dx in (-1, 0, 1) for dy in (-1, 0, 1)}
              for cols in columns]  # fmt: skip
    return [sum(1 for j, other in enumerate(columns) if j != c and other & around[c])
            if columns[c] else 0 for c in range(len(columns))]  # fmt: skip


def test_yard_neighbours_match_the_set_definition_on_drawn_yards():
    scenarios = ["hall-4c", "precast-house", "e4s4"]
    scenarios += [m.scenario() for name in ("test-large", "test-other") for m in members(name)[:2]]
    counts = []
    for scenario in scenarios:
        env = multicrane.parallel_env(scenario, decisions="task")
        for seed in (0, 5):
            env.reset(seed=seed)
            sim = env.unwrapped.sim
            expected = _yard_neighbours_reference(sim.site, sim.state.pickup)
            assert yard_neighbours(sim.site, sim.state.pickup) == expected
            counts += expected
    assert 0 in counts and max(counts) >= 3  # lone components and crowded ones were checked


def test_the_order_follows_the_scores_with_ties_in_list_order():
    _, base = _reset("hall-4c", 4, 0)
    features = component_features(base.mode.task_book(), base.scenario)
    chain = FEATURES.index("chain")
    weights = np.zeros(len(FEATURES))
    weights[chain] = 1.0
    order = OrderScorer(weights).order(features, base.scenario)
    assert sorted(order) == list(range(base.scenario.n_components))
    values = features[order, chain]
    assert (np.diff(values) <= 0).all()  # highest chain first
    for level in set(values.tolist()):  # within a level, the scenario's order
        same = [c for c in order if features[c, chain] == level]
        assert same == [c for c in base.scenario.order if features[c, chain] == level]
    reverse = OrderScorer([1.0] + [0.0] * (len(FEATURES) - 1)).order(features, base.scenario)
    assert reverse == list(reversed(base.scenario.order))


def test_the_scorer_is_made_again_for_each_episode():
    env = multicrane.parallel_env("e3s2", n_cranes=2, decisions="task")
    weights = np.zeros(len(FEATURES))
    weights[FEATURES.index("shortest_distance")] = -1.0  # depends on the episode's yard
    kept = TaskPrioritized(env, rank="chain", scorer=OrderScorer(weights))
    for seed in (4, 5):
        fresh = TaskPrioritized(env, rank="chain", scorer=OrderScorer(weights))
        assert (run_episode(env, kept, seed, record=True)["actions"]
                == run_episode(env, fresh, seed, record=True)["actions"])  # fmt: skip


def test_a_scorer_file_round_trips_and_plays_by_name(tmp_path):
    weights = np.linspace(-1, 1, len(FEATURES))
    path = tmp_path / "scorer.json"
    OrderScorer(weights, {"rank": "chain"}).save(path)
    loaded = OrderScorer.load(path)
    assert np.array_equal(loaded.weights, weights) and loaded.meta == {"rank": "chain"}
    assert np.array_equal(OrderScorer.load(tmp_path).weights, weights)  # the run directory
    env = multicrane.parallel_env("hall-4c", n_cranes=4, decisions="task")
    by_name = policies.make(f"prioritized:rank=chain,scorer={tmp_path}", env, seed=1)
    direct = TaskPrioritized(env, rank="chain", scorer=loaded)
    assert (run_episode(env, by_name, 1, record=True)["actions"]
            == run_episode(env, direct, 1, record=True)["actions"])  # fmt: skip


N = len(FEATURES)
GOOD = {"format": "multicrane-order-scorer", "version": 1, "features": list(FEATURES),
        "weights": [0.0] * N}  # fmt: skip
FIRST = list(FEATURES[:16])  # a file written before the later features were added


def test_a_file_of_the_first_features_weighs_the_later_ones_zero(tmp_path):
    weights = np.linspace(-1, 1, 16)
    path = tmp_path / "scorer.json"
    path.write_text(json.dumps({**GOOD, "features": FIRST, "weights": weights.tolist()}))
    loaded = OrderScorer.load(path)
    assert np.array_equal(loaded.weights, np.concatenate([weights, np.zeros(N - 16)]))
    _, base = _reset("hall-4c", 4, 2)
    features = component_features(base.mode.task_book(), base.scenario)
    assert np.allclose(loaded.scores(features), features[:, :16] @ weights)


@pytest.mark.parametrize(("text", "words"), [
    (None, "cannot read it"),
    ("{not json", "not JSON"),
    (json.dumps([1, 2]), "'format' must be"),
    (json.dumps({**GOOD, "format": "other"}), "'format' must be"),
    (json.dumps({**GOOD, "features": ["chain"]}), "'features' must list"),
    (json.dumps({**GOOD, "features": []}), "'features' must list"),
    (json.dumps({**GOOD, "features": "list_place"}), "'features' must list"),
    (json.dumps({**GOOD, "features": FIRST + ["other"]}), "'features' must list"),
    (json.dumps({**GOOD, "features": FIRST}), "'weights' must be 16 finite numbers"),
    (json.dumps({**GOOD, "weights": [0.0] * 3}), f"'weights' must be {N} finite numbers"),
    (json.dumps({**GOOD, "weights": ["a"] * N}), f"'weights' must be {N} finite numbers"),
    (json.dumps({**GOOD, "weights": [True] * N}), f"'weights' must be {N} finite numbers"),
    (json.dumps({**GOOD, "weights": [float("nan")] * N}), f"'weights' must be {N} finite"),
])  # fmt: skip
def test_a_bad_scorer_file_is_refused_by_name(tmp_path, text, words):
    path = tmp_path / "scorer.json"
    if text is not None:
        path.write_text(text)
    with pytest.raises(ValueError, match="order scorer") as err:
        OrderScorer.load(path)
    assert words in str(err.value) and str(path) in str(err.value)


def test_bad_weights_and_an_order_beside_a_scorer_are_refused():
    with pytest.raises(ValueError, match=f"{N} finite weights"):
        OrderScorer([0.0, np.inf] + [0.0] * (N - 2))
    env = multicrane.parallel_env("e3s2", decisions="task")
    with pytest.raises(ValueError, match="an order or a scorer, not both"):
        TaskPrioritized(env, order=list(range(env.unwrapped.scenario.n_components)),
                        scorer=OrderScorer.list_order())  # fmt: skip


@pytest.mark.parametrize("hidden", [0, 2])
def test_a_generation_moves_only_the_trained_features(hidden):
    seen = []

    def mapper(_, jobs, chunksize):  # a stand-in for the episodes: a ratio per probe
        seen.extend(jobs)
        return [[1.0 + 0.01 * i for i in range(len(job[2]))] for job in jobs]

    args = es.parser().parse_args(["--pairs", "3", "--features", "4", "--hidden", str(hidden)])
    scorer = OrderScorer.list_order(hidden, np.random.default_rng(1))
    trained = scorer.trainable(4)
    assert len(trained) == 4 + hidden * (4 + 2)
    grad, ratio = es.es_step(mapper, scorer, trained, [7, 8], np.random.default_rng(0), args)
    assert grad.shape == trained.shape and np.isfinite(grad).all() and 1.0 < ratio < 1.06
    assert [job[0] for job in seen] == [7, 8] and len(seen[0][2]) == 6
    start, fixed = scorer.parameters(), np.setdiff1d(np.arange(len(scorer.parameters())), trained)
    for probe in seen[0][2]:
        moved = probe.parameters()
        assert probe.hidden_units == hidden and (moved[fixed] == start[fixed]).all()
        assert (moved[trained] != start[trained]).all()
    if hidden:  # the inputs of features 4.. to the hidden units stay as drawn
        assert np.array_equal(seen[0][2][0].hidden["weights"][:, 4:],
                              scorer.hidden["weights"][:, 4:])  # fmt: skip
    with pytest.raises(SystemExit):
        es.main(["--out", "x", "--features", str(N + 1)])
    with pytest.raises(SystemExit):
        es.main(["--out", "x", "--hidden", "-1"])


def test_a_fit_set_draws_its_own_members_played_from_the_evaluation_seed():
    args = es.parser().parse_args(["--fit-set", "test-small", "--sites", "5"])
    val_sites, draw = es.site_draws(args, np.random.default_rng(0))
    assert val_sites == [f"test-small:{i}" for i in range(50)]
    first, second = draw(), draw()
    assert len(set(first)) == 5 and set(first) <= set(val_sites) and first != second
    scenario, seed = es.site_episode("test-small:3")
    assert scenario == members("test-small")[3].scenario() and seed == 1_000_000
    scenario, seed = es.site_episode(17)
    assert scenario == train_member(17).scenario() and seed == 17
    with pytest.raises(SystemExit):
        es.main(["--out", "x", "--fit-set", "test-nothing"])


@pytest.mark.parametrize("hidden", [0, 2])
def test_the_trainer_is_a_function_of_its_seed(tmp_path, hidden):
    def run(out, workers):
        es.main(["--out", str(out), "--seed", "3", "--generations", "2", "--pairs", "1",
                 "--sites", "2", "--val-sites", "2", "--val-every", "1", "--max-components",
                 "16", "--cranes", "2", "4", "--workers", str(workers), "--hidden",
                 str(hidden), "--lr", "0.3"])  # fmt: skip
        return OrderScorer.load(out / "scorer.json"), (out / "log.jsonl").read_text()

    one, log = run(tmp_path / "a", 1)
    two, _ = run(tmp_path / "b", 1)
    assert np.array_equal(one.parameters(), two.parameters())
    assert one.hidden_units == hidden and one.meta["hidden"] == hidden
    rows = [json.loads(line) for line in log.splitlines()]
    assert [r["generation"] for r in rows] == [0, 1, 2]
    assert rows[0]["validation"] == 1.0  # the start is the plain rule itself
    assert all(0 < r["ratio"] <= 2 for r in rows[1:])
    assert one.meta["rank"] == "chain" and one.meta["generation"] in (0, 1, 2)
    assert one.meta["cranes"] == [2, 4] and one.meta["max_components"] == 16
    assert one.meta["features"] == N
    assert one.meta["validation_ratio"] == min(r["validation"] for r in rows)
    table = es.curves([str(tmp_path / "a"), str(tmp_path / "b")]).splitlines()
    assert table[0].endswith("| a | b |") and len(table) == 2 + 3
    assert table[2].startswith("| 0 |") and table[2].endswith("| 1.0000 | 1.0000 |")
    with pytest.raises(SystemExit, match="no such log"):
        es.curves([str(tmp_path)])


@pytest.mark.parametrize("site_seed", [11, 12, 14, 23, 31, 40])
def test_the_guarded_rule_is_the_shorter_of_its_order_and_the_planners(site_seed):
    env = multicrane.parallel_env(train_scenario(site_seed), decisions="task")
    bad = OrderScorer([1.0] + [0.0] * (len(FEATURES) - 1))  # the list order reversed
    planner = run_episode(env, TaskPrioritized(env), site_seed)["makespan"]
    alone = run_episode(env, TaskPrioritized(env, rank="chain", scorer=bad), site_seed)
    guarded = run_episode(env, TaskPrioritized(env, rank="chain", scorer=bad, guard=True),
                          site_seed, record=True)  # fmt: skip
    assert guarded["makespan"] == min(planner, alone["makespan"])  # the copies are the episode
    assert guarded["makespan"] <= planner
    if alone["makespan"] > planner:  # fell back: the planner's own episode, action for action
        plain = run_episode(env, TaskPrioritized(env), site_seed, record=True)
        assert guarded["actions"] == plain["actions"]


def test_the_guard_is_refused_on_a_site_with_events():
    env = multicrane.parallel_env("e3s2", n_cranes=2, decisions="task", events="low")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="future site events"):
        TaskPrioritized(env, rank="chain", scorer=OrderScorer.list_order(), guard=True)


def test_a_hidden_layer_scores_by_its_formula_and_starts_at_the_list_order():
    _, base = _reset("hall-4c", 4, 5)
    features = component_features(base.mode.task_book(), base.scenario)
    start = OrderScorer.list_order(3, np.random.default_rng(0))
    assert start.hidden_units == 3 and not start.hidden["out"].any()
    assert start.order(features, base.scenario) == list(base.scenario.order)  # outputs 0
    rng = np.random.default_rng(4)
    scorer = start.with_parameters(rng.standard_normal(len(start.parameters())))
    h = scorer.hidden
    by_hand = features @ scorer.weights + np.tanh(features @ h["weights"].T + h["bias"]) @ h["out"]
    assert np.allclose(scorer.scores(features), by_hand)
    assert np.array_equal(scorer.with_parameters(scorer.parameters()).parameters(),
                          scorer.parameters())  # fmt: skip
    with pytest.raises(ValueError, match="parameters expected"):
        scorer.with_parameters(scorer.parameters()[:-1])
    with pytest.raises(ValueError, match="hidden layer needs"):
        OrderScorer(scorer.weights, hidden={**h, "bias": np.zeros(2)})
    with pytest.raises(ValueError, match="hidden layer needs"):
        OrderScorer(scorer.weights, hidden={**h, "out": np.full(3, np.nan)})
    with pytest.raises(ValueError, match="missing \\['bias'\\]"):
        OrderScorer(scorer.weights, hidden={"weights": h["weights"], "out": h["out"]})
    with pytest.raises(ValueError, match="hidden layer needs"):
        OrderScorer(scorer.weights, hidden={**h, "out": 1.0})


def test_a_hidden_scorer_file_round_trips_and_pads_a_file_of_the_first_features(tmp_path):
    rng = np.random.default_rng(2)
    start = OrderScorer.list_order(2, rng)
    scorer = start.with_parameters(rng.standard_normal(len(start.parameters())), {"hidden": 2})
    scorer.save(tmp_path / "scorer.json")
    body = json.loads((tmp_path / "scorer.json").read_text())
    assert body["version"] == 2 and len(body["hidden"]["weights"]) == 2
    loaded = OrderScorer.load(tmp_path)
    assert np.array_equal(loaded.parameters(), scorer.parameters()) and loaded.meta == {"hidden": 2}
    short = {**GOOD, "version": 2, "features": FIRST, "weights": [0.5] * 16,
             "hidden": {"weights": [[1.0] * 16], "bias": [0.1], "out": [2.0]}}  # fmt: skip
    (tmp_path / "short.json").write_text(json.dumps(short))
    padded = OrderScorer.load(tmp_path / "short.json")
    assert padded.hidden["weights"].shape == (1, N) and not padded.hidden["weights"][:, 16:].any()
    _, base = _reset("hall-4c", 4, 2)
    x = component_features(base.mode.task_book(), base.scenario)[:, :16]
    assert np.allclose(padded.scores(np.pad(x, ((0, 0), (0, N - 16)))),
                       x @ np.full(16, 0.5) + 2.0 * np.tanh(x.sum(axis=1) + 0.1))  # fmt: skip


HIDDEN = {"weights": [[0.0] * N], "bias": [0.0], "out": [1.0]}


@pytest.mark.parametrize(("hidden", "words"), [
    ([1, 2], "'hidden' must hold 'weights'"),
    ({"weights": []}, "'hidden' must hold 'weights'"),
    ({**HIDDEN, "weights": [[0.0] * 3]}, "'hidden' 'weights' row 0 must be"),
    ({**HIDDEN, "weights": [[0.0] * N, "x"]}, "'hidden' 'weights' row 1 must be"),
    ({**HIDDEN, "bias": []}, "'hidden' 'bias' must be 1 finite"),
    ({k: v for k, v in HIDDEN.items() if k != "out"}, "'hidden' 'out' must be 1 finite"),
    ({**HIDDEN, "out": [float("inf")]}, "'hidden' 'out' must be 1 finite"),
])  # fmt: skip
def test_a_bad_hidden_layer_is_refused_by_name(tmp_path, hidden, words):
    path = tmp_path / "scorer.json"
    path.write_text(json.dumps({**GOOD, "version": 2, "hidden": hidden}))
    with pytest.raises(ValueError, match="order scorer") as err:
        OrderScorer.load(path)
    assert words in str(err.value) and str(path) in str(err.value)
    path.write_text(json.dumps({**GOOD, "version": 3}))
    with pytest.raises(ValueError, match="'version' must be 1 or 2"):
        OrderScorer.load(path)


def test_averaging_the_iterates_changes_what_is_validated_not_the_search(tmp_path):
    def run(out, average):
        es.main(["--out", str(out), "--seed", "5", "--generations", "3", "--pairs", "1",
                 "--sites", "2", "--val-sites", "3", "--val-every", "1", "--max-components",
                 "16", "--lr", "0.5", "--average", str(average), "--workers", "1"])  # fmt: skip
        rows = [json.loads(line) for line in (out / "log.jsonl").read_text().splitlines()]
        return OrderScorer.load(out), rows

    plain, plain_rows = run(tmp_path / "a", 0.0)
    mean, mean_rows = run(tmp_path / "b", 0.5)
    assert [r.get("ratio") for r in mean_rows] == [r.get("ratio") for r in plain_rows]
    assert mean.meta["average"] == 0.5 and plain.meta["average"] == 0.0
    assert mean.meta["validation_ratio"] == min(r["validation"] for r in mean_rows)
    if mean.meta["generation"] > 0:  # an average of the start and the iterates: not the start
        assert not np.array_equal(mean.weights, OrderScorer.list_order().weights)
    with pytest.raises(SystemExit):
        es.main(["--out", "x", "--average", "1"])
