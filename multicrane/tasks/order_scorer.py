"""A learned list order for the prioritized rule: static component features and their scorer.

The prioritized rule (``multicrane.tasks.priority_rule``) ranks ready pairs by a list order of
the components. ``component_features(book, scenario)`` describes each component by what is
known at reset (``FEATURES``, below); an ``OrderScorer`` weighs them (a linear score, and
optionally a hidden layer of tanh units beside it), and its ``order`` lists the components by
score, highest first, ties by the scenario's order: a list order for the rule
(``policies.task_planners.TaskPrioritized(scorer=...)``). ``tools/order_es.py`` learns the
weights on ``train`` sites. A scorer file is JSON data (``save`` / ``load``), never code:
version 1 holds the linear weights, version 2 adds the hidden layer.

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
    owner, xs, ys = [], [], []
    for c, cells in enumerate(pickup):
        for j in cells:
            x, y, _ = site.cell(j)
            owner.append(c)
            xs.append(x)
            ys.append(y)
    n = len(pickup)
    if not owner:
        return [0] * n
    x0, y0 = min(xs) - 1, min(ys) - 1  # one free column on every side for the dilation
    X, Y = max(xs) - x0 + 2, max(ys) - y0 + 2
    columns = np.zeros((n, X, Y), dtype=bool)  # each component's pick-up columns
    columns[owner, np.subtract(xs, x0), np.subtract(ys, y0)] = True
    around = columns.copy()  # and every column next to one of them
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            around[:, 1:-1, 1:-1] |= columns[:, 1 + dx : X - 1 + dx, 1 + dy : Y - 1 + dy]
    flat = columns.reshape(n, -1).astype(np.float32)
    touch = (around.reshape(n, -1).astype(np.float32) @ flat.T) > 0  # (c, j): j next to c
    has = flat.any(axis=1)
    return np.where(has, touch.sum(axis=1) - has, 0).astype(int).tolist()


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
    """A score of ``FEATURES``: linear, plus with ``hidden`` a layer of tanh units,
    ``x @ weights + tanh(x @ hidden["weights"].T + hidden["bias"]) @ hidden["out"]``;
    ``order`` lists components by score, highest first."""

    def __init__(self, weights, meta: dict | None = None, hidden: dict | None = None):
        w = np.asarray(weights, dtype=np.float64)
        if w.shape != (len(FEATURES),) or not np.isfinite(w).all():
            got = np.asarray(weights).tolist()
            raise ValueError(f"an order scorer needs {len(FEATURES)} finite weights "
                             f"({', '.join(FEATURES)}), got {got}")  # fmt: skip
        self.weights = w
        self.hidden = None if hidden is None else _hidden_layer(hidden)
        self.meta = dict(meta or {})

    @classmethod
    def list_order(cls, hidden_units: int = 0,
                   rng: np.random.Generator | None = None) -> OrderScorer:  # fmt: skip
        """The scorer whose order is the scenario's list order (the plain rule's); with
        ``hidden_units``, tanh units whose input weights are drawn from ``rng`` (standard
        normal) and whose output weights are 0, so the order is still the list's."""
        weights = [-1.0] + [0.0] * (len(FEATURES) - 1)
        if not hidden_units:
            return cls(weights)
        rng = rng if rng is not None else np.random.default_rng(0)
        inputs = rng.standard_normal((hidden_units, len(FEATURES)))
        zeros = np.zeros(hidden_units)
        return cls(weights, hidden={"weights": inputs, "bias": zeros, "out": zeros})

    @property
    def hidden_units(self) -> int:
        return 0 if self.hidden is None else len(self.hidden["out"])

    def parameters(self) -> np.ndarray:
        """Every weight in one vector: the linear weights, then the hidden layer's input
        weights (row by row), biases and output weights."""
        if self.hidden is None:
            return self.weights.copy()
        h = self.hidden
        return np.concatenate([self.weights, h["weights"].ravel(), h["bias"], h["out"]])

    def with_parameters(self, vector, meta: dict | None = None) -> OrderScorer:
        """A scorer of this shape holding ``vector`` (``parameters``' layout)."""
        v, n, k = np.asarray(vector, dtype=np.float64), len(FEATURES), self.hidden_units
        if v.shape != (n + k * (n + 2),):
            raise ValueError(f"{n + k * (n + 2)} parameters expected, got {v.shape}")
        hidden = {"weights": v[n : n + k * n].reshape(k, n), "bias": v[n + k * n : n + k * n + k],
                  "out": v[n + k * n + k :]} if k else None  # fmt: skip
        return OrderScorer(v[:n], meta, hidden)

    def trainable(self, features: int) -> np.ndarray:
        """The indices into ``parameters`` that use only the first ``features`` features:
        their linear weights, those inputs of the hidden units, the biases and outputs."""
        n, k = len(FEATURES), self.hidden_units
        mask = np.zeros(n + k * (n + 2), dtype=bool)
        mask[:features] = True
        if k:
            mask[n : n + k * n].reshape(k, n)[:, :features] = True
            mask[n + k * n :] = True
        return np.flatnonzero(mask)

    def scores(self, features: np.ndarray) -> np.ndarray:
        x = np.asarray(features, dtype=np.float64)
        s = x @ self.weights
        if self.hidden is not None:
            h = self.hidden
            s = s + np.tanh(x @ h["weights"].T + h["bias"]) @ h["out"]
        return s

    def order(self, features: np.ndarray, scenario) -> list[int]:
        """The components by score, highest first; ties in the scenario's list order."""
        return _by_score(scenario, self.scores(features))

    def sampled_orders(self, features: np.ndarray, scenario, count: int, temperature: float,
                       rng: np.random.Generator) -> list[list[int]]:  # fmt: skip
        """``count`` orders: ``order``'s first, then ``count - 1`` drawn from the
        Plackett-Luce distribution of the scores (the Gumbel-max form: each score plus
        ``temperature`` times the scores' standard deviation over the site's components
        times a standard Gumbel draw, sorted; the scale makes ``temperature`` mean the same
        on every site). Only the draws use ``rng``; ``count`` 1 draws nothing."""
        s = self.scores(features)
        scale = _sampling_scale(s, temperature)
        noisy = [s + scale * rng.gumbel(size=s.shape) for _ in range(count - 1)]
        return [_by_score(scenario, scores) for scores in (s, *noisy)]

    def log_probability_gradient(self, features: np.ndarray, order,
                                 temperature: float) -> np.ndarray:  # fmt: skip
        """The gradient, over ``parameters()``, of the log-probability that
        ``sampled_orders`` at ``temperature`` draws ``order`` (every component once), with
        its scale (the temperature times the scores' spread) held at its value here."""
        x = np.asarray(features, dtype=np.float64)
        s = self.scores(x)
        scale = _sampling_scale(s, temperature)
        s = s / scale
        rest = np.asarray(order)
        ds = np.zeros(len(s))
        for i in range(len(rest)):
            logits = s[rest[i:]]
            p = np.exp(logits - logits.max())
            ds[rest[i:]] -= p / p.sum()
            ds[rest[i]] += 1.0
        ds /= scale
        if self.hidden is None:
            return x.T @ ds
        h = self.hidden
        units = np.tanh(x @ h["weights"].T + h["bias"])
        pre = ds[:, None] * h["out"][None, :] * (1 - units**2)
        return np.concatenate([x.T @ ds, (pre.T @ x).ravel(), pre.sum(0), units.T @ ds])

    def save(self, path) -> None:
        body = {"format": FORMAT, "version": 1 if self.hidden is None else 2,
                "features": list(FEATURES), "weights": self.weights.tolist()}  # fmt: skip
        if self.hidden is not None:
            body["hidden"] = {k: v.tolist() for k, v in self.hidden.items()}
        body["meta"] = self.meta
        Path(path).write_text(json.dumps(body, indent=1) + "\n")

    @classmethod
    def load(cls, path) -> OrderScorer:
        """Reads a scorer file, or ``scorer.json`` in a run directory; ``ValueError`` names the
        file and the key that is wrong. A file that names only the first features (one
        written before the later ones were added) weighs the others 0: the same order."""
        path = Path(path)
        if path.is_dir():
            path = path / "scorer.json"
        where = f"order scorer {str(path)!r}"
        try:
            body = json.loads(path.read_text())
        except OSError as exc:
            raise ValueError(f"{where}: cannot read it ({exc.strerror})") from None
        except json.JSONDecodeError as exc:
            raise ValueError(f"{where}: not JSON ({exc.msg}, line {exc.lineno})") from None
        if not isinstance(body, dict) or body.get("format") != FORMAT:
            raise ValueError(f"{where}: 'format' must be {FORMAT!r}")
        if body.get("version", 1) not in (1, 2):
            raise ValueError(f"{where}: 'version' must be 1 or 2, got {body.get('version')!r}")
        named = body.get("features")
        if not isinstance(named, list) or not named or named != list(FEATURES[: len(named)]):
            raise ValueError(f"{where}: 'features' must list {', '.join(FEATURES)} (or the "
                             f"first of them, in this order), got {named!r}")  # fmt: skip
        weights = _numbers(body.get("weights"), len(named), f"{where}: 'weights'")
        pad = len(FEATURES) - len(named)
        hidden = body.get("hidden")
        if hidden is not None:
            hidden = _read_hidden(hidden, len(named), f"{where}: 'hidden'")
            hidden["weights"] = np.pad(hidden["weights"], ((0, 0), (0, pad)))
        meta = body.get("meta", {})
        padded = list(weights) + [0.0] * pad
        return cls(padded, meta if isinstance(meta, dict) else {}, hidden)


