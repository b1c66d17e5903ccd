"""A learned list order for the prioritized rule: static component features and a linear scorer.

The prioritized rule (``multicrane.tasks.priority_rule``) ranks ready pairs by a list order of
the components. ``component_features(book, scenario)`` describes each component by what is
known at reset (``FEATURES``, below); an ``OrderScorer`` weighs them, and its ``order`` lists the
components by score, highest first, ties by the scenario's order: a list order for the rule
(``policies.task_planners.TaskPrioritized(scorer=...)``). ``tools/order_es.py`` learns the
weights on ``train`` sites. A scorer file is JSON data (``save`` / ``load``), never code.

The features of component ``c`` (lengths scaled by the site's size or by the mean shortest
distance): its place in the scenario's list order, its class's size and its place in its class
by list order and by distance (a class: the components with the same compatible targets), the
shortest and mean distance from its pick-up pose to a compatible target, the pick-up pose's x
and y, the chain and dependents of target ``c`` (``multicrane.tasks.support_graph``) and its
centre, the mean chain and height of its compatible targets, the crane count; then its place
among all components by shortest distance, the pick-up pose's height, how many components lie
next to it in the yard (``yard_neighbours``), the mean dependents of its compatible targets,
and the crane count times its shortest distance. A per-site constant changes no order in a
linear score; the last term lets the weight of the distance grow or shrink with the cranes.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from multicrane.tasks.book import TaskBook
from multicrane.tasks.support_graph import site_chains

FEATURES = (
    "list_place", "class_size", "class_place", "class_place_by_distance", "shortest_distance",
    "mean_distance", "pickup_x", "pickup_y", "chain", "dependents", "centre_x", "centre_y",
    "centre_z", "fits_chain", "fits_height", "cranes", "distance_rank", "pickup_z",
    "yard_neighbours", "fits_dependents", "cranes_x_distance",
)  # fmt: skip
FORMAT = "multicrane-order-scorer"


def interchangeable_classes(site, order) -> dict[tuple, list[int]]:
    """The classes of interchangeable components (same compatible targets), each listed in
    ``order`` (the scenario's list order)."""
    out: dict[tuple, list[int]] = {}
    for c in order:
        out.setdefault(tuple(site.compatible[c]), []).append(c)
    return out


def yard_neighbours(site, pickup) -> list[int]:
    """Per component, how many others lie in the yard next to it: a pick-up cell within one
    cell of its own, horizontally (any height); 0 for a pre-built component."""
    columns = [{tuple(site.cell(x)[:2]) for x in cells} for cells in pickup]
    around = [{(x + dx, y + dy) for x, y in cols for dx in (-1, 0, 1) for dy in (-1, 0, 1)}
              for cols in columns]  # fmt: skip
    return [sum(1 for j, other in enumerate(columns) if j != c and other & around[c])
            if columns[c] else 0 for c in range(len(columns))]  # fmt: skip


def component_features(book: TaskBook, scenario) -> np.ndarray:
    """(C, len(FEATURES)) float32: every component's static features (module doc), after a
    reset (the pick-up poses are the episode's)."""
    sim = book.sim
    site, n = sim.site, scenario.n_components
    size = np.asarray(scenario.size, dtype=float)
    dist = book.carrier.pair_distances().astype(float)
    dist[dist < 0] = np.nan
    shortest, mean = np.nanmin(dist, axis=1), np.nanmean(dist, axis=1)
    scale = float(np.nanmean(shortest)) or 1.0
    chain, dependents = site_chains(site)
    top = max(int(chain.max()), 1)
    cells: dict[int, list] = {}
    for cell, t in enumerate(site.target_at.tolist()):
        if t >= 0:
            cells.setdefault(t, []).append(site.cell(cell))
    centre = np.array([np.mean(cells[t], axis=0) / size for t in range(n)])
    place = {c: i for i, c in enumerate(scenario.order)}
    of_class = interchangeable_classes(site, scenario.order)
    distance_rank = np.argsort(np.argsort(np.nan_to_num(shortest), kind="stable"), kind="stable")
    neighbours = yard_neighbours(site, sim.state.pickup)
    rows = []
    for c in range(n):
        members, fits = of_class[tuple(site.compatible[c])], list(site.compatible[c])
        by_distance = sorted(members, key=lambda k: shortest[k])
        pickup = np.mean([site.cell(x) for x in sim.state.pickup[c]], axis=0) / size
        rows.append([
            place[c] / n, len(members) / n, members.index(c) / len(members),
            by_distance.index(c) / len(members), shortest[c] / scale, mean[c] / scale,
            pickup[0], pickup[1], chain[c] / top, dependents[c] / n, *centre[c],
            chain[fits].mean() / top, centre[fits, 2].mean(), sim.n_cranes / 16,
            distance_rank[c] / n, pickup[2], neighbours[c] / 8, dependents[fits].mean() / n,
            sim.n_cranes / 16 * shortest[c] / scale,
        ])  # fmt: skip
    return np.nan_to_num(np.asarray(rows, dtype=np.float32))


class OrderScorer:
    """A linear score of ``FEATURES``; ``order`` lists components by score, highest first."""

    def __init__(self, weights, meta: dict | None = None):
        w = np.asarray(weights, dtype=np.float64)
        if w.shape != (len(FEATURES),) or not np.isfinite(w).all():
            got = np.asarray(weights).tolist()
            raise ValueError(f"an order scorer needs {len(FEATURES)} finite weights "
                             f"({', '.join(FEATURES)}), got {got}")  # fmt: skip
        self.weights = w
        self.meta = dict(meta or {})

    @classmethod
    def list_order(cls) -> OrderScorer:
        """The scorer whose order is the scenario's list order (the plain rule's)."""
        return cls([-1.0] + [0.0] * (len(FEATURES) - 1))

    def scores(self, features: np.ndarray) -> np.ndarray:
        return np.asarray(features, dtype=np.float64) @ self.weights

    def order(self, features: np.ndarray, scenario) -> list[int]:
        """The components by score, highest first; ties in the scenario's list order."""
        s = self.scores(features)
        return sorted(scenario.order, key=lambda c: -s[c])

    def save(self, path) -> None:
        body = {"format": FORMAT, "version": 1, "features": list(FEATURES),
                "weights": self.weights.tolist(), "meta": self.meta}  # fmt: skip
        Path(path).write_text(json.dumps(body, indent=1) + "\n")

    @classmethod
    def load(cls, path) -> OrderScorer:
        """Reads a scorer file, or ``scorer.json`` in a run directory; ``ValueError`` names the
        file and the key that is wrong. A file that names only the first features (one
        written before the later ones were added) weighs the others 0: the same order."""
        path = Path(path)
        if path.is_dir():
            path = path / "scorer.json"
        try:
            body = json.loads(path.read_text())
        except OSError as exc:
            raise ValueError(f"order scorer {str(path)!r}: cannot read it "
                             f"({exc.strerror})") from None  # fmt: skip
        except json.JSONDecodeError as exc:
            raise ValueError(f"order scorer {str(path)!r}: not JSON ({exc.msg}, line "
                             f"{exc.lineno})") from None  # fmt: skip
        if not isinstance(body, dict) or body.get("format") != FORMAT:
            raise ValueError(f"order scorer {str(path)!r}: 'format' must be {FORMAT!r}")
        named = body.get("features")
        if not isinstance(named, list) or not named or named != list(FEATURES[: len(named)]):
            raise ValueError(f"order scorer {str(path)!r}: 'features' must list "
                             f"{', '.join(FEATURES)} (or the first of them, in this order), "
                             f"got {named!r}")  # fmt: skip
        weights = body.get("weights")
        ok = isinstance(weights, list) and all(
            isinstance(w, int | float) and not isinstance(w, bool) and math.isfinite(w)
            for w in weights
        )
        if not ok or len(weights) != len(named):
            raise ValueError(f"order scorer {str(path)!r}: 'weights' must be {len(named)} "
                             f"finite numbers, one per feature, got {weights!r}")  # fmt: skip
        meta = body.get("meta", {})
        padded = list(weights) + [0.0] * (len(FEATURES) - len(named))
        return cls(padded, meta if isinstance(meta, dict) else {})
