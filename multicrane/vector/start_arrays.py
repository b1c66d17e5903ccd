"""The start rule and grid indexing as flat arrays, shared by the vector envs' site compilers.

``fixed_starts`` and ``candidate_tables`` give what the start-drawing kernel
(``multicrane.vector.paper_reset.draw_start``) reads about a scenario: the fixed initial poses,
and one table of candidate poses with their probabilities per distinct candidate list of the
``[random_start]`` rule; ``grid_arrays`` and ``component_arrays`` give every field both
compilers share. ``padded`` packs ragged index lists into one -1 padded array, and
``column_of`` maps a padded-grid cell to its plan column.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from multicrane.core.schema import Scenario
from multicrane.sim import geometry
from multicrane.sim.site import Site
from multicrane.sim.start import candidate_poses


def grid_arrays(site: Site, X: int, Y: int, H: int) -> dict[str, Any]:
    """The grid's fields of a compiled site: static occupancy, move offsets, plan columns."""
    return {
        "static_occ": site.static.astype(np.int8),
        "move_delta": np.array(site.move_delta, dtype=np.int64),
        "column_of": column_of(site, X, Y, H),
        "column_base": np.array([site.lin(x, y, 0) for x in range(X) for y in range(Y)]),
        "height": H,
    }


def component_arrays(scenario: Scenario, site: Site) -> dict[str, Any]:
    """The components', targets' and start rule's fields of a compiled site (the start ones
    are what ``draw_start`` reads)."""
    comps = scenario.components
    width = max(c.length for c in comps)
    return {
        "length": np.array([c.length for c in comps], dtype=np.int64),
        "waits": np.array(site.waits, dtype=bool),
        "prebuilt": np.array([c.prebuilt for c in comps], dtype=bool),
        "n_prebuilt": sum(c.prebuilt for c in comps),
        "target_cells": padded(site.target_cells, width),
        "target_at": site.target_at.astype(np.int64),
        "supports": padded(site.target_supports),
        "compatible": padded(site.compatible),
        "prebuilt_on": padded([list(c.prebuilt_on) for c in comps]),
        **fixed_starts(scenario, site, width),
        **candidate_tables(scenario, site, width),
    }


def padded(rows: list[list[int]], width: int | None = None) -> np.ndarray:
    """Ragged rows of indices as one int64 array padded with -1 (at least one column)."""
    width = max([width or 0, 1, *(len(r) for r in rows)])
    out = np.full((len(rows), width), -1, dtype=np.int64)
    for i, row in enumerate(rows):
        out[i, : len(row)] = row
    return out


def column_of(site: Site, X: int, Y: int, H: int) -> np.ndarray:
    column = np.full(site.shape, -1, dtype=np.int64)
    column[1 : X + 1, 1 : Y + 1, 1 : H + 1] = np.arange(X * Y).reshape(X, Y, 1)
    return column.reshape(-1)


def fixed_starts(scenario: Scenario, site: Site, width: int) -> dict[str, np.ndarray]:
    cells: list[list[int]] = []
    pickup: list[list[int]] = []
    occ = np.zeros(site.size, dtype=bool)
    for c in scenario.components:
        if c.initial is None:
            cells.append([])
            pickup.append([])
            continue
        cells.append(site.lin_pose(c.initial))
        pickup.append(site.lin_pose(geometry.pickup_pose(c, scenario.beam_lift_z)))
        occ[cells[-1]] = True
    return {
        "fixed_cells": padded(cells, width),
        "fixed_pickup": padded(pickup, width),
        "fixed_occ": occ,
    }


def candidate_tables(scenario: Scenario, site: Site, width: int) -> dict[str, np.ndarray]:
    """The random start rule's candidate poses of every drawn component, one table per
    distinct candidate list (components of one shape share theirs)."""
    comps = scenario.components
    drawn = [i for i in scenario.order if comps[i].initial is None and not comps[i].prebuilt]
    table_of = np.full(len(comps), -1, dtype=np.int64)
    keys: list[tuple] = []
    cells: list[list[int]] = []
    pickup: list[list[int]] = []
    probs: list[float] = []
    starts = [0]
    for i in drawn:
        candidates = candidate_poses(scenario, comps[i])
        key = tuple((pose, geometry.pickup_pose(comps[i], scenario.beam_lift_z, pose), p)
                    for pose, p in candidates)  # fmt: skip
        if key not in keys:
            keys.append(key)
            for pose, lifted, p in key:
                cells.append(site.lin_pose(pose))
                pickup.append(site.lin_pose(lifted))
                probs.append(p)
            starts.append(len(probs))
        table_of[i] = keys.index(key)
    return {
        "drawn": np.array(drawn, dtype=np.int64),
        "table_of": table_of,
        "table_start": np.array(starts, dtype=np.int64),
        "cand_cells": padded(cells, width),
        "cand_pickup": padded(pickup, width),
        "cand_prob": np.array(probs, dtype=np.float64),
    }
