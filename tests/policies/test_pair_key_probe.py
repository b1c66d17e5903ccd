"""tools/pair_key_probe.py: the learned pair key swaps the rule's ranking, and only inside."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import load_tool

import multicrane
import multicrane.tasks.priority_rule as priority_rule
from multicrane.episodes.rollout import run_episode
from multicrane.scenario.named_sets import scenario_set
from policies.task_planners import TaskPrioritized

probe = load_tool("pair_key_probe")


def _episode(site: int, rank: str = "chain") -> int:
    env = multicrane.parallel_env(scenario_set("test-small")[site][1], decisions="task")
    rule = TaskPrioritized(env, rank=rank, scorer="order-es21-s0")
    return run_episode(env, rule, 1_000_000)["makespan"]


@pytest.mark.parametrize("site", [0, 7, 11])
def test_the_start_key_ranks_every_round_as_the_chain_rank(site):
    library = priority_rule.ranked_pairs
    same: list[bool] = []
    with probe.keyed_ranking(probe.PairKey(probe.start_weights())):
        keyed = priority_rule.ranked_pairs
        assert keyed is not library

        def both(carrier, candidates, taken, rank, list_rank):
            ours = keyed(carrier, candidates, taken, rank, list_rank)
            same.append(ours == library(carrier, candidates, taken, "chain", list_rank))
            return ours

        priority_rule.ranked_pairs = both
        _episode(site)
    assert len(same) > 5 and all(same)
    assert priority_rule.ranked_pairs is library


def test_a_key_changes_the_episode_inside_and_nothing_after():
    reverse = np.zeros(len(probe.PAIR_FEATURES))
    reverse[0] = -1.0  # the learned list order backwards, chain ignored
    before = [_episode(s) for s in range(4)]
    with probe.keyed_ranking(probe.PairKey(reverse)):
        inside = [_episode(s) for s in range(4)]
    assert inside != before
    assert [_episode(s) for s in range(4)] == before


def test_the_ranking_is_restored_when_the_episode_fails():
    library = priority_rule.ranked_pairs
    with pytest.raises(RuntimeError), probe.keyed_ranking(probe.PairKey(probe.start_weights())):
        raise RuntimeError("an episode failed")
    assert priority_rule.ranked_pairs is library


def test_pair_features_name_every_column_and_scale_them():
    env = multicrane.parallel_env(scenario_set("test-small")[3][1], decisions="task")
    env.reset(seed=1_000_000)
    captured = []
    with probe.keyed_ranking(probe.PairKey(probe.start_weights())):
        keyed = priority_rule.ranked_pairs

        def spy(carrier, candidates, taken, rank, list_rank):
            rows, comp, targets, d = priority_rule.ready_pairs(carrier, candidates, taken)
            captured.append(probe.pair_features(carrier, comp, targets, d, rows, list_rank))
            return keyed(carrier, candidates, taken, rank, list_rank)

        priority_rule.ranked_pairs = spy
        rule = TaskPrioritized(env, rank="chain", scorer="order-es21-s0")
        rule({})
    features = captured[0]
    assert features.shape[1] == len(probe.PAIR_FEATURES)
    assert np.isfinite(features).all()
    assert (features[:, 0] >= 0).all() and (features[:, 0] < 1).all()  # list place
    assert (features[:, 5] == 0).all()  # nothing under way at the first decision
    assert (features[:, -1] == 0).all()  # time 0


def test_one_generation_trains_keeps_and_evaluates_a_key(tmp_path, capsys):
    out = tmp_path / "run"
    argv = ["--out", str(out), "--generations", "1", "--pairs", "1", "--sites", "2",
            "--pool", "2", "--val-sites", "2", "--val-every", "1", "--workers", "1"]  # fmt: skip
    assert probe.main(argv) == 0
    rows = [json.loads(line) for line in (out / "log.jsonl").read_text().splitlines()]
    assert [r["generation"] for r in rows] == [0, 1]
    assert "ratio" in rows[1] and rows[1]["weights"] != rows[0]["weights"]
    kept = json.loads((out / "pair_key.json").read_text())
    assert kept["validation"] == min(r["validation"] for r in rows)
    assert len(kept["weights"]) == len(probe.PAIR_FEATURES)
    assert "kept generation" in capsys.readouterr().out


@pytest.mark.parametrize("argv, says", [
    ([], "give --out"),
    (["--out", "x", "--fit-set", "no-such-set"], "no-such-set"),
    (["--evaluate", "no-such-run"], "no-such-run/pair_key.json: no such file"),
])  # fmt: skip
def test_bad_arguments_are_named(argv, says, capsys):
    with pytest.raises(SystemExit):
        probe.main(argv)
    assert says in capsys.readouterr().err
