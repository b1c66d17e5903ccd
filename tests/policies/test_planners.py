"""Classical multi-crane planners (policies.prioritized, multicrane.episodes.rollout, the
comparison tool).

The prioritized planner must complete every shipped scenario with 1-4 cranes within the step
limit without a single blocked or failed action, whatever order the cranes act in, finish the
large scenarios sooner with more cranes, and decide fast.
"""

from __future__ import annotations

import itertools
from functools import cache
from pathlib import Path

import pytest
from conftest import SCENARIOS, reach_skip

import multicrane
from multicrane.core.codes import EventType
from multicrane.episodes.rollout import evaluate, run_episode, summarise
from multicrane.scenario.loader import parse_scenario
from policies.greedy import GreedyPolicy
from policies.prioritized import PrioritizedPlanner
from policies.random_policy import RandomPolicy

ROOT = Path(__file__).resolve().parents[2]
SEEDS = (0, 1)
CRANES = (1, 2, 3, 4)
LARGE = ("frame2-3c", "hall-4c")
BAD = (EventType.BLOCKED, EventType.ILLEGAL, EventType.CLAIM_CONFLICT, EventType.LIFT_BLOCKED)


@cache
def prioritized_episode(scenario: str, n: int, seed: int) -> tuple[dict, dict]:
    """Metrics and planner counters of one prioritized episode (shared between tests)."""
    env = multicrane.parallel_env(scenario, n_cranes=n)
    planner = PrioritizedPlanner(env)
    return run_episode(env, planner, seed=seed), dict(planner.stats)


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_prioritized_completes_every_scenario_without_blocked_moves(scenario):
    for n, seed in itertools.product(CRANES, SEEDS):
        if reach_skip(scenario, n):
            continue  # crane reach: this tower-crane scenario needs more of its cranes
        m, stats = prioritized_episode(scenario, n, seed)
        where = f"{scenario} with {n} cranes, seed {seed}"
        assert m["success"], f"{where}: not completed in {m['steps']} steps"
        assert m["makespan"] == m["steps"]
        for kind in BAD:
            assert m["events"][kind.name] == 0, f"{where}: {m['events'][kind.name]} {kind.name}"
        assert m["blocked_moves"] == 0 and m["failed_actions"] == 0
        # Every planned action was legal, and the site never left the plans.
        assert stats["fallbacks"] == 0, where
        assert stats["replans"] == 0, where


@pytest.mark.parametrize("scenario", LARGE)
def test_more_cranes_finish_the_large_scenarios_sooner(scenario):
    for seed in SEEDS:
        one = prioritized_episode(scenario, 1, seed)[0]["makespan"]
        spans = [prioritized_episode(scenario, n, seed)[0]["makespan"] for n in CRANES]
        assert all(s < one for s in spans[1:]), f"{scenario}, seed {seed}: makespans {spans}"
        assert spans[3] < one / 2.5, f"{scenario}, seed {seed}: 4 cranes too slow: {spans}"


# Two beams on one row at z = 4, resting on pre-built columns: b's shortest plan would follow
# one cell behind a, entering each cell in the step a leaves it.
CONVOY = """
format = 1
name = "convoy"
[site]
size = [16, 6, 6]
construction_area = { min = [7, 0], max = [15, 5] }
foundations = [[8, 2], [11, 2]]
[rules]
cranes = 2
step_limit = 50
interchangeable_targets = false
order = ["a", "b", "p1", "p2"]
[[components]]
id = "a"
kind = "beam"
length = 3
initial = [[4, 3, 1], [6, 3, 1]]
target = [[10, 3, 4], [12, 3, 4]]
supports = ["p2"]
[[components]]
id = "b"
kind = "beam"
length = 3
initial = [[1, 3, 1], [3, 3, 1]]
target = [[7, 3, 4], [9, 3, 4]]
supports = ["p1"]
[[components]]
id = "p1"
kind = "column"
length = 4
prebuilt = true
target = [[8, 2, 1], [8, 2, 4]]
[[components]]
id = "p2"
kind = "column"
length = 4
prebuilt = true
target = [[11, 2, 1], [11, 2, 4]]
"""


def play_in_every_order(env, seed: int) -> int:
    """Play a prioritized episode; at every step, check that each order in which the cranes
    may act leaves every planned action unblocked, that no cell passes from one component
    to another within a step (no following, no swaps), and that the planner never had to
    override its plan. Returns the makespan."""
    planner = PrioritizedPlanner(env)
    obs, _ = env.reset(seed=seed)
    sim = env.sim
    orders = list(itertools.permutations(range(sim.n_cranes)))

    def owners() -> dict[int, int]:
        return {j: c for c in range(sim.site.n_components) for j in sim.state.cells[c]}

    before = owners()
    while env.agents:
        actions = planner(obs)
        joint = [actions[a] for a in env.possible_agents]
        snap = sim.snapshot()
        for order in orders:
            out = sim.step(joint, list(order))
            bad = [e for e in out.events if e.type in BAD]
            assert not bad, f"step {sim.state.step_count}, order {order}: {bad}"
            sim.restore(snap)
        obs, *_ = env.step(actions)
        after = owners()
        handed = {j: (before[j], c) for j, c in after.items() if before.get(j, c) != c}
        assert not handed, f"step {sim.state.step_count}: cells changed hands {handed}"
        before = after
    assert sim.done
    # Every planned action was legal when chosen (no fallback to waiting) and the site never
    # left the plans (no replanning).
    assert planner.stats["fallbacks"] == 0 and planner.stats["replans"] == 0, planner.stats
    return sim.state.step_count


@pytest.mark.parametrize(("scenario", "seed"), [("frame2-3c", 0), ("hall-4c", 1)])
def test_plans_hold_in_every_action_order(scenario, seed):
    play_in_every_order(multicrane.parallel_env(scenario, n_cranes=4), seed)


