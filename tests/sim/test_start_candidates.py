"""The random start's candidate table (computed on arrays) equals the rule applied pose by pose.

``multicrane.sim.start`` enumerates every drawable pose with numpy; this test keeps the plain
per-pose rule of scenarios/README.md ("Random start") and compares poses, order and
probabilities on every shipped random-start scenario and on generated ones.
"""

from __future__ import annotations

import pytest

from multicrane.scenario.catalog import scenario_names
from multicrane.scenario.components_table import in_site
from multicrane.scenario.generator import generate
from multicrane.scenario.loader import load_scenario
from multicrane.sim import geometry
from multicrane.sim.start import _compute


def per_pose(scenario, component):
    rule = scenario.random_start
    obstacle = scenario.obstacle_cells()
    n_x = sum(b.x[1] - b.x[0] + 1 for b in rule.bands)
    poses, probs = [], []
    for band in rule.bands:
        ys = range(band.y[0], band.y[1] + 1)
        for x in range(band.x[0], band.x[1] + 1):
            for y in ys:
                for d in rule.directions:
                    k = component.length - 1
                    pose = ((x, y, rule.z), (x + k * d[0], y + k * d[1], rule.z + k * d[2]))
                    cells = geometry.pose_cells(*pose)
                    ok = all(
                        in_site(c, scenario.size)
                        and c not in obstacle
                        and not scenario.in_construction_area(c[0], c[1])
                        for c in cells
                    )
                    if ok:
                        lifted = geometry.pickup_pose(component, scenario.beam_lift_z, pose)
                        ok = all(
                            in_site(c, scenario.size) and c not in obstacle
                            for c in geometry.pose_cells(*lifted)
                        )
                    if ok:
                        poses.append(pose)
                        probs.append(1.0 / (n_x * len(ys) * len(rule.directions)))
    return poses, probs


def random_start_scenarios():
    shipped = [load_scenario(n) for n in scenario_names()]
    made = [generate(f, 3, random_start=True, obstacles=3, storeys=1) for f in ("frame", "hall")]
    return [s for s in shipped + made if s.random_start is not None]


@pytest.mark.parametrize("scenario", random_start_scenarios(), ids=lambda s: s.name)
def test_candidate_table_equals_the_per_pose_rule(scenario):
    for c in scenario.components:
        if c.prebuilt or c.initial is not None:
            continue
        table = _compute(scenario, c)
        poses, probs = per_pose(scenario, c)
        assert list(table.poses) == poses
        assert table.probs.tolist() == probs
