"""The report pages' tables (``multicrane.tables``) and the planner page built from them."""

from __future__ import annotations

from multicrane.reports.planners import Cell, Results, Setup
from multicrane.reports.planners_notes import observations, precedence_note
from multicrane.reports.planners_page import TABLES, markdown_page, text_report
from multicrane.tables import markdown_table, text_table

HEAD = ["name", "kind", "n"]
ROWS = [["alpha", "x", "1"], ["b", "long kind", "22"]]


def test_markdown_table_aligns_by_letter_and_the_rest_right():
    assert markdown_table(HEAD, ROWS) == [
        "| name | kind | n |",
        "|---|---:|---:|",
        "| alpha | x | 1 |",
        "| b | long kind | 22 |",
    ]
    assert markdown_table(HEAD, ROWS, align="ll")[1] == "|---|---|---:|"
    assert markdown_table(HEAD, ROWS, align="")[1] == "|---:|---:|---:|"
    assert markdown_table(HEAD, [], align="lrl") == ["| name | kind | n |", "|---|---:|---|"]


def test_text_table_pads_each_column_to_its_widest_cell():
    assert text_table(HEAD, ROWS).splitlines() == [
        "name        kind   n",
        "alpha          x   1",
        "b      long kind  22",
    ]
    assert text_table(HEAD, ROWS, align="").splitlines()[1] == "alpha          x   1"
    assert text_table(HEAD, ROWS, align="lll").splitlines()[2] == "b      long kind  22"
    assert text_table(HEAD, []) == "name  kind  n"


def _cell(makespans: list[int]) -> Cell:
    summary = {
        "success_rate": 1.0, "makespan_mean": sum(makespans) / len(makespans),
        "makespan_min": min(makespans), "makespan_max": max(makespans),
        "blocked_moves_mean": 0.0, "utilisation_mean": 0.5,
        "plan_ms_per_step": 0.5, "plan_ms_per_crane": 0.25, "plan_ms_max": 2.0,
    }  # fmt: skip
    results = [{"seed": s, "success": True, "makespan": m, "steps": m, "blocked_moves": 0,
                "failed_actions": 0} for s, m in enumerate(makespans)]  # fmt: skip
    return Cell(results, summary, seconds=0.1, stats={"searches": 3})


def _results(spans: dict[int, list[int]]) -> Results:
    setup = Setup(["e1s1"], sorted(spans), ["prioritized"], seeds=2, random_seeds=0)
    cells = {("e1s1", n, "prioritized"): _cell(m) for n, m in spans.items()}
    return Results(setup, cells, {}, wall=1.0)


def test_notes_only_about_what_was_run():
    flat = _results({1: [20, 20], 2: [20, 20]})
    assert precedence_note(flat).startswith("**Precedence-bound scenarios.** In e1s1 more")
    faster = _results({1: [20, 20], 2: [12, 14]})
    assert precedence_note(faster) is None
    notes = observations(faster)
    assert notes[0].startswith("**Prioritized** completes every episode in 2 of 2")
    assert not any(n.startswith(("**Random**", "**Greedy**", "**One crane")) for n in notes)
    assert "6 searches" in notes[-1]  # summed over the two settings


def test_page_shows_a_table_section_only_when_it_has_rows():
    res = _results({1: [20, 20], 2: [12, 14]})
    page = markdown_page(res, "multicrane compare-planners")
    assert "| e1s1 | 2 |  |  |  | 13.0 (12-14) | 2/2 | 0.0 |" in page
    for table in TABLES:  # e1s1 is not a large scenario and no bound or task cost ran
        assert f"## {table.title}" not in page
    assert page.index("## Observations") < page.index("## Limitations")
    assert text_report(res).endswith("Total wall time 1.0 s.\n")
