"""Best of K learned orders: the scorer's sampled orders, the rule's search over them, the probe.

``OrderScorer.sampled_orders`` draws from the Plackett-Luce distribution of the scores;
``TaskPrioritized(samples=K)`` plays the candidates on copies of the site and keeps the
shortest; ``tools/order_sampling.py`` reports what each K would play.
"""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest
from conftest import load_tool

import multicrane
import policies
from multicrane.episodes.rollout import run_episode
from multicrane.scenario.named_sets import members, train_scenario
from multicrane.tasks.order_scorer import FEATURES, OrderScorer, component_features
from multicrane.training.seeding import evaluation_seeds
from policies.registry import policy_seed
from policies.task_planners import TaskPrioritized

N = len(FEATURES)
sampling = load_tool("order_sampling")


def _scorer(seed: int) -> OrderScorer:
    """A scorer of random weights: an order far from the list's, so candidates differ."""
    return OrderScorer(np.random.default_rng(seed).standard_normal(N))


def _features(scenario, seed):
    env = multicrane.parallel_env(scenario, decisions="task")
    env.reset(seed=seed)
    return env, component_features(env.unwrapped.mode.task_book(), scenario)


def test_sampled_orders_start_with_the_order_and_are_permutations_from_the_rng():
    scenario = train_scenario(12)
    _, features = _features(scenario, 12)
    scorer = _scorer(0)
    rng = np.random.default_rng(5)
    state = rng.bit_generator.state
    assert scorer.sampled_orders(features, scenario, 1, 0.5, rng) == [
        scorer.order(features, scenario)]  # fmt: skip
    assert rng.bit_generator.state == state  # one order draws nothing
    orders = scorer.sampled_orders(features, scenario, 6, 0.5, np.random.default_rng(5))
    assert len(orders) == 6 and orders[0] == scorer.order(features, scenario)
    for order in orders:
        assert sorted(order) == sorted(scenario.order)
    assert len({tuple(o) for o in orders}) > 1
    again = scorer.sampled_orders(features, scenario, 6, 0.5, np.random.default_rng(5))
    assert again == orders
    cold = scorer.sampled_orders(features, scenario, 4, 1e-9, np.random.default_rng(5))
    assert all(o == orders[0] for o in cold)  # no temperature: the scorer's own order


@pytest.mark.parametrize("temperature", [0.5, 1.0, 3.0])
def test_two_components_come_first_with_the_plackett_luce_probability(temperature):
    # Scores 1 and 0: their spread is 0.5, so the Gumbel scale is temperature / 2 and the
    # first component leads with probability 1 / (1 + exp(-2 / temperature)).
    scorer = OrderScorer([1.0] + [0.0] * (N - 1))
    features = np.zeros((2, N))
    features[0, 0] = 1.0
    site = SimpleNamespace(order=[0, 1])
    draws = scorer.sampled_orders(features, site, 4001, temperature, np.random.default_rng(1))
    first = np.mean([o[0] == 0 for o in draws[1:]])
    assert first == pytest.approx(1 / (1 + np.exp(-2 / temperature)), abs=0.03)


@pytest.mark.parametrize("site_seed", [11, 14, 23, 40])
def test_the_rule_with_samples_plays_the_shortest_candidate(site_seed):
    scenario = train_scenario(site_seed)
    env, features = _features(scenario, site_seed)
    scorer = _scorer(site_seed)
    seed = policy_seed(site_seed)
    orders = scorer.sampled_orders(features, scenario, 5, 0.5, np.random.default_rng(seed))
    spans = [run_episode(env, TaskPrioritized(env, rank="chain", order=o), site_seed)["makespan"]
             for o in orders]  # fmt: skip
    played = run_episode(env, TaskPrioritized(env, seed=seed, rank="chain", scorer=scorer,
                                              samples=5), site_seed, record=True)  # fmt: skip
    assert played["makespan"] == min(spans) <= spans[0]  # the copies are the episode
    best = orders[int(np.argmin(spans))]  # ties: the earlier candidate
    replay = run_episode(env, TaskPrioritized(env, rank="chain", order=best), site_seed,
                         record=True)  # fmt: skip
    assert played["actions"] == replay["actions"]
    made = policies.make("prioritized", env, seed=site_seed, rank="chain", scorer=scorer,
                         samples=5)  # fmt: skip
    assert run_episode(env, made, site_seed)["makespan"] == played["makespan"]


