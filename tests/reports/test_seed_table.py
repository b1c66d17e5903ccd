"""multicrane seed-table: pooling training seeds, the intervals, the comparison with a planner."""

from __future__ import annotations

import json

import pytest

from multicrane.cli import main
from multicrane.reports.seed_table import entries, episode_ratio, markdown_table, shorter_share
from multicrane.stats import ci95


def _row(policy, spans, seeds=(10, 11, 12)):
    return {
        "policy": policy,
        "summary": {},
        "episodes": [
            {
                "scenario": "e2s2",
                "n_cranes": 2,
                "seed": s,
                "success": m is not None,
                "makespan": m if m is not None else 999,
            }  # fmt: skip
            for s, m in zip(seeds, spans, strict=True)
        ],
    }


ROWS = [
    _row("runs/hall-s0", [100, 110, 120]),
    _row("runs/hall-s1", [90, None, 100]),
    _row("prioritized", [95, 105, 100]),
    _row("greedy", [120, 130, 140]),
]


def test_run_directories_of_one_prefix_pool_into_one_learned_entry():
    got = entries(ROWS)
    assert [e.name for e in got] == ["hall", "prioritized", "greedy"]
    hall = got[0]
    assert hall.learned and hall.seeds == ["runs/hall-s0", "runs/hall-s1"]
    assert hall.per_seed == [110.0, 95.0]  # seed 1's unfinished episode is left out
    assert hall.mean == pytest.approx(102.5)
    assert hall.ci == pytest.approx(ci95([110.0, 95.0]))  # over seeds, not episodes
    assert (hall.finished, hall.episodes, hall.seeds_all_finished) == (5, 6, 1)


def test_a_search_guided_by_run_directories_pools_by_its_whole_spec():
    rows = [
        _row("lookahead:candidates=8,guide=runs/hall-s0", [100, 110, 120]),
        _row("lookahead:candidates=8,guide=runs/hall-s1", [90, 100, 110]),
        _row("lookahead:candidates=4,guide=runs/hall-s0", [1, 2, 3]),
        _row("lookahead:candidates=20", [4, 5, 6]),
    ]
    eight, four, planner = entries(rows)
    assert eight.name == "lookahead:candidates=8,guide=runs/hall" and len(eight.seeds) == 2
    assert four.name == "lookahead:candidates=4,guide=runs/hall" and len(four.seeds) == 1
    assert planner.name == "lookahead:candidates=20" and not planner.learned


def test_evaluate_labels_of_run_directories_pool_by_algorithm_and_prefix():
    rows = [
        _row("maskable_ppo (hall-s0)", [100, 110, 120]),
        _row("maskable_ppo (hall-s1)", [90, 100, 110]),
        _row("maskable_ppo (other)", [1, 2, 3]),
    ]
    pooled, single = entries(rows)
    assert pooled.name == "maskable_ppo (hall)" and pooled.learned and len(pooled.seeds) == 2
    assert pooled.samples == [110.0, 100.0]
    assert single.name == "maskable_ppo (other)" and single.learned
    assert single.samples == [1.0, 2.0, 3.0]  # one training seed: the interval is over episodes


def test_a_planner_row_is_over_its_episodes():
    planner = entries(ROWS)[1]
    assert not planner.learned
    assert planner.mean == pytest.approx(100.0)
    assert planner.ci == pytest.approx(ci95([95, 105, 100]))


@pytest.mark.parametrize(
    "learned, base, expected",
    [
        ([[100, 110, 120], [90, None, 100]], [95, 105, 100], (1, 1, 5)),
        ([[1, 1, 1]], [None, None, None], (0, 0, 0)),
        ([[5, 6, 7]], [5, 6, 7], (0, 3, 3)),
    ],
)
def test_shorter_share_counts_pairs_where_both_finished(learned, base, expected):
    rows = [_row(f"x-s{i}", spans) for i, spans in enumerate(learned)] + [_row("p", base)]
    learned_entry, planner = entries(rows)
    assert shorter_share(learned_entry, planner) == expected


def test_episode_ratio_weighs_every_episode_alike():
    small_and_big = [_row("x-s0", [20, 200], seeds=(1, 2)), _row("p", [10, 400], seeds=(1, 2))]
    learned, planner = entries(small_and_big)
    assert episode_ratio(learned, planner) == pytest.approx((2.0 + 0.5) / 2)
    assert learned.mean / planner.mean == pytest.approx(220 / 410)  # the big site dominates


def test_rows_of_different_episodes_are_refused():
    rows = [_row("a", [1, 2, 3]), _row("b", [1, 2, 3], seeds=(10, 11, 13))]
    with pytest.raises(ValueError, match="not the same episodes"):
        entries(rows)


