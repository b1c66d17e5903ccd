"""The start of an episode: where each component lies at reset, drawn from the episode's rng.

Called once per ``reset`` with the episode's ``np.random.Generator``; nothing else draws random
numbers for the start. Order of draws: first the target of every pre-built component that may
stand on several targets (the paper's Env1 coin), then the random initial poses in list order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from multicrane import geometry
from multicrane.scenario import ComponentSpec, Scenario, ScenarioError
from multicrane.types import Kind

Pose = geometry.Pose
MAX_START_ATTEMPTS = 1000


@dataclass(frozen=True)
class Start:
    """Initial poses (None for pre-built components) and the target each pre-built one fills."""

    initial: tuple[Pose | None, ...]
    prebuilt_target: tuple[int, ...]  # -1 for components that are not pre-built


def candidate_poses(scenario: Scenario, component: ComponentSpec) -> list[tuple[Pose, float]]:
    """Every pose the random start rule can draw for a component, with its probability.

    The rule: node 1's x is uniform over all x values of the bands; y is uniform over the
    y range of the band holding that x; the direction from node 1 to node 2 is uniform over
    ``directions``. Poses that leave the site or the yard, touch an obstacle, or whose pick-up
    pose is not free of obstacles are left out (the caller renormalises).
    """
    table = _candidates(scenario, scenario.components.index(component))
    return list(zip(table.poses, table.probs.tolist(), strict=True))


@dataclass(frozen=True)
class _Candidates:
    poses: tuple[Pose, ...]
    cells: np.ndarray  # (n, length) flat cell indices (see _flat)
    probs: np.ndarray  # (n,) probability of each pose under the rule


_CACHE: dict[tuple, _Candidates] = {}
_CACHE_MAX = 20_000  # entries; cleared when full (many generated scenarios in one process)


def _flat(scenario: Scenario, cell: tuple[int, int, int]) -> int:
    X, Y, H = scenario.size
    return (cell[0] * Y + cell[1]) * (H + 1) + cell[2]


def _candidates(scenario: Scenario, index: int) -> _Candidates:
    """Computed once per scenario content and component (keyed by the file's hash)."""
    key = (scenario.sha256, scenario.source, index)
    if key in _CACHE:
        return _CACHE[key]
    component = scenario.components[index]
    # The table depends only on the component's shape: kind, length, and for a beam its own
    # target's axis and height (its pick-up pose); components of one shape share it.
    shape = (scenario.sha256, scenario.source, "shape", component.kind, component.length)
    if component.kind is Kind.BEAM:
        shape += (geometry.axis_of(*component.target), component.target[0][2])
    if shape not in _CACHE:
        if len(_CACHE) > _CACHE_MAX:
            _CACHE.clear()
        _CACHE[shape] = _compute(scenario, component)
    _CACHE[key] = _CACHE[shape]
    return _CACHE[key]


def _compute(scenario: Scenario, component: ComponentSpec) -> _Candidates:
    rule = scenario.random_start
    assert rule is not None
    obstacle = scenario.obstacle_cells()
    xs = [x for band in rule.bands for x in range(band.x[0], band.x[1] + 1)]
    poses: list[Pose] = []
    probs: list[float] = []
    for band in rule.bands:
        ys = range(band.y[0], band.y[1] + 1)
        for x in range(band.x[0], band.x[1] + 1):
            for y in ys:
                for d in rule.directions:
                    k = component.length - 1
                    pose = ((x, y, rule.z), (x + k * d[0], y + k * d[1], rule.z + k * d[2]))
                    if _usable(scenario, component, pose, obstacle):
                        poses.append(pose)
                        probs.append(1.0 / (len(xs) * len(ys) * len(rule.directions)))
    cells = np.array(
        [[_flat(scenario, c) for c in geometry.pose_cells(*p)] for p in poses], dtype=np.intp
    ).reshape(len(poses), component.length)
    return _Candidates(tuple(poses), cells, np.array(probs))


def _usable(scenario: Scenario, component: ComponentSpec, pose: Pose, obstacle: set) -> bool:
    for cell in geometry.pose_cells(*pose):
        if not geometry.in_site(cell, scenario.size) or cell in obstacle:
            return False
        if scenario.in_construction_area(cell[0], cell[1]):
            return False
    lifted = geometry.pickup_pose(component, scenario.beam_lift_z, pose)
    return all(
        geometry.in_site(cell, scenario.size) and cell not in obstacle
        for cell in geometry.pose_cells(*lifted)
    )


def draw_start(scenario: Scenario, rng: np.random.Generator) -> Start:
    """Draw one episode's start; deterministic given the generator's state."""
    comps = scenario.components
    prebuilt_target = [-1] * len(comps)
    taken_targets: set[int] = set()
    for i, c in enumerate(comps):
        if c.prebuilt and not c.prebuilt_on:
            prebuilt_target[i] = i
            taken_targets.add(i)
    for i, c in enumerate(comps):
        if c.prebuilt and c.prebuilt_on:
            choices = [t for t in c.prebuilt_on if t not in taken_targets]
            if not choices:
                raise ScenarioError(
                    f"{scenario.source}: no free target left for pre-built {c.id!r}"
                )
            prebuilt_target[i] = int(choices[int(rng.integers(len(choices)))])
            taken_targets.add(prebuilt_target[i])

    X, Y, H = scenario.size
    fixed = np.zeros(X * Y * (H + 1), dtype=bool)
    for c in comps:
        if c.initial is not None:
            fixed[[_flat(scenario, cell) for cell in geometry.pose_cells(*c.initial)]] = True
    drawn = [i for i in scenario.order if comps[i].initial is None and not comps[i].prebuilt]
    for _ in range(MAX_START_ATTEMPTS):
        poses = _draw_random_poses(scenario, drawn, fixed, rng)
        if poses is not None:
            initial = [c.initial for c in comps]
            for i, pose in poses.items():
                initial[i] = pose
            return Start(tuple(initial), tuple(prebuilt_target))
    raise ScenarioError(
        f"{scenario.source}: random_start found no start in {MAX_START_ATTEMPTS} attempts"
    )


def _draw_random_poses(
    scenario: Scenario, drawn: list[int], fixed: np.ndarray, rng: np.random.Generator
) -> dict[int, Pose] | None:
    """One attempt: place the drawn components in list order; None when one finds no pose.

    A draw that would overlap an earlier component is redrawn: drawing among the free poses
    with renormalised probabilities is the same distribution, without the loop.
    """
    occupied = fixed.copy()
    poses: dict[int, Pose] = {}
    for i in drawn:
        table = _candidates(scenario, i)
        free = ~occupied[table.cells].any(axis=1)
        if not free.any():
            return None
        weights = table.probs * free
        pick = int(rng.choice(len(weights), p=weights / weights.sum()))
        poses[i] = table.poses[pick]
        occupied[table.cells[pick]] = True
    return poses
