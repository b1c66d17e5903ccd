"""Solvability at load: every target reachable from every start, and no precedence cycle.

Two necessary conditions for a scenario to be finishable, checked by the loader after the
other checks (``check_solvable``):

- **Reachability.** A lifted component keeps its shape (moves only translate it), so for
  each component a breadth-first search of its rigid shape through the *static* site (the
  site's bounds and obstacles; other components move and are ignored) must connect every
  pick-up pose it can have (its fixed initial pose's, or each pose the random start rule
  can draw) to the pose of some target it may fill. An enclosed target fails here.
- **Precedence.** The targets' supports (a beam's columns, the column target below a
  column: ``target_supports``) must form no cycle, else no order of assembly exists.

A failure is a :class:`~multicrane.core.schema.ScenarioError` naming the component's key.
The search works on whole numpy arrays: about a millisecond per component shape on the
shipped sites.
"""

from __future__ import annotations

import numpy as np

from multicrane.core.kinds import STACKED, kind_spec
from multicrane.core.schema import Cell, Scenario, ScenarioError
from multicrane.scenario.toml_table import TomlTable
from multicrane.sim import geometry
from multicrane.sim.start import candidate_poses


def check_solvable(s: Scenario, tables: list[TomlTable] | None = None) -> None:
    """Raise ScenarioError when some target cannot be reached from some start of its
    component, or when the supports form a cycle (``tables``: the components' tables)."""

    def fail(i: int, key: str, problem: str) -> ScenarioError:
        if tables is not None:
            return tables[i].refuse(key, problem)
        c = s.components[i]
        value = [list(p) for p in c.target] if key == "target" else [s.ids[j] for j in c.supports]
        return ScenarioError(f"{s.source}: components[{i}].{key} = {value!r}: {problem}")

    cycle = precedence_cycle(s)
    if cycle:
        ids = " -> ".join(repr(s.components[i].id) for i in cycle)
        raise fail(cycle[0], "supports", f"the supports form a cycle ({ids}): no assembly order")
    regions = _Regions(_static_free(s))
    pickups: dict[tuple, list[geometry.Pose]] = {}
    starts = {i: _pickup_poses(s, i, pickups) for i, c in enumerate(s.components) if not c.prebuilt}
    shared: dict[int, np.ndarray] = {}  # labels of a pick-up list shared by one shape
    for i, poses in starts.items():
        if id(poses) not in shared:
            shared[id(poses)] = regions.labels(_offsets(s.components[i].target), poses)
    labels_of = {i: shared[id(poses)] for i, poses in starts.items()}
    compatible = _compatible_all(s)
    for i, poses in starts.items():
        c = s.components[i]
        targets = compatible[i]
        extent = _offsets(c.target)
        goal = {regions.label_of(extent, _anchor(s.components[t].target)) for t in targets} - {0}
        bad = ~np.isin(labels_of[i], list(goal))
        if bad.any():
            pose = poses[int(np.flatnonzero(bad)[0])]
            where = "its initial pose" if c.initial is not None else "the drawn start"
            raise fail(
                i,
                "target",
                f"cannot be reached: no obstacle-free path of the lifted component from "
                f"{where}'s pick-up pose {[list(p) for p in pose]} to "
                + ("its target" if len(targets) == 1 else "any target it may fill"),
            )
    t = _unfilled_target(s, regions, labels_of, compatible)
    if t is not None:
        raise fail(
            t,
            "target",
            "cannot be reached: no component that may fill this target has an "
            "obstacle-free path to it from its pick-up pose(s)",
        )