def test_samples_and_guard_together_are_never_longer_than_either():
    site_seed = 23
    env, _ = _features(train_scenario(site_seed), site_seed)
    scorer, seed = _scorer(3), policy_seed(site_seed)

    def span(**options):
        rule = TaskPrioritized(env, seed=seed, rank="chain", scorer=scorer, **options)
        return run_episode(env, rule, site_seed)["makespan"]

    planner = run_episode(env, TaskPrioritized(env), site_seed)["makespan"]
    both = span(samples=4, guard=True)
    assert both == min(span(samples=4), planner)


@pytest.mark.parametrize(
    "options, words",
    [
        ({"samples": 0}, "samples must be a whole number"),
        ({"samples": -2}, "samples must be a whole number"),
        ({"samples": 2.5}, "samples must be a whole number"),
        ({"samples": True}, "samples must be a whole number"),
        ({"samples": "4"}, "samples must be a whole number"),
        ({"samples": 4, "scorer": None}, "give it a scorer"),
        ({"temperature": 0}, "temperature must be a positive number, got 0"),
        ({"temperature": -1.0}, "temperature must be a positive number"),
        ({"temperature": float("nan")}, "temperature must be a positive number"),
        ({"temperature": float("inf")}, "temperature must be a positive number"),
        ({"temperature": "hot"}, "got 'hot'"),
        ({"temperature": True}, "temperature must be a positive number"),
    ],
)
def test_bad_sampling_options_are_named(options, words):
    env = multicrane.parallel_env("e3s2", decisions="task")
    options = {"scorer": OrderScorer.list_order(), **options}
    with pytest.raises(ValueError, match=words):
        TaskPrioritized(env, rank="chain", **options)


def test_samples_are_refused_on_a_site_with_events():
    env = multicrane.parallel_env("e3s2", n_cranes=2, decisions="task", events="low")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="samples plays copies.*future site events"):
        TaskPrioritized(env, rank="chain", scorer=OrderScorer.list_order(), samples=2)
    TaskPrioritized(env, rank="chain", scorer=OrderScorer.list_order(), samples=1)  # no copies


def test_the_probe_reports_what_the_policy_plays(tmp_path, capsys):
    site_seed, scorer = 14, _scorer(14)
    planner, spans = sampling.candidate_spans(site_seed, scorer, "chain", 4, 1.0)
    env = multicrane.parallel_env(train_scenario(site_seed), decisions="task")
    for k in (1, 2, 4):
        made = policies.make("prioritized", env, seed=site_seed, rank="chain", scorer=scorer,
                             samples=k, temperature=1.0)  # fmt: skip
        assert run_episode(env, made, site_seed)["makespan"] == min(spans[:k])
    assert planner == run_episode(env, TaskPrioritized(env), site_seed)["makespan"]
    scorer.save(tmp_path / "scorer.json")
    assert sampling.main(["--scorer", str(tmp_path), "--sites", "2", "--max-components", "12",
                          "--samples", "3", "--workers", "1"]) == 0  # fmt: skip
    _, with_list = sampling.candidate_spans(site_seed, scorer, "chain", 4, 1.0, ("list",), 2)
    env.reset(seed=site_seed)
    features = component_features(env.unwrapped.mode.task_book(), env.unwrapped.scenario)
    orders = scorer.sampled_orders(features, env.unwrapped.scenario, 2, 1.0,
                                   np.random.default_rng(policy_seed(site_seed)))  # fmt: skip
    assert with_list[:4] == spans and len(with_list) == 6
    for order, span in zip(orders, with_list[4:], strict=True):
        made = TaskPrioritized(env, rank="list", order=order)
        assert run_episode(env, made, site_seed)["makespan"] == span
    for bad, words in ((["--set", "test-nothing"], "test-nothing"),
                       (["--samples", "0"], "--samples must be at least 1"),
                       (["--other-ranks", "list", "--other-samples", "20"],
                        "--other-samples must be 1 to --samples .16., got 20")):
        with pytest.raises(SystemExit, match=words):
            sampling.main(["--scorer", str(tmp_path), *bad])
    with pytest.raises(SystemExit, match="nowhere.json.: no such file or run directory"):
        sampling.main(["--scorer", str(tmp_path / "nowhere.json")])
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("2 train sites, temperature 0.5: prioritized")
    assert [line.split(":")[0].strip() for line in out[1:]] == ["best of   1", "best of   2",
                                                                "best of   3"]  # fmt: skip
    assert sampling.main(["--scorer", str(tmp_path), "--sites", "2", "--max-components", "12",
                          "--samples", "3", "--workers", "1", "--other-ranks", "list", "nearest",
                          "--other-samples", "2"]) == 0  # fmt: skip
    out = capsys.readouterr().out.splitlines()
    assert out[-1].split(":")[0].strip() == "and the first 2 under list, nearest (7)"