def test_no_following_into_a_cell_vacated_in_the_same_step():
    scenario = parse_scenario(CONVOY, "convoy.toml")
    # a: claim (1) + 6 moves, arrives at t = 7; b keeps a cell between them and arrives at
    # t = 8 (following would arrive at 7); then the two assemble steps.
    assert play_in_every_order(multicrane.parallel_env(scenario), seed=0) == 9


def test_planning_time_per_decision_on_the_largest_scenario():
    m, _ = prioritized_episode("hall-4c", 4, 0)
    # Measured about 0.4 ms per joint decision on a shared 2-core machine; the bound is loose.
    assert m["plan_ms_per_step"] < 50.0, m["plan_ms_per_step"]


def test_planner_reuse_recall_and_mode_checks():
    env = multicrane.parallel_env("e3s2", n_cranes=2)
    planner = PrioritizedPlanner(env)
    spans = []
    for seed in (3, 3):  # the same planner over two episodes: plans are forgotten at reset
        obs, _ = env.reset(seed=seed)
        while env.agents:
            actions = planner(obs)
            assert planner(obs) == actions  # a second call at the same step changes nothing
            obs, *_ = env.step(actions)
        assert env.sim.done
        spans.append(env.sim.state.step_count)
    assert spans[0] == spans[1]
    with pytest.raises(ValueError, match="auto"):
        PrioritizedPlanner(multicrane.parallel_env("e3s2", auto=True))
    with pytest.raises(ValueError, match="rank"):
        PrioritizedPlanner(env, rank="best")
    nearest = run_episode(env, PrioritizedPlanner(env, rank="nearest"), seed=0)
    assert nearest["success"] and nearest["blocked_moves"] == 0


def test_metrics_definitions_and_summarise():
    env = multicrane.parallel_env("e3s2", n_cranes=3)
    m = run_episode(env, GreedyPolicy(env, seed=0), seed=0)
    assert m["success"] and m["makespan"] == m["steps"] > 0
    assert m["crane_steps"] + m["idle_crane_steps"] == 3 * m["steps"]
    assert 0 < m["utilisation"] <= 1 and m["idle_crane_steps"] > 0
    assert m["blocked_moves"] == m["events"]["BLOCKED"]
    assert m["events"]["ASSEMBLED"] == env.sim.k
    assert m["plan_ms_per_crane"] == pytest.approx(m["plan_ms_per_step"] / 3)
    assert m["plan_ms_max"] >= m["plan_ms_per_step"]

    # One crane that never idles between components: busy every step but the gaps.
    env1 = multicrane.parallel_env("e1s1", n_cranes=1)
    m1 = run_episode(env1, PrioritizedPlanner(env1), seed=0)
    assert m1["crane_steps"] == m1["steps"]  # it claims the next one right after assembling

    # Random runs to the step limit: no makespan.
    r = run_episode(env1, RandomPolicy(seed=0), seed=0)
    assert not r["success"] and r["makespan"] is None and r["steps"] == env1.step_limit
    agg = summarise([m1, r])
    assert agg["episodes"] == 2 and agg["success_rate"] == 0.5
    assert agg["makespan_mean"] == m1["makespan"] and agg["makespan_sem"] is None
    assert agg["steps_mean"] == (m1["steps"] + r["steps"]) / 2
    none = summarise([r])
    assert none["success_rate"] == 0 and none["makespan_mean"] is None
    with pytest.raises(ValueError):
        summarise([])

    env2 = multicrane.parallel_env("e2s1", n_cranes=2)
    results, summary = evaluate(env2, lambda env, seed: PrioritizedPlanner(env), range(2))
    assert [x["seed"] for x in results] == [0, 1] and summary["success_rate"] == 1.0


def test_compare_tool_writes_a_markdown_page(tmp_path):
    from multicrane.cli import main

    out = tmp_path / "planners.md"
    argv = ["compare-planners", "--scenarios", "e1s1", "hall-4c", "--cranes", "1", "4"]
    argv += ["--seeds", "1", "--random-seeds", "1", "--markdown", "--output", str(out)]
    assert main(argv) == 0
    page = out.read_text()
    assert page.startswith("# Classical multi-crane planners")
    assert "| e1s1 | 1 |" in page and "| hall-4c | 4 |" in page
    assert "## Planning time per decision" in page and "## Observations" in page
    assert "ms per joint decision" in page and "opt+2/comp" in page
    # the lower bound and its gaps, and the task-mode section
    assert "## Lower bound and gaps" in page and "## Task mode (large scenarios)" in page
    assert "vs. the lower bound" in page


def test_report_gaps_are_never_negative_and_task_mode_matches():
    """The report's bound and gaps: a bound over a makespan would be a bug in one of them."""
    import policies
    from multicrane.reports.planners import Setup, run_all

    setup = Setup(["e3s2", "hall-4c"], [1, 3], ["greedy", "prioritized"], seeds=2,
                  random_seeds=0, optimal=False, bound_time_limit=20.0)  # fmt: skip
    makers = {name: policies.factory(name, paper=False) for name in setup.policies}
    res = run_all(setup, makers)
    assert set(res.bounds) == {(s, n) for s in setup.scenarios for n in setup.cranes}
    for key, bound in res.bounds.items():
        assert len(bound.values) == 2 and all(v > 0 for v in bound.values)
        for policy in setup.policies:
            gaps = res.gaps(*key, policy)
            assert len(gaps) == 2 and min(gaps) >= 0.0, (key, policy, gaps)
    assert set(res.task) == {("hall-4c", 1), ("hall-4c", 3)}
    for cost in res.task.values():
        assert cost.same_as_motion and cost.rounds >= 1 and cost.ms_per_round > 0
