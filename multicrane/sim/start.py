"""The start of an episode: where each component lies at reset, drawn from the episode's rng.

Called once per ``reset`` with the episode's ``np.random.Generator``; nothing else draws random
numbers for the start. Order of draws: first the target of every pre-built component that may
stand on several targets (the paper's Env1 coin), then the random initial poses in list order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from multicrane.core.kinds import kind_spec
from multicrane.core.schema import ComponentSpec, Scenario, ScenarioError
from multicrane.sim import geometry

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


def has_candidates(scenario: Scenario, component: ComponentSpec) -> bool:
    """True when the random start rule can draw some pose for the component."""
    return len(_candidates(scenario, scenario.components.index(component)).poses) > 0


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
    # The table depends only on the component's shape: kind, length, and for a kind lifted
    # about its centre (a beam) its own target's axis and height (its pick-up pose);
    # components of one shape share it.
    shape = (scenario.sha256, scenario.source, "shape", component.kind, component.length)
    if kind_spec(component.kind).lifted_about_centre:
        shape += (geometry.axis_of(*component.target), component.target[0][2])
    if shape not in _CACHE:
        if len(_CACHE) > _CACHE_MAX:
            _CACHE.clear()
        _CACHE[shape] = _compute(scenario, component)
    _CACHE[key] = _CACHE[shape]
    return _CACHE[key]


def _compute(scenario: Scenario, component: ComponentSpec) -> _Candidates:
    """Every drawable pose, in the rule's order (band, x, y, direction), tested as arrays:
    the pose's cells inside the site, in the yard and off obstacles, and its pick-up pose's
    cells inside the site and off obstacles."""
    rule = scenario.random_start
    assert rule is not None
    X, Y, H = scenario.size
    blocked = np.zeros((X, Y, H + 1), dtype=bool)
    for box in scenario.obstacles:
        (x0, y0, z0), (x1, y1, z1) = box.lo, box.hi
        blocked[x0 : x1 + 1, y0 : y1 + 1, z0 : z1 + 1] = True
    ax0, ay0, ax1, ay1 = scenario.construction_area
    n_x = sum(b.x[1] - b.x[0] + 1 for b in rule.bands)
    length = component.length
    steps = np.arange(length)
    dirs = np.array(rule.directions, dtype=np.int64)  # (D, 3)
    poses: list[Pose] = []
    probs: list[float] = []
    for band in rule.bands:
        xs = np.arange(band.x[0], band.x[1] + 1)
        ys = np.arange(band.y[0], band.y[1] + 1)
        gx, gy, gd = np.meshgrid(xs, ys, np.arange(len(dirs)), indexing="ij")
        n1 = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, rule.z)], axis=1)  # (P, 3)
        d = dirs[gd.ravel()]
        n2 = n1 + (length - 1) * d
        cells = n1[:, None, :] + steps[None, :, None] * d[:, None, :]  # (P, L, 3)
        ok = _inside(cells, X, Y, H) & ~_in_area(cells, ax0, ay0, ax1, ay1)
        ok &= ~_hits(blocked, cells, ok)
        lifted = _lifted_cells(component, scenario.beam_lift_z, n1, n2, steps)
        ok &= _inside(lifted, X, Y, H)
        ok &= ~_hits(blocked, lifted, ok)
        p = 1.0 / (n_x * len(ys) * len(dirs))
        for k in np.flatnonzero(ok):
            a, b = n1[k], n2[k]
            poses.append(((int(a[0]), int(a[1]), int(a[2])), (int(b[0]), int(b[1]), int(b[2]))))
            probs.append(p)
    flat = np.array(
        [[_flat(scenario, c) for c in geometry.pose_cells(*p)] for p in poses], dtype=np.intp
    ).reshape(len(poses), length)
    return _Candidates(tuple(poses), flat, np.array(probs))


def _inside(cells: np.ndarray, X: int, Y: int, H: int) -> np.ndarray:
    x, y, z = cells[..., 0], cells[..., 1], cells[..., 2]
    return ((x >= 0) & (x < X) & (y >= 0) & (y < Y) & (z >= 1) & (z <= H)).all(axis=-1)


def _in_area(cells: np.ndarray, x0: int, y0: int, x1: int, y1: int) -> np.ndarray:
    x, y = cells[..., 0], cells[..., 1]
    return ((x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)).any(axis=-1)


def _hits(blocked: np.ndarray, cells: np.ndarray, where: np.ndarray) -> np.ndarray:
    """Per pose (only where ``where``; cells inside the site there): some cell is blocked."""
    out = np.zeros(len(cells), dtype=bool)
    idx = np.flatnonzero(where)
    if len(idx):
        c = cells[idx]
        out[idx] = blocked[c[..., 0], c[..., 1], c[..., 2]].any(axis=-1)
    return out


def _lifted_cells(
    component: ComponentSpec, beam_lift_z: int | None, n1: np.ndarray, n2: np.ndarray,
    steps: np.ndarray,
) -> np.ndarray:  # fmt: skip
    """The cells of the pick-up pose of each start (``geometry.lifted_pose`` on arrays; only
    bars start at random)."""
    length = component.length
    if not kind_spec(component.kind).lifted_about_centre:
        base = n1 + np.array([0, 0, 1])
        axis = 2
    else:
        z = beam_lift_z if beam_lift_z is not None else component.target[0][2]
        axis = geometry.axis_of(*component.target)
        base = np.stack([(n1[:, 0] + n2[:, 0]) // 2, (n1[:, 1] + n2[:, 1]) // 2,
                         np.full(len(n1), z)], axis=1)  # fmt: skip
        base[:, axis] -= (length - 1) // 2
    unit = np.zeros(3, dtype=np.int64)
    unit[axis] = 1
    return base[:, None, :] + steps[None, :, None] * unit[None, None, :]


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


def weighted_index(rng: np.random.Generator, p: np.ndarray) -> int:
    """``int(rng.choice(len(p), p=p))`` without its argument checks (``p`` is a probability
    vector built here): numpy draws one ``rng.random()`` and finds it in the normalised
    cumulative sums, and so does this, so the draws and the generator's state are the same
    (tests/sim/test_start_draw.py compares both)."""
    cdf = p.cumsum()
    cdf /= cdf[-1]
    return int(cdf.searchsorted(rng.random(), side="right"))


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
        pick = weighted_index(rng, weights / weights.sum())
        poses[i] = table.poses[pick]
        occupied[table.cells[pick]] = True
    return poses
