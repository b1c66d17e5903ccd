"""Shortest collision-free paths of one rigid component through the voxel grid.

A component's position is the linear index of its first cell in the simulator's padded grid;
its shape never changes once lifted (moves only translate it). ``distance_field`` runs a
breadth-first search backwards from the goal positions over the positions where the whole
component fits, treating every other component as a fixed obstacle. It works on whole
arrays (one shifted copy per move and search depth), so it takes about a millisecond on the
paper's sites.
"""

from __future__ import annotations

import numpy as np

from multicrane.core.codes import N_MOVES, Status
from multicrane.sim.grid_search import UNREACHABLE, breadth_first, fits_everywhere
from multicrane.sim.simulator import FREE, Simulator
from multicrane.sim.site import Site

__all__ = [
    "UNREACHABLE",
    "breadth_first",
    "current_cells",
    "distance_field",
    "field_from",
    "fit_mask",
    "fits_everywhere",
    "goal_positions",
    "next_move",
    "path_to",
    "zone_ok",
]


def current_cells(sim: Simulator, comp: int) -> list[int]:
    """Where the component is, or where its next move starts from: an initial component
    is judged from its pick-up pose (the automatic mode lifts it with its first move)."""
    return (
        sim.state.cells[comp]
        if sim.state.status[comp] != Status.INITIAL
        else sim.state.pickup[comp]
    )


def fit_mask(sim: Simulator, comp: int, shape: list[int]) -> np.ndarray:
    """Boolean per position: the component, shaped as ``shape``, fits there."""
    free = (sim.state.occ == FREE) | (sim.state.occ == comp + 1)
    return fits_everywhere(free, [j - shape[0] for j in shape])


def zone_ok(site: Site, crane: int, offsets) -> np.ndarray | None:
    """Boolean per position: a shape with these cell offsets lies wholly in ``crane``'s zone
    (``site.reach``); None when the scenario has no reach (every crane reaches everywhere)."""
    if site.reach is None:
        return None
    return fits_everywhere(site.reach[crane], offsets)


def goal_positions(sim: Simulator, comp: int, targets: list[int]) -> list[int]:
    """Positions at which the component's cells equal one of the targets' cells."""
    shape = current_cells(sim, comp)
    rel = sorted(j - shape[0] for j in shape)
    goals = []
    for t in targets:
        cells = sorted(sim.site.target_cells[t])
        start = cells[0] - rel[0]
        if sorted(start + r for r in rel) == cells:
            goals.append(start)
    return goals


def distance_field(
    sim: Simulator, comp: int, targets: list[int], crane: int | None = None
) -> np.ndarray:
    """Moves from every position to the nearest goal (``UNREACHABLE`` where none). With
    ``crane``, only positions inside that crane's zone count (see ``zone_ok``)."""
    shape = current_cells(sim, comp)
    ok = fit_mask(sim, comp, shape)
    if crane is not None:
        zone = zone_ok(sim.site, crane, [j - shape[0] for j in shape])
        if zone is not None:
            ok &= zone
    return breadth_first(ok, goal_positions(sim, comp, targets), sim.site.move_delta)


def next_move(sim: Simulator, comp: int, dist: np.ndarray) -> int | None:
    """A move that goes one step down the distance field, or None (at a goal or stuck)."""
    here = current_cells(sim, comp)[0]
    d = dist[here]
    if d <= 0:
        return None
    for move in range(N_MOVES):
        if dist[here + sim.site.move_delta[move]] == d - 1:
            return move
    return None


def field_from(sim: Simulator, comp: int, stops: list[int]) -> np.ndarray:
    """Moves from where the component is (its pick-up pose if initial) to every position.

    Positions in ``stops`` are reached but never passed through: a component that covers a
    target it may fill arrives there, so a path cannot go on through such a pose.
    """
    shape = current_cells(sim, comp)
    ok = fit_mask(sim, comp, shape)
    through = ok.copy()
    through[stops] = False
    return breadth_first(ok, [shape[0]], sim.site.move_delta, through)


def path_to(sim: Simulator, dist: np.ndarray, goal: int, stops: set[int]) -> list[int]:
    """The moves of a shortest path to ``goal`` in a ``field_from(..., stops)`` field."""
    moves: list[int] = []
    here = goal
    d = int(dist[here])
    if d < 0:
        raise ValueError("goal unreachable")
    while d > 0:
        for move in range(N_MOVES):
            prev = here - sim.site.move_delta[move]
            if dist[prev] == d - 1 and (d == 1 or prev not in stops):
                moves.append(move)
                here = prev
                break
        else:
            raise AssertionError("broken distance field")
        d -= 1
    moves.reverse()
    return moves
