"""The task book's static path lengths (``TaskBook.static_len``): one row for every crane
without reach zones, each crane inside its own zone with them; checked against the
per-crane, per-task reference loop over ``StaticPaths.length``."""

from __future__ import annotations

import numpy as np
import pytest

import multicrane
from multicrane.scenario.named_sets import members
from multicrane.sim.shortest_paths import UNREACHABLE
from multicrane.tasks.goal_poses import GoalPoses, goal_position
from multicrane.tasks.static_paths import StaticPaths, compact


def _reference(env) -> np.ndarray:
    sim, book = env.sim, env.mode.task_book()
    paths = StaticPaths(sim)  # a fresh cache: nothing carried over from the book's
    zones = sim.site.reach is not None
    out = np.full((sim.n_cranes, len(book.tasks)), UNREACHABLE, dtype=np.int64)
    for p, (c, t) in enumerate(book.tasks.pairs):
        for k in range(sim.n_cranes):
            if zones and not book.carrier.reaches_pair(k, c, t):
                continue
            out[k, p] = paths.length(sim.state.pickup[c], t, k if zones else -1)
    return out


@pytest.mark.parametrize(
    "scenario,cranes", [("hall-4c", 4), ("frame2-3c", 3), ("e3s2", 2), ("towers-3c", 3)]
)
def test_static_lengths_match_the_reference_loop(scenario, cranes):
    env = multicrane.parallel_env(scenario, n_cranes=cranes, decisions="task")
    for seed in (0, 1, 7):
        env.reset(seed=seed)
        book = env.mode.task_book()
        expected = _reference(env)
        assert np.array_equal(book.static_len, expected)
        assert np.array_equal(book.static_ok, expected != UNREACHABLE)
        assert book.static_ok.any()
    if env.sim.site.reach is not None:  # the zones make the rows differ
        assert not all(np.array_equal(book.static_len[0], row) for row in book.static_len)


def test_the_reset_timing_tool_runs(capsys):
    """``tools/task_reset_speed.py`` (the figure of docs/performance.md) on a small site."""
    from conftest import load_tool

    load_tool("task_reset_speed").main("e3s2", 2, 3)
    out = capsys.readouterr().out
    assert out.startswith("e3s2, 2 cranes: ") and out.rstrip().endswith("3 resets")


def test_the_round_split_tool_times_every_part_and_puts_the_methods_back(capsys):
    """``tools/round_split.py`` (docs/performance.md, "Fourth pass") on a small site: every
    part ran, the simulated steps inside the env's step; the timed methods are the originals
    again afterwards."""
    from conftest import load_tool

    from multicrane.envs.task_mode import TaskMode

    tool = load_tool("round_split")
    step = TaskMode.step
    parts = {label.strip(): (us, n) for label, us, n in tool.split("e3s2", 2, 40, "random")}
    assert TaskMode.step is step
    assert all(us > 0 and n > 0 for us, n in parts.values())
    assert parts["task mode: simulated steps"][0] < parts["env.step"][0]
    assert parts["Simulator.step"][1] >= 1  # at least one simulated step a round
    tool.main(["e3s2", "--cranes", "2", "--rounds", "20"])
    assert "planner's call" in capsys.readouterr().out


def test_the_first_decision_timing_tool_runs(capsys):
    """``tools/first_decision.py`` (docs/performance.md, "Planning on large sites") on a
    held-out member with the guarded search, and an unknown member named."""
    from conftest import load_tool

    tool = load_tool("first_decision")
    name = members("test-other")[0].name
    tool.main([name, "prioritized:rank=chain,samples=2,guard=true,scorer=order-es21-s0"])
    out = capsys.readouterr().out
    assert out.startswith(f"{name}: reset ") and "first decision" in out and "MiB" in out
    with pytest.raises(SystemExit, match="no such member of test-other"):
        tool.main(["test-other/nowhere-s1", "prioritized"])


@pytest.mark.parametrize("scenario", ["hall-4c", "frame2-3c", "e4s4", "precast-house"])
def test_the_cached_goal_poses_are_goal_position(scenario):
    """``GoalPoses`` (the carrier's and the static paths' cache) answers ``goal_position``
    for every component's shape and target, a pose or None, asked twice."""
    env = multicrane.parallel_env(scenario, decisions="task")
    env.reset(seed=3)
    site, state = env.sim.site, env.sim.state
    poses = GoalPoses(site)
    found = missing = 0
    for _ in range(2):
        for pick in state.pickup:
            if not pick:
                continue
            rel = tuple(j - pick[0] for j in pick)
            for t in range(len(site.target_cells)):
                expected = goal_position(rel, site.target_cells[t])
                assert poses[rel, t] == expected
                found += expected is not None
                missing += expected is None
    assert found and missing  # both answers were checked


@pytest.mark.parametrize("scenario", ["hall-4c", "e4s4", "precast-house", "towers-3c"])
def test_pair_distances_match_the_loop_over_compatible_targets(scenario):
    """``GoalPoses.pair_distances`` (by shape, in numpy) against the loop it replaced: per
    component with a pick-up pose and compatible target with a goal pose, the Manhattan
    distance between the two poses' first cells; -1 everywhere else. Drawn yards, a pick-up
    pose taken away (a pre-built component has none) and one cut to its first cell (a shape
    that covers none of its compatible targets)."""
    env = multicrane.parallel_env(scenario, decisions="task")
    poses = None
    for seed in (0, 5):
        env.reset(seed=seed)
        site = env.sim.site
        pickup = [list(p) for p in env.sim.state.pickup]
        pickup[0] = []
        cut = next(c for c, pick in enumerate(pickup) if len(pick) > 1)
        pickup[cut] = pickup[cut][:1]
        poses = poses or GoalPoses(site)  # kept across episodes, as the carrier's
        expected = np.full((site.n_components, len(site.target_cells)), -1, dtype=np.int64)
        for c, pick in enumerate(pickup):
            rel = tuple(j - pick[0] for j in pick) if pick else ()
            for t in site.compatible[c] if pick else ():
                goal = goal_position(rel, site.target_cells[t])
                if goal is not None:
                    a, b = site.cell(pick[0]), site.cell(goal)
                    expected[c, t] = sum(abs(x - y) for x, y in zip(a, b, strict=True))
        got = poses.pair_distances(pickup)
        assert got.dtype == np.int64 and np.array_equal(got, expected)
        assert (expected >= 0).sum() > 1 and (expected[0] == -1).all()
        assert site.compatible[cut] and (expected[cut] == -1).all()


@pytest.mark.parametrize(("longest", "dtype"), [(7, np.int16), (32767, np.int16),
                                                (32768, np.int32), (10**6, np.int32)])  # fmt: skip
def test_distance_fields_are_kept_small_only_when_every_distance_fits(longest, dtype):
    dist = np.array([-1, 0, 3, longest], dtype=np.int32)
    kept = compact(dist)
    assert kept.dtype == dtype and kept.tolist() == dist.tolist()
