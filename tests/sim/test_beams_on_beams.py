"""Beams resting on beams: a secondary beam on two primary beams, table-driven.

The site (12 x 10 x 6): four columns standing on foundations, two primary beams along x on
them (``b1`` on ``c1`` and ``c2``, ``b2`` on ``c3`` and ``c4``) and a secondary beam ``s``
along y between the two primaries, resting on both (``supports = ["b1", "b2"]``). The kind
table's beam rests on columns and beams; the simulator's readiness (a target is ready when
its supports are assembled) works through each target's support list, whatever their kind.
"""

from __future__ import annotations

import numpy as np
import pytest

import multicrane
from multicrane.core.codes import CLAIM_BASE, EventType, Status
from multicrane.episodes.rollout import run_episode
from multicrane.scenario.loader import parse_scenario
from multicrane.sim.simulator import Simulator
from policies.prioritized import PrioritizedPlanner

C1, C2, C3, C4, B1, B2, S = range(7)
NAMES = ("c1", "c2", "c3", "c4", "b1", "b2", "s")


def site(prebuilt: tuple[str, ...] = (), cranes: int = 1) -> str:
    """The site's file; the components named in ``prebuilt`` start assembled."""
    parts = {
        "c1": ("column", "[[5, 2, 1], [5, 2, 3]]", "[[0, 0, 1], [0, 2, 1]]", ""),
        "c2": ("column", "[[9, 2, 1], [9, 2, 3]]", "[[1, 0, 1], [1, 2, 1]]", ""),
        "c3": ("column", "[[5, 6, 1], [5, 6, 3]]", "[[2, 0, 1], [2, 2, 1]]", ""),
        "c4": ("column", "[[9, 6, 1], [9, 6, 3]]", "[[3, 0, 1], [3, 2, 1]]", ""),
        "b1": ("beam", "[[6, 2, 3], [8, 2, 3]]", "[[0, 5, 1], [2, 5, 1]]", '["c1", "c2"]'),
        "b2": ("beam", "[[6, 6, 3], [8, 6, 3]]", "[[0, 7, 1], [2, 7, 1]]", '["c3", "c4"]'),
        "s": ("beam", "[[7, 3, 3], [7, 5, 3]]", "[[3, 5, 1], [3, 7, 1]]", '["b1", "b2"]'),
    }
    text = f"""
format = 1
name = "beams-on-beams"
[site]
size = [12, 10, 6]
construction_area = {{ min = [4, 1], max = [10, 7] }}
foundations = [[5, 2], [9, 2], [5, 6], [9, 6]]
[rules]
cranes = {cranes}
step_limit = 600
order = ["c1", "c2", "c3", "c4", "b1", "b2", "s"]
"""
    for cid, (kind, target, initial, supports) in parts.items():
        text += f'[[components]]\nid = "{cid}"\nkind = "{kind}"\nlength = 3\n'
        text += f"target = {target}\n"
        text += "prebuilt = true\n" if cid in prebuilt else f"initial = {initial}\n"
        text += f"supports = {supports}\n" if supports else ""
    return text


def test_a_beam_on_two_beams_loads_with_both_as_supports():
    s = parse_scenario(site(), source="beams.toml")
    assert s.components[S].supports == (B1, B2)
    assert Simulator(s).site.target_supports[S] == [B1, B2]


@pytest.mark.parametrize(
    ("prebuilt", "ready"),
    [
        ((), False),
        (("c1", "c2", "c3", "c4"), False),  # the columns, but neither primary beam
        (("c1", "c2", "c3", "c4", "b1"), False),  # one primary beam only
        (("c1", "c2", "c3", "c4", "b2"), False),
        (("c1", "c2", "c3", "c4", "b1", "b2"), True),  # both: the secondary beam may go
    ],
)
def test_a_beam_on_two_beams_is_not_ready_until_both_are_assembled(prebuilt, ready):
    sim = Simulator(parse_scenario(site(prebuilt), source="beams.toml"))
    sim.reset(np.random.default_rng(0))
    assert bool(sim.target_ready[S]) is ready
    assert bool(sim.action_mask(0)[CLAIM_BASE + S]) is ready  # a beam waits for its target
    out = sim.step([CLAIM_BASE + S])
    if ready:
        assert sim.state.status[S] == Status.IN_TRANSIT
    else:
        assert [e.type for e in out.events] == [EventType.ILLEGAL]


@pytest.mark.parametrize("cranes", [1, 2])
def test_the_prioritized_planner_builds_the_secondary_beam_last(cranes):
    env = multicrane.parallel_env(parse_scenario(site(cranes=cranes), source="beams.toml"))
    metrics = run_episode(env, PrioritizedPlanner(env), seed=0)
    assert metrics["success"], metrics