def test_the_curve_takes_the_best_of_the_first_k_candidates():
    planner = np.array([10.0, 20.0])
    spans = np.array([[12.0, 9.0, 11.0, 8.0, 7.0], [18.0, 22.0, 17.0, 21.0, 16.0]])
    rows = sampling.curve(planner, spans)
    assert [r["samples"] for r in rows] == [1, 2, 4, 5]
    assert [r["makespan"] for r in rows] == [15.0, 13.5, 12.5, 11.5]
    assert rows[0]["longer"] == 1 and rows[0]["worst"] == pytest.approx(1.2)
    assert rows[1]["ratio"] == pytest.approx(27.0 / 30.0)
    assert rows[1]["site_ratio"] == pytest.approx((0.9 + 0.9) / 2)
    assert rows[3]["longer"] == 0 and rows[3]["worst"] == pytest.approx(0.8)


def _log_probability(scorer, features, order, scale) -> float:
    """The Plackett-Luce log-probability of ``order`` under the scores over ``scale``."""
    s, rest, total = scorer.scores(features) / scale, np.asarray(order), 0.0
    for i in range(len(rest)):
        logits = s[rest[i:]]
        total += s[rest[i]] - (np.log(np.exp(logits - logits.max()).sum()) + logits.max())
    return total


@pytest.mark.parametrize("hidden", [0, 3])
def test_the_log_probability_gradient_matches_finite_differences(hidden):
    rng = np.random.default_rng(hidden)
    features = rng.standard_normal((7, N))
    start = OrderScorer.list_order(hidden, rng)
    scorer = start.with_parameters(rng.standard_normal(len(start.parameters())))
    order, temperature = list(rng.permutation(7)), 0.7
    scale = temperature * scorer.scores(features).std()
    theta = scorer.parameters()
    grad = scorer.log_probability_gradient(features, order, temperature)
    assert grad.shape == theta.shape
    for i in rng.choice(len(theta), min(len(theta), 25), replace=False):
        step = np.zeros_like(theta)
        step[i] = 1e-6
        up = _log_probability(scorer.with_parameters(theta + step), features, order, scale)
        down = _log_probability(scorer.with_parameters(theta - step), features, order, scale)
        assert grad[i] == pytest.approx((up - down) / 2e-6, abs=1e-6)


def test_a_reinforce_generation_weighs_each_sample_by_its_ratio_against_its_sites_mean():
    es = load_tool("order_es")
    args = es.parser().parse_args(["--estimator", "reinforce", "--samples", "2",
                                   "--features", "3"])  # fmt: skip
    scorer = OrderScorer.list_order()
    trained = scorer.trainable(3)
    grads = {7: np.arange(2 * N, dtype=float).reshape(2, N), 8: np.ones((2, N))}
    ratios = {7: [0.9, 1.1], 8: [1.0, 1.0]}
    seen = []

    def mapper(_, jobs, chunksize):  # a stand-in for the episodes
        seen.extend(jobs)
        return [(ratios[job[0]], grads[job[0]]) for job in jobs]

    grad, mean = es.reinforce_step(mapper, scorer, trained, [7, 8], np.random.default_rng(0),
                                   args)  # fmt: skip
    assert [job[0] for job in seen] == [7, 8] and seen[0][3:5] == (2, 0.5)
    assert seen[0][5] != seen[1][5]  # each site its own draws
    advantages = np.array([-0.1, 0.1])  # site 8's samples tie: no signal
    spread = np.array([-0.1, 0.1, 0.0, 0.0]).std()
    by_hand = (advantages @ grads[7][:, :3]) / (4 * spread)
    assert np.allclose(grad, by_hand) and mean == pytest.approx(1.0)


