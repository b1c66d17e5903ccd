"""Crane reach: whether every component can be carried, start to target, by one crane in its zone.

A scenario with ``[[crane]]`` entries gives each tower crane a zone (``Site.reach``: every cell
whose column lies within the crane's radius of its base, at every height). A crane carries a
component only while all the component's cells are in its zone, and there is no hand-over
between cranes, so each component needs one crane whose zone holds its pick-up pose, some
compatible target, and a path of the rigid shape between them through the static site (walls
and obstacles; other components are ignored). This is checked for every start pose a
component can have: its fixed ``initial``, or every pose the ``[random_start]`` rule can draw.
With interchangeable targets, every target must also be reachable that way by some crane
from some start of a compatible component (else nobody could ever fill it).

Per crane and component shape, the positions where the shape fits the static site inside the
zone are split into connected regions (one breadth-first search from each goal not yet
labelled, ``multicrane.sim.grid_search``); a start is carriable when its pick-up position lies in
the region of a compatible target. Results are cached per (scenario, crane count).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from multicrane.core.schema import Pose, Scenario
from multicrane.sim import geometry
from multicrane.sim.grid_search import breadth_first, fits_everywhere
from multicrane.sim.site import FREE, Site
from multicrane.sim.start import candidate_poses


def crane_count_problem(scenario: Scenario, n_cranes: int) -> str | None:
    """Why ``n_cranes`` cranes cannot build this scenario under its reach, or None.

    None without ``[[crane]]`` entries. Otherwise ``n_cranes`` must not exceed the cranes
    described, and the first ``n_cranes`` of them must be able to carry every component.
    """
    specs = scenario.crane_specs
    if not specs:
        return None
    if n_cranes > len(specs):
        return (
            f"n_cranes = {n_cranes}, but scenario {scenario.name!r} describes "
            f"{len(specs)} cranes ([[crane]]); at most {len(specs)} can be used"
        )
    found = uncarriable(scenario, n_cranes)
    return None if found is None else found[2]


def check_crane_count(scenario: Scenario, n_cranes: int) -> None:
    """Raise ValueError (naming the numbers or the component) when ``crane_count_problem``."""
    problem = crane_count_problem(scenario, n_cranes)
    if problem is not None:
        raise ValueError(problem)


def uncarriable(
    scenario: Scenario, n_cranes: int | None = None
) -> tuple[int, Pose | None, str] | None:
    """The first component (index, start pose, message) that none of the first ``n_cranes``
    cranes (default: all described) can carry from that start to a compatible target, or
    else the first target (index, None, message) to which none can carry a compatible
    component; None when every component can be carried from every start it can have and
    every target can be filled."""
    n = len(scenario.crane_specs) if n_cranes is None else n_cranes
    if not scenario.crane_specs:
        return None
    return _uncarriable(scenario, n)


@lru_cache(maxsize=32)
def _uncarriable(scenario: Scenario, n: int) -> tuple[int, Pose | None, str] | None:
    site = Site(scenario)
    regions = _Regions(site)
    # The targets some crane can carry some compatible component to.
    fillable: set[int] = set()
    for i, comp in enumerate(scenario.components):
        if comp.prebuilt:
            continue
        if comp.initial is not None:
            starts = [comp.initial]
        else:
            starts = [pose for pose, _ in candidate_poses(scenario, comp)]
        if not starts:
            continue  # the loader's random-start check reports it
        lift_z = scenario.beam_lift_z
        picks = [sorted(site.lin_pose(geometry.pickup_pose(comp, lift_z, s))) for s in starts]
        rel = tuple(j - picks[0][0] for j in picks[0])
        positions = np.array([cells[0] for cells in picks], dtype=np.intp)
        goals_of = [_position(rel, site.target_cells[t]) for t in site.compatible[i]]
        goals = [g for g in goals_of if g is not None]
        carried = np.zeros(len(starts), dtype=bool)
        for crane in range(n):
            ok, labels = regions.of(crane, rel, goals)
            wanted = sorted({int(labels[g]) for g in goals if ok[g]})
            if wanted:
                here = ok[positions] & np.isin(labels[positions], wanted)
                carried |= here
                if here.any():
                    reached = set(labels[positions[here]].tolist())
                    fillable.update(
                        t
                        for t, g in zip(site.compatible[i], goals_of, strict=True)
                        if g is not None and ok[g] and int(labels[g]) in reached
                    )
        if not carried.all():
            start = starts[int(np.flatnonzero(~carried)[0])]
            lifted = geometry.pickup_pose(comp, scenario.beam_lift_z, start)
            return i, start, _message(scenario, n, comp.id, start, lifted)
    for t, comp in enumerate(scenario.components):
        always_filled = comp.prebuilt and not comp.prebuilt_on  # its own pre-built component
        if t not in fillable and not always_filled:
            return t, None, (
                f"the target of component {comp.id!r} ({_show(comp.target)}) cannot be filled: "
                f"no crane ({_cranes(scenario, n)}) can carry a compatible component to it "
                "inside its zone"
            )
    return None


def _cranes(scenario: Scenario, n: int) -> str:
    return "; ".join(
        f"crane {k}: base {list(s.base)}, radius {s.radius:g}"
        for k, s in enumerate(scenario.crane_specs[:n])
    )


def _message(scenario: Scenario, n: int, cid: str, start: Pose, lifted: Pose) -> str:
    cranes = _cranes(scenario, n)
    which = "any crane" if n == len(scenario.crane_specs) else f"any of the first {n} cranes"
    which = "crane 0 (the only one used)" if n == 1 else which
    return (
        f"component {cid!r} starting at {_show(start)} (pick-up pose {_show(lifted)}) cannot be "
        f"carried to a compatible target by {which} inside its zone ({cranes}); hand-over "
        "between cranes is not supported"
    )


def _show(pose: Pose) -> str:
    return str([list(pose[0]), list(pose[1])])


def _position(rel: tuple[int, ...], target_cells: list[int]) -> int | None:
    """The position at which a shape (sorted offsets ``rel``) covers the target exactly."""
    cells = sorted(target_cells)
    start = cells[0]
    return start if [start + r for r in rel] == cells else None


class _Regions:
    """Per (crane, shape): where the shape fits the static site in the zone, and region labels
    (0: not labelled; labels are given lazily, one breadth-first search per new region)."""

    def __init__(self, site: Site):
        self.site = site
        self.free = site.static == FREE
        self._cache: dict[tuple[int, tuple[int, ...]], tuple[np.ndarray, np.ndarray]] = {}

    def of(self, crane: int, rel: tuple[int, ...], goals: list[int]):
        key = (crane, rel)
        if key not in self._cache:
            assert self.site.reach is not None
            ok = fits_everywhere(self.free & self.site.reach[crane], rel)
            self._cache[key] = (ok, np.zeros(ok.size, dtype=np.int32))
        ok, labels = self._cache[key]
        for g in goals:
            if ok[g] and labels[g] == 0:
                dist = breadth_first(ok, [g], self.site.move_delta)
                labels[dist >= 0] = int(labels.max()) + 1
        return ok, labels
