"""The copies' site-event schedules, drawn at reset by numpy itself and written into the arrays.

``Simulator.reset`` takes one number from the episode's generator after the start
(``integers(2**63)``), seeds a fresh generator with it and draws the ``EventSchedule`` from
that (``multicrane.sim.events.draw_schedule``). Resets are rare next to steps, so rather than
compile those draws this module does exactly that in Python for the copies whose reset
kernel stopped after the start (``buffers.scheduling``): the copy's five ``PCG64`` words go into
a numpy generator, the number is taken, the words come back, and the schedule's arrival
steps, outages and closure boxes are written into the copy's rows of the ``MotionState``
(the interval tables grow when a schedule has more rows than they hold). The kernels of
``multicrane.vector.motion_events`` then apply it.
"""

from __future__ import annotations

import numpy as np

from multicrane.sim.events import EventSchedule, EventSpec, draw_schedule
from multicrane.sim.site import Site
from multicrane.vector.motion_state import MotionState
from multicrane.vector.pcg64 import generator_of, state_of


def draw_schedules(
    spec: EventSpec, site: Site, n_cranes: int, horizon: int, state: MotionState,
    copies: np.ndarray,
) -> MotionState:  # fmt: skip
    """Draw and write the schedule of each copy in ``copies`` (its start already drawn, as
    ``Simulator.reset`` draws it); returns the state, with grown tables if needed."""
    prebuilt = np.array([c.prebuilt for c in site.scenario.components], dtype=bool)
    for b in copies:
        generator = generator_of(state.rng[b])
        seed = int(generator.integers(2**63))
        state.rng[b] = state_of(generator)
        schedule = draw_schedule(
            spec, site, prebuilt, n_cranes, horizon, np.random.default_rng(seed)
        )
        state = write_schedule(state, int(b), schedule)
    return state


def write_schedule(state: MotionState, b: int, schedule: EventSchedule) -> MotionState:
    """Copy ``b``'s rows of the schedule tables from ``schedule``; returns the state (with
    grown ``outages`` or ``closures`` when they had too few rows)."""
    outages = [tuple(o) for o in schedule.outages]
    closures = [(*c.box[0], *c.box[1], c.start, c.end) for c in schedule.closures]
    state = state._replace(
        outages=_with_rows(state.outages, len(outages)),
        closures=_with_rows(state.closures, len(closures)),
    )
    state.arrival[b] = schedule.arrival
    state.n_outages[b] = len(outages)
    state.n_closures[b] = len(closures)
    if outages:
        state.outages[b, : len(outages)] = outages
    if closures:
        state.closures[b, : len(closures)] = closures
    return state


def _with_rows(table: np.ndarray, rows: int) -> np.ndarray:
    """``table`` ([B, K, W]) itself, or a copy with at least ``rows`` rows per copy."""
    if rows <= table.shape[1]:
        return table
    grown = np.zeros((table.shape[0], max(rows, 2 * table.shape[1]), table.shape[2]),
                     dtype=table.dtype)  # fmt: skip
    grown[:, : table.shape[1]] = table
    return grown