class _Regions:
    """The connected regions of each shape's positions in the static site, labelled lazily:
    one flood fill per region (not per target)."""

    def __init__(self, free: np.ndarray):
        self.free = free
        self.by_extent: dict[tuple[int, int, int], tuple[np.ndarray, np.ndarray]] = {}

    def label_of(self, extent: tuple[int, int, int], cell: Cell) -> int:
        """The connected region (> 0) of the shape's positions holding ``cell``; 0: none."""
        if extent not in self.by_extent:
            self.by_extent[extent] = (
                _fits(self.free, extent), np.zeros(self.free.shape, dtype=np.int32)
            )
        fits, labels = self.by_extent[extent]
        if not fits[cell]:
            return 0
        if labels[cell] == 0:
            labels[_flood(fits, cell)] = int(labels.max()) + 1
        return int(labels[cell])

    def labels(self, extent: tuple[int, int, int], poses: list[geometry.Pose]) -> np.ndarray:
        """The region label of each pick-up pose of one shape (0: does not fit)."""
        self.label_of(extent, _anchor(poses[0]))  # the regions of this shape exist from here on
        anchors = np.array([_anchor(p) for p in poses]).T
        labels = self.by_extent[extent][1][tuple(anchors)]
        for k in np.flatnonzero(labels == 0):  # not flooded yet, or not fitting
            labels[k] = self.label_of(extent, _anchor(poses[k]))
        return labels


def _unfilled_target(
    s: Scenario, regions: _Regions, labels_of: dict[int, np.ndarray], compatible: list[set[int]]
) -> int | None:
    """A target some movable component must fill that no component reaches from each of its
    starts (with interchangeable targets, any component that may fill it), or None."""
    maybe_prebuilt = {j for c in s.components if c.prebuilt for j in c.prebuilt_on or ()}
    maybe_prebuilt |= {i for i, c in enumerate(s.components) if c.prebuilt and not c.prebuilt_on}
    for t in range(len(s.components)):
        if t in maybe_prebuilt:
            continue
        fillers = [i for i in labels_of if t in compatible[i]]
        target = s.components[t].target
        label = regions.label_of(_offsets(target), _anchor(target))
        if label == 0 or not any((labels_of[i] == label).all() for i in fillers):
            return t
    return None


def precedence_cycle(s: Scenario) -> list[int]:
    """Component indices along a cycle of the target supports (first repeated), or []."""
    supports = target_supports(s)
    state = [0] * len(supports)  # 0 new, 1 on the stack, 2 done
    for root in range(len(supports)):
        if state[root]:
            continue
        stack: list[tuple[int, int]] = [(root, 0)]
        path = [root]
        state[root] = 1
        while stack:
            node, k = stack[-1]
            if k < len(supports[node]):
                stack[-1] = (node, k + 1)
                nxt = supports[node][k]
                if state[nxt] == 1:
                    return path[path.index(nxt) :] + [nxt]
                if state[nxt] == 0:
                    state[nxt] = 1
                    stack.append((nxt, 0))
                    path.append(nxt)
            else:
                state[node] = 2
                stack.pop()
                path.pop()
    return []


def target_supports(s: Scenario) -> list[list[int]]:
    """Per target, the targets it rests on: a beam's or panel's supports, the target below a
    stacked one (a column: ``multicrane.core.kinds``)."""
    bottom_of: dict[Cell, int] = {}
    for j, c in enumerate(s.components):
        for cell in geometry.pose_cells(*c.target):
            bottom_of[cell] = j
    out = []
    for c in s.components:
        if kind_spec(c.kind).supports != STACKED:
            out.append(list(c.supports))
            continue
        x, y, z = min(geometry.pose_cells(*c.target), key=lambda cell: cell[2])
        below = bottom_of.get((x, y, z - 1))
        out.append([below] if below is not None else [])
    return out


def _compatible_all(s: Scenario) -> list[set[int]]:
    """Per component, the targets it may fill (its own; with interchangeable targets, every
    target of the same kind and shape: ``geometry.shape_key``)."""
    if not s.interchangeable_targets:
        return [{i} for i in range(len(s.components))]
    shape = [geometry.shape_key(c.kind, c.target) for c in s.components]
    groups: dict[tuple, set[int]] = {}
    for j, key in enumerate(shape):
        groups.setdefault(key, set()).add(j)
    return [groups[key] for key in shape]