def test_a_best_generation_climbs_the_log_probability_of_each_sites_shortest_samples():
    es = load_tool("order_es")
    args = es.parser().parse_args(["--estimator", "best", "--samples", "3", "--features", "3"])
    scorer = OrderScorer.list_order()
    trained = scorer.trainable(3)
    grads = {7: np.arange(3 * N, dtype=float).reshape(3, N), 8: np.ones((3, N)) * [[1], [2], [4]]}
    ratios = {7: [0.9, 1.1, 0.95], 8: [1.0, 0.8, 0.8]}  # site 8: two shortest, a tie

    def mapper(_, jobs, chunksize):  # a stand-in for the episodes
        return [(ratios[job[0]], grads[job[0]]) for job in jobs]

    grad, mean = es.reinforce_step(mapper, scorer, trained, [7, 8], np.random.default_rng(0),
                                   args)  # fmt: skip
    by_hand = -(grads[7][0, :3] + (grads[8][1, :3] + grads[8][2, :3]) / 2) / 2
    assert np.allclose(grad, by_hand)
    assert mean == pytest.approx(np.mean(ratios[7] + ratios[8]))


def test_the_reinforce_trainer_is_a_function_of_its_seed(tmp_path):
    es = load_tool("order_es")

    def run(out):
        es.main(["--out", str(out), "--seed", "2", "--estimator", "reinforce", "--samples", "3",
                 "--generations", "2", "--sites", "2", "--val-sites", "2", "--val-every", "1",
                 "--max-components", "16", "--workers", "1", "--lr", "0.3"])  # fmt: skip
        return OrderScorer.load(out), (out / "log.jsonl").read_text()

    one, log = run(tmp_path / "a")
    two, again = run(tmp_path / "b")
    rows = [json.loads(line) for line in log.splitlines()]
    timeless = [{k: v for k, v in r.items() if k != "seconds"} for r in rows]
    assert timeless == [{k: v for k, v in json.loads(line).items() if k != "seconds"}
                        for line in again.splitlines()]  # fmt: skip
    assert np.array_equal(one.parameters(), two.parameters())
    assert [r["episodes"] for r in rows] == [4, 4 + 2 * 4 + 4, 4 + 2 * (2 * 4 + 4)]
    assert one.meta["estimator"] == "reinforce" and one.meta["samples"] == 3
    with pytest.raises(SystemExit):
        es.main(["--out", str(tmp_path / "c"), "--estimator", "reinforce", "--samples", "1"])


@pytest.mark.parametrize("index, planner, searched", [(6, 49, 50), (17, 57, 61)])
def test_the_guard_plays_the_planners_plan_where_every_learned_order_is_longer(index, planner,
                                                                               searched):
    """Two test-other sites (7 and 5 cranes, a family `train` never draws) where the shipped
    seed-0 order's best of 16 is longer than the planner: with the guard the rule plays the
    planner's makespan; the figures of docs/marl-results.md's guarded search."""
    scenario, seed = members("test-other")[index].scenario(), evaluation_seeds(1)[0]
    env = multicrane.parallel_env(scenario, decisions="task")

    def span(**options):
        made = policies.make("prioritized", env, seed=seed, rank="chain",
                             scorer="order-es21-s0", samples=16, **options)  # fmt: skip
        return run_episode(env, made, seed)["makespan"]

    assert run_episode(env, TaskPrioritized(env), seed)["makespan"] == planner
    assert span() == searched
    assert span(guard=True) == planner