def test_markdown_table_has_the_ratio_the_share_and_the_gap_to_the_bound():
    table = markdown_table(entries(ROWS), "prioritized", bounds=[80, 80, 80])
    lines = table.splitlines()
    assert lines[0].startswith("| policy |") and "gap to bound (80.0)" in lines[0]
    hall = lines[2]
    assert "hall (2 seeds)" in hall and "5/6" in hall and "1/2" in hall
    ratio = (100 / 95 + 110 / 105 + 120 / 100 + 90 / 95 + 100 / 100) / 5
    assert "110.0, 95.0" in hall and f"1.025 ({ratio:.3f})" in hall and "1/5 (1 equal)" in hall
    assert "+28.1 %" in hall  # (102.5 - 80) / 80
    assert "+25.0 %" in lines[3]  # the planner: 100 against 80


def test_command_prints_the_table_without_bounds(tmp_path, capsys):
    path = tmp_path / "ev.json"
    path.write_text(json.dumps(ROWS))
    out = tmp_path / "table.md"
    assert main(["seed-table", str(path), "--bound-time", "0", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "e2s2, 2 cranes, 3 episodes (reset seeds 10..12)" in printed
    assert out.read_text().startswith("| policy |")


def test_command_bounds_every_episode(tmp_path, capsys):
    rows = [_row("prioritized", [40, 41], seeds=(0, 1)), _row("r-s0", [50, 45], seeds=(0, 1))]
    path = tmp_path / "ev.json"
    path.write_text(json.dumps(rows))
    out = tmp_path / "t.md"
    assert main(["seed-table", str(path), "--bound-time", "5", "--out", str(out)]) == 0
    bounds = json.loads(out.with_suffix(".bounds.json").read_text())
    assert bounds["seeds"] == [0, 1] and all(b > 0 for b in bounds["bounds"])
    assert "gap to bound" in capsys.readouterr().out
    # Reused: the same table without solving again; refused for other episodes.
    again = tmp_path / "again.md"
    saved = out.with_suffix(".bounds.json")
    assert main(["seed-table", str(path), "--bounds", str(saved), "--out", str(again)]) == 0
    assert again.read_text() == out.read_text()
    other = tmp_path / "other.json"
    other.write_text(json.dumps([_row("prioritized", [40, 41], seeds=(0, 2))]))
    assert main(["seed-table", str(other), "--bounds", str(saved)]) != 0
    assert "bounds of other episodes" in capsys.readouterr().err
    # Two CP-SAT workers prove the same bounds here (these relaxations are solved exactly).
    two = tmp_path / "two.md"
    assert main(["seed-table", str(path), "--bound-time", "5", "--bound-workers", "2",
                 "--out", str(two)]) == 0  # fmt: skip
    assert json.loads(two.with_suffix(".bounds.json").read_text())["bounds"] == bounds["bounds"]
    assert main(["seed-table", str(path), "--bound-workers", "0"]) != 0
    assert "--bound-workers 0: must be at least 1" in capsys.readouterr().err


@pytest.mark.parametrize(
    "text, message",
    [("{not json", "not JSON"), ('[{"policy": "a"}]', "missing 'episodes'"), ("[]", "no policies")],
)
def test_bad_files_get_a_clear_error(tmp_path, capsys, text, message):
    path = tmp_path / "ev.json"
    path.write_text(text)
    assert main(["seed-table", str(path), "--bound-time", "0"]) != 0
    err = capsys.readouterr().err
    assert str(path) in err and message in err


def test_a_missing_file_is_named(tmp_path, capsys):
    assert main(["seed-table", str(tmp_path / "nope.json")]) != 0
    assert "nope.json" in capsys.readouterr().err


def test_command_bounds_the_sites_of_a_scenario_set(tmp_path, capsys):
    from multicrane.scenario.named_sets import resolve_set

    sites = [(name.split("/")[-1], s.cranes) for name, s in resolve_set("set:train:0-2")]
    rows = [
        {"policy": policy, "summary": {}, "episodes": [
            {"scenario": n, "n_cranes": c, "seed": 7, "success": True, "makespan": m}
            for (n, c), m in zip(sites, spans, strict=True)]}
        for policy, spans in (("prioritized", [300, 300]), ("r-s0", [310, 290]))
    ]  # fmt: skip
    path = tmp_path / "ev.json"
    path.write_text(json.dumps(rows))
    out = tmp_path / "t.md"
    argv = ["seed-table", str(path), "--sites", "set:train:0-2", "--bound-time", "2",
            "--out", str(out)]  # fmt: skip
    assert main(argv) == 0
    assert "set:train:0-2: 2 episodes on 2 sites" in capsys.readouterr().out
    assert len(json.loads(out.with_suffix(".bounds.json").read_text())["bounds"]) == 2
    assert "1/2" in out.read_text()  # shorter than the planner on one site of two