def _pickup_poses(s: Scenario, i: int, cache: dict[tuple, list]) -> list[geometry.Pose]:
    """The distinct pick-up poses of component ``i`` over its starts; drawn starts depend
    only on the component's shape, so their pick-up poses are computed once per shape."""
    c = s.components[i]
    if c.initial is not None:
        return [geometry.pickup_pose(c, s.beam_lift_z, c.initial)]
    key = (c.kind, c.length, geometry.axis_of(*c.target), c.target[0][2])
    if key not in cache:
        initials = [pose for pose, _ in candidate_poses(s, c)]
        cache[key] = list(
            dict.fromkeys(geometry.pickup_pose(c, s.beam_lift_z, p) for p in initials)
        )
    return cache[key]


def _anchor(pose: geometry.Pose) -> Cell:
    """The pose's lowest corner (min x, y, z): its position in the search grid."""
    a, b = pose
    return (min(a[0], b[0]), min(a[1], b[1]), min(a[2], b[2]))


def _offsets(pose: geometry.Pose) -> tuple[int, int, int]:
    """The shape's extent beyond its anchor along x, y and z."""
    a, b = pose
    return (abs(a[0] - b[0]), abs(a[1] - b[1]), abs(a[2] - b[2]))


def _static_free(s: Scenario) -> np.ndarray:
    """(X, Y, H + 1) bool: cells inside the site and outside obstacles (z = 0 is ground)."""
    X, Y, H = s.size
    free = np.ones((X, Y, H + 1), dtype=bool)
    free[:, :, 0] = False
    for box in s.obstacles:
        (x0, y0, z0), (x1, y1, z1) = box.lo, box.hi
        free[x0 : x1 + 1, y0 : y1 + 1, z0 : z1 + 1] = False
    return free


def _fits(free: np.ndarray, extent: tuple[int, int, int]) -> np.ndarray:
    """Bool per anchor position: the box of ``extent`` (a straight shape or a panel) fits
    there. Axis by axis, a box fits where the box one axis shorter fits at every shift."""
    fits = free
    for axis, n in enumerate(extent):
        grown = fits.copy()
        for k in range(1, n + 1):
            shifted = np.zeros_like(free)
            src = [slice(None)] * 3
            dst = [slice(None)] * 3
            src[axis] = slice(k, None)
            dst[axis] = slice(None, -k)
            shifted[tuple(dst)] = fits[tuple(src)]
            grown &= shifted
        fits = grown
    return fits


def _flood(fits: np.ndarray, start: Cell) -> np.ndarray:
    """The positions connected to ``start`` by unit moves through fitting positions.

    Sweeps whole straight runs at a time: a fitting position is reached when any position
    of its run (the maximal line of fitting positions along an axis) is, so the number of
    sweeps grows with the turns of the paths, not with their length.
    """
    seen = np.zeros_like(fits)
    seen[start] = True
    count = 1
    while True:
        for axis in range(3):
            seen |= _runs_reached(fits, seen, axis)
        now = int(np.count_nonzero(seen))
        if now == count:
            return seen
        count = now


def _runs_reached(fits: np.ndarray, seen: np.ndarray, axis: int) -> np.ndarray:
    """The fitting positions whose run along ``axis`` holds a seen fitting position."""
    f = np.moveaxis(fits, axis, -1)
    s = np.moveaxis(seen, axis, -1)
    starts = f.copy()
    starts[..., 1:] &= ~f[..., :-1]  # a run starts where the position before does not fit
    run = np.cumsum(starts, axis=None).reshape(f.shape) * f  # 0: not fitting
    hit = np.zeros(int(run.max()) + 1, dtype=bool)
    hit[run[s & f]] = True
    hit[0] = False
    return np.moveaxis(hit[run], -1, axis)