def _by_score(scenario, scores) -> list[int]:
    """The scenario's components by score, highest first; ties in its list order."""
    return sorted(scenario.order, key=lambda c: -scores[c])


def _sampling_scale(scores: np.ndarray, temperature: float) -> float:
    """The Gumbel scale of ``sampled_orders``: the temperature times the scores' spread (1
    when every score is the same)."""
    return temperature * (float(scores.std()) or 1.0)


def _numbers(value, count: int, where: str) -> list[float]:
    """``value`` if it is a list of ``count`` finite numbers, else a ``ValueError``."""
    ok = isinstance(value, list) and len(value) == count and all(
        isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)
        for x in value
    )  # fmt: skip
    if not ok:
        raise ValueError(f"{where} must be {count} finite numbers, got {value!r}")
    return [float(x) for x in value]


def _read_hidden(hidden, named: int, where: str) -> dict:
    """The hidden layer of a scorer file: ``weights`` (one row of ``named`` numbers per
    unit), ``bias`` and ``out`` (one number per unit)."""
    rows = hidden.get("weights") if isinstance(hidden, dict) else None
    if not isinstance(rows, list) or not rows:
        raise ValueError(f"{where} must hold 'weights' (a list of rows, one per unit), "
                         f"'bias' and 'out', got {hidden!r}")  # fmt: skip
    units = len(rows)
    matrix = [_numbers(r, named, f"{where} 'weights' row {i}") for i, r in enumerate(rows)]
    return {"weights": np.array(matrix),
            "bias": np.array(_numbers(hidden.get("bias"), units, f"{where} 'bias'")),
            "out": np.array(_numbers(hidden.get("out"), units, f"{where} 'out'"))}  # fmt: skip


def _hidden_layer(hidden: dict) -> dict:
    """The hidden layer as float arrays, shapes checked: ``weights`` (H, FEATURES),
    ``bias`` and ``out`` (H,), all finite."""
    keys = ("weights", "bias", "out")
    missing = [k for k in keys if not isinstance(hidden, dict) or k not in hidden]
    if missing:
        raise ValueError(f"a hidden layer needs 'weights', 'bias' and 'out', missing {missing}")
    w, b, o = (np.asarray(hidden[k], dtype=np.float64) for k in keys)
    units = o.shape[0] if o.ndim == 1 else 0
    fine = w.shape == (units, len(FEATURES)) and b.shape == o.shape == (units,) and units
    if not fine or not all(np.isfinite(a).all() for a in (w, b, o)):
        raise ValueError(f"a hidden layer needs weights ({units}, {len(FEATURES)}), bias and "
                         f"out ({units},), all finite, got {w.shape}, {b.shape}, {o.shape}")
    return {"weights": w, "bias": b, "out": o}
