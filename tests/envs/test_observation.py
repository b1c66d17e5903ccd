"""The incrementally kept observation equals a from-scratch computation from the grid."""

from __future__ import annotations

import numpy as np
import pytest

import multicrane
from multicrane.core.codes import Status
from multicrane.envs.observation import (
    AT_TARGET,
    COMPONENT_FEATURES,
    FREE_TARGET,
    IN_TRANSIT,
    INITIAL,
    MINE,
    MY_TARGETS,
    OBSTACLE,
    OVER_LIMIT,
    READY,
)
from multicrane.sim.simulator import Simulator


def reference_planes(sim: Simulator, ready: list[int], crane: int) -> np.ndarray:
    """Every channel computed directly from the occupancy grid, cell by cell."""
    X, Y, H = sim.scenario.size
    planes = np.zeros((X, Y, 9), dtype=np.float32)
    grid = sim.state.occ.reshape(sim.site.shape)[1 : X + 1, 1 : Y + 1, :]

    def top(channel: int, cells_xyz) -> None:
        for x, y, z in cells_xyz:
            planes[x, y, channel] = max(planes[x, y, channel], z / H)

    obstacle = [(x, y, z) for x, y, z in zip(*np.nonzero(grid == -1), strict=True) if 1 <= z <= H]
    top(OBSTACLE, obstacle)
    for c in range(sim.site.n_components):
        cells = [sim.site.cell(j) for j in sim.state.cells[c]]
        status = sim.state.status[c]
        if status == Status.INITIAL:
            top(INITIAL, cells)
            if c in ready:
                top(READY, cells)
        elif status == Status.IN_TRANSIT:
            top(IN_TRANSIT, cells)
            if sim.state.moves[c] > sim.site.move_limit:
                top(OVER_LIMIT, cells)
        else:
            top(AT_TARGET, cells)
    for t in range(sim.site.n_components):
        if sim.state.filled_by[t] < 0:
            top(FREE_TARGET, [sim.site.cell(j) for j in sim.site.target_cells[t]])
    held = sim.state.held[crane]
    if held >= 0:
        top(MINE, [sim.site.cell(j) for j in sim.state.cells[held]])
        for t in sim.ready_targets(held):
            top(MY_TARGETS, [sim.site.cell(j) for j in sim.site.target_cells[t]])
    return planes


@pytest.mark.parametrize(
    ("scenario", "cranes", "auto"),
    [("e1s4", 1, True), ("e3s2", 2, False), ("e4s4", 3, False), ("frame2-3c", 3, False)],
)
def test_incremental_observation_matches_reference(scenario, cranes, auto):
    env = multicrane.parallel_env(scenario, n_cranes=cranes, auto=auto)
    obs, _ = env.reset(seed=3)
    rng = np.random.default_rng(3)
    layout = env.observation_layout
    sim = env.sim
    checked = 0
    for step in range(400):
        if step % 7 == 0 or not env.agents:
            ready = sorted(
                c
                for c in range(sim.site.n_components)
                if obs["crane_0"]["observation"][layout.components].reshape(-1, COMPONENT_FEATURES)[
                    c, 4
                ]
            )
            for i, agent in enumerate(env.possible_agents):
                parts = layout.split(obs[agent]["observation"])
                np.testing.assert_allclose(
                    parts["planes"], reference_planes(sim, ready, i), atol=1e-6
                )
                table = parts["components"]
                np.testing.assert_array_equal(table[:, :4].argmax(axis=1), sim.state.status)
                assert table[:, 6].sum() == (sim.state.held[i] >= 0)
            checked += 1
        if not env.agents:
            obs, _ = env.reset()
            continue
        actions = {}
        for agent in env.agents:
            legal = np.flatnonzero(obs[agent]["action_mask"])
            actions[agent] = int(legal[rng.integers(len(legal))])
        obs, *_ = env.step(actions)
    assert checked > 50


def test_ready_marks_match_claimable_components():
    env = multicrane.parallel_env("e3s2", n_cranes=2)
    obs, _ = env.reset(seed=0)
    table = env.observation_layout.split(obs["crane_0"]["observation"])["components"]
    assert np.flatnonzero(table[:, 4]).tolist() == env.sim.claimable_components()



def test_a_component_taking_a_cell_another_left_in_the_same_step_is_observed():
    """Two columns carried side by side, the first following the second into the cells it
    leaves in the same step (found by the vector env's differential test): every old cell is
    cleared before a new one is painted, so the planes equal those computed from the grid."""
    from test_rules import micro_site

    from multicrane.scenario.loader import parse_scenario

    scenario = parse_scenario(micro_site(cranes=2), source="micro")
    followed = 0
    for seed in range(20):  # the cranes act in a random order each step
        env = multicrane.parallel_env(scenario)
        env.reset(seed=seed)
        env.step({"crane_0": 8, "crane_1": 9})  # crane 0 lifts c1, crane 1 lifts c2 beside it
        x_before = env.sim.site.cell(env.sim.state.cells[0][0])[0]
        obs, *_ = env.step({"crane_0": 2, "crane_1": 2})  # both x+1: c1 into c2's cells
        if env.sim.site.cell(env.sim.state.cells[0][0])[0] == x_before + 1:
            followed += 1
            layout = env.observation_layout
            for i, agent in enumerate(env.possible_agents):
                planes = layout.split(obs[agent]["observation"])["planes"]
                np.testing.assert_allclose(planes, reference_planes(env.sim, [], i), atol=1e-6)
    assert followed > 0
