"""The tracks of multicrane-bench and the fixed rule that gives every instance's parameters.

A version is a tuple of ``Size`` rows; each size makes three tracks: ``SIZE`` (static site,
no reach), ``SIZE-reach`` (tower cranes with limited reach) and ``SIZE-events`` (site
events, ``multicrane.sim.events``, levels low and high alternating). Instance ``k`` of a
track (``k = 0 .. count - 1``) is fully named by the version, the track and ``k``:

- its family cycles through frame, hall, tower (``FAMILIES`` order);
- its size aims at ``lo + k (hi - lo) / (count - 1)`` components: of ``SHAPE_DRAWS`` shapes
  drawn with ``random.Random("multicrane-bench:VERSION:TRACK:k")`` from the family's ranges
  widened for the size (``WIDER``), the one nearest that aim with a count in ``[lo, hi]``, a
  height of at most 64 and a site within ``MAX_SITE_CELLS`` (the first on ties);
- its crane count spreads over the size's range in a shuffled order (so crane count and
  size are not tied);
- yard, obstacles (0-3) and interchangeable targets (never with reach) are drawn from the
  same generator; starts are fixed (``random_start = False``);
- the generator seed is ``GENERATOR_SEED + 1000 * track index + k``, the reset seed ``k``.

``instances(version)`` lists the ``InstanceSpec`` rows; ``InstanceSpec.scenario()`` generates
the site (``multicrane.scenario.generator.generate``) named by the instance id.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, replace
from typing import Any

from multicrane.core.schema import Scenario
from multicrane.scenario.generator import FAMILIES, MAX_HEIGHT, YARDS, generate, site_cells
from multicrane.scenario.limits import MAX_SITE_CELLS
from multicrane.scenario.named_sets import component_count

SUITE = "multicrane-bench"
VARIANTS = ("", "reach", "events")
EVENT_LEVELS = ("low", "high")  # the events tracks alternate them, instance by instance
GENERATOR_SEED = 3_000_000  # outside the train seeds and the held-out sets' seeds
SHAPE_DRAWS = 400
# Per family, how far the size's ranges of bays and storeys go past the family's own.
WIDER: dict[str, dict[str, int]] = {
    "small": {"bays_x": 1, "bays_y": 1, "storeys": 1},
    "medium": {"bays_x": 3, "bays_y": 2, "storeys": 3},
    "large": {"bays_x": 6, "bays_y": 4, "storeys": 6},
}


@dataclass(frozen=True)
class Size:
    """A size of a version: its component and crane ranges (inclusive), instances per track
    and the CP-SAT time limit of each instance's bound (seconds)."""

    name: str
    components: tuple[int, int]
    cranes: tuple[int, int]
    count: int
    bound_seconds: float


VERSIONS: dict[str, tuple[Size, ...]] = {
    "v1": (
        Size("small", (10, 50), (1, 4), 8, 60.0),
        Size("medium", (50, 200), (2, 8), 4, 60.0),
        Size("large", (200, 500), (4, 16), 3, 60.0),
    ),
}


@dataclass(frozen=True)
class InstanceSpec:
    """One instance: how its scenario file is generated and how its episode is played."""

    id: str
    track: str
    family: str
    generator_seed: int
    params: tuple[tuple[str, Any], ...]  # the generator parameters, sorted by name
    cranes: int
    seed: int  # the reset seed of the episode
    events: str  # "none", "low" or "high"
    reach: bool

    @property
    def file(self) -> str:
        """The scenario file, relative to the version's folder."""
        return f"{self.track}/{self.id}.toml"

    def scenario(self) -> Scenario:
        """The generated site, named by the instance id."""
        made = generate(self.family, self.generator_seed, **dict(self.params))
        return replace(made, name=self.id)


def versions() -> tuple[str, ...]:
    """The suite versions this code can build."""
    return tuple(VERSIONS)


def sizes(version: str) -> tuple[Size, ...]:
    """The sizes of ``version`` (ValueError naming the known versions if unknown)."""
    if version not in VERSIONS:
        raise ValueError(f"unknown suite version {version!r}; versions: {', '.join(VERSIONS)}")
    return VERSIONS[version]


def track_names(version: str) -> tuple[str, ...]:
    """Every track of ``version``, smallest size first: ``small``, ``small-reach``, ..."""
    return tuple(_track(size.name, v) for size in sizes(version) for v in VARIANTS)


def size_of(track: str) -> str:
    """The size a track belongs to: ``small`` for ``small-reach``."""
    return track.split("-")[0]


def _track(size: str, variant: str) -> str:
    return f"{size}-{variant}" if variant else size


def instances(version: str) -> list[InstanceSpec]:
    """Every instance of ``version``, track by track (``track_names`` order)."""
    out = []
    for t, (size, variant) in enumerate((s, v) for s in sizes(version) for v in VARIANTS):
        order = list(range(size.count))
        random.Random(f"{SUITE}:{version}:{_track(size.name, variant)}:cranes").shuffle(order)
        out += [_instance(version, t, size, variant, k, order[k]) for k in range(size.count)]
    return out


def _spread(k: int, count: int, lo: int, hi: int) -> int:
    return lo + round(k * (hi - lo) / max(count - 1, 1))


def _instance(version: str, t: int, size: Size, variant: str, k: int, j: int) -> InstanceSpec:
    track = _track(size.name, variant)
    rng = random.Random(f"{SUITE}:{version}:{track}:{k}")
    family = sorted(FAMILIES)[k % len(FAMILIES)]
    seed = GENERATOR_SEED + 1000 * t + k
    aim = _spread(k, size.count, *size.components)
    reach = variant == "reach"
    options = {
        "yard": rng.choice(YARDS),
        "obstacles": rng.randint(0, 3),
        "cranes": _spread(j, size.count, *size.cranes),
        "reach": reach,
        "interchangeable": not reach and rng.random() < 0.5,
        "random_start": False,
    }
    shape = _shape(family, seed, size, aim, options, rng)
    events = EVENT_LEVELS[k % len(EVENT_LEVELS)] if variant == "events" else "none"
    return InstanceSpec(
        id=f"{track}-{k + 1:02d}", track=track, family=family, generator_seed=seed,
        params=tuple(sorted({**shape, **options}.items())), cranes=options["cranes"],
        seed=k, events=events, reach=reach,
    )  # fmt: skip


def _shape(family: str, seed: int, size: Size, aim: int, options: dict,
           rng: random.Random) -> dict[str, int]:  # fmt: skip
    """The drawn shape nearest ``aim`` components within the size's range (see module doc)."""
    ranges, wider = FAMILIES[family], WIDER[size.name]
    lo, hi = size.components
    best, best_n = None, None
    for _ in range(SHAPE_DRAWS):
        shape = {key: rng.randint(a, b + wider.get(key, 0)) for key, (a, b) in ranges.items()}
        if family == "tower":
            shape["bays_x"] = 1
        n = component_count(shape)
        if not lo <= n <= hi or (shape["storeys"] + 1) * shape["column_height"] > MAX_HEIGHT:
            continue
        if best_n is not None and abs(n - aim) >= abs(best_n - aim):
            continue
        if site_cells(family, seed, **shape, **options) <= MAX_SITE_CELLS:
            best, best_n = shape, n
    if best is None:
        raise RuntimeError(f"no {family} shape with {lo}..{hi} components for seed {seed}")
    return best
