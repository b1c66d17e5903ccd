"""Named scenario sets: the ``train`` distribution and held-out ``test-small``, ``test-large``,
``test-other``.

Every site is made by ``multicrane.scenario.generator.generate(family, seed, **params)``; a set is a
rule that picks the family and the parameters from the seed (``random.Random`` seeded with
the set's name and the seed), so a member is fully named by ``(set, seed)``.

- ``train``: a distribution, not a list: any seed in ``TRAIN_SEEDS`` (0 .. 999,999) gives a
  site of any family, 1-4 cranes, every option on or off (``train_scenario(seed)``;
  ``draw_train_seeds`` draws seeds within a size and crane range).
- ``test-small``: 50 sites, seeds 1,000,000 .. 1,000,049: at most 30 components, 2-4 cranes.
- ``test-large``: 50 sites, seeds 2,000,000 .. 2,000,049: 60-200 components, 4-16 cranes;
  the k-th seed aims at 60 + 140 k / 49 components (of 400 shapes drawn, the one nearest
  that size whose site stays within ``MAX_SITE_CELLS``), so the sizes spread over the range;
  its crane count is 4 + 12 j / 49 with j = 7 k mod 50 (every count, in another order).
- ``test-other``: 50 sites, seeds 4,000,000 .. 4,000,049, outside the training range in two
  ways at once: a family ``train`` never draws (``precast``: beams, columns and floor slabs,
  7-34 components, ``PANEL_FAMILIES``) and 5-16 cranes (``train``: 1-4).

The held-out seeds lie outside ``TRAIN_SEEDS``, so no held-out site is a training site, and
outside the benchmark suite's generator seeds (``multicrane.suite.tracks``, from 3,000,000).
Tower-crane reach is drawn only with own targets and fixed starts (see the generator).
``scenario_set(name)`` generates a set's members on first use and keeps them (per process);
``members(name)`` lists their names, families and parameters without generating anything.
Command lines name a set as ``set:NAME`` where they take a scenario (``is_set_ref``).
"""

from __future__ import annotations

import random
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

from multicrane.core.schema import Scenario
from multicrane.scenario.generator import (
    FAMILIES,
    PANEL_FAMILIES,
    YARDS,
    generate,
    site_cells,
)
from multicrane.scenario.limits import MAX_SITE_CELLS

TRAIN_SEEDS = range(0, 1_000_000)
SET_PREFIX = "set:"


@dataclass(frozen=True)
class SetRule:
    """A held-out set: its seeds, component and crane ranges (inclusive)."""

    seeds: range
    components: tuple[int, int]
    cranes: tuple[int, int]
    spread: bool = False  # sizes aimed evenly over ``components`` (else: the first that fits)
    families: tuple[str, ...] = ()  # the families drawn from (none named: ``FAMILIES``)


HELD_OUT: dict[str, SetRule] = {
    "test-small": SetRule(range(1_000_000, 1_000_050), (1, 30), (2, 4)),
    "test-large": SetRule(range(2_000_000, 2_000_050), (60, 200), (4, 16), spread=True),
    # Any size its family draws (the bound is no bound); slabs count beside columns and beams.
    "test-other": SetRule(
        range(4_000_000, 4_000_050), (1, 10**9), (5, 16), families=tuple(PANEL_FAMILIES)
    ),
}


@dataclass(frozen=True)
class Member:
    """One site of a set: ``generate(family, seed, **params)`` makes it."""

    name: str
    family: str
    seed: int
    params: tuple[tuple[str, Any], ...]

    def scenario(self) -> Scenario:
        return generate(self.family, self.seed, **dict(self.params))


def component_count(p: dict[str, Any]) -> int:
    """Columns and beams of a building with these bays and storeys."""
    nx, ny = p["bays_x"], p["bays_y"]
    per_storey = (nx + 1) * (ny + 1) + nx * (ny + 1) + ny * (nx + 1)
    return p["storeys"] * per_storey


def _options(rng: random.Random, cranes: tuple[int, int], fixed_reach: bool) -> dict[str, Any]:
    opts: dict[str, Any] = {
        "yard": rng.choice(YARDS),
        "obstacles": rng.randint(0, 3),
        "cranes": rng.randint(*cranes),
        "interchangeable": rng.random() < 0.5,
        "random_start": rng.random() < 0.5,
    }
    # Reach needs own targets; with fixed starts only, to keep generation quick.
    reach = fixed_reach and not opts["interchangeable"] and not opts["random_start"]
    opts["reach"] = reach and rng.random() < 0.5
    return opts


def _member(set_name: str, seed: int, rule: SetRule | None) -> Member:
    rng = random.Random(f"{set_name}:{seed}")
    family = rng.choice(sorted((rule and rule.families) or FAMILIES))
    ranges = FAMILIES.get(family) or PANEL_FAMILIES[family]
    lo, hi = rule.components if rule else (1, 10**9)
    large = rule is not None and rule.spread
    if large:  # sizes spread evenly over the range, by the seed's place in the set
        k, last = seed - rule.seeds.start, max(len(rule.seeds) - 1, 1)
        aim = lo + round(k * (hi - lo) / last)
    best: dict[str, int] | None = None
    opts = _options(rng, rule.cranes, True) if large else {}
    if large:  # crane counts spread too, in another order (7 k mod 50: a permutation)
        c_lo, c_hi = rule.cranes
        opts["cranes"] = c_lo + round((7 * k) % (last + 1) * (c_hi - c_lo) / last)
    for _ in range(10_000 if not large else 400):
        shape = {k: rng.randint(a, b) for k, (a, b) in ranges.items()}
        if large:  # room for more bays (halls, frames) and storeys (frames, towers)
            shape["bays_x"] = rng.randint(ranges["bays_x"][0], ranges["bays_x"][1] + 3)
            shape["bays_y"] = rng.randint(ranges["bays_y"][0], ranges["bays_y"][1] + 2)
            more = 1 if family == "hall" else 3
            shape["storeys"] = rng.randint(ranges["storeys"][0], ranges["storeys"][1] + more)
        if family == "tower":
            shape["bays_x"] = 1
        n = component_count(shape)
        if not (lo <= n <= hi and (shape["storeys"] + 1) * shape["column_height"] <= 64):
            continue
        if not large:
            best = shape
            break
        if (
            best is None or abs(n - aim) < abs(component_count(best) - aim)
        ) and site_cells(family, seed, **shape, **opts) <= MAX_SITE_CELLS:
            best = shape  # the drawn shape nearest the aimed size (the first on ties)
    if best is None:  # pragma: no cover - the ranges always contain a fitting shape
        raise RuntimeError(f"{set_name}: no {family} shape with {lo}..{hi} components")
    shape = best
    params = {**shape, **(opts or _options(rng, rule.cranes if rule else (1, 4), True))}
    if family in PANEL_FAMILIES:  # panels need fixed starts (drawn all the same, as above)
        params["random_start"] = False
    return Member(f"{set_name}/{family}-s{seed}", family, seed, tuple(sorted(params.items())))


def train_member(seed: int) -> Member:
    """The ``train`` site of ``seed`` (any seed in ``TRAIN_SEEDS``)."""
    if seed not in TRAIN_SEEDS:
        raise ValueError(
            f"train seed {seed} is outside {TRAIN_SEEDS.start}..{TRAIN_SEEDS.stop - 1} "
            "(seeds outside belong to the held-out sets)"
        )
    return _member("train", seed, None)


def draw_train_seeds(rng, count: int, max_components: int,
                     cranes: tuple[int, int] = (1, 4)) -> list[int]:  # fmt: skip
    """``count`` distinct ``train`` seeds drawn with ``rng`` (a numpy ``Generator``) whose
    sites have at most ``max_components`` components and a crane count in ``cranes``
    (inclusive; read from the drawn parameters, without generating the site)."""
    out: list[int] = []
    while len(out) < count:
        s = int(rng.integers(TRAIN_SEEDS.start, TRAIN_SEEDS.stop))
        params = dict(train_member(s).params)
        fits = cranes[0] <= params["cranes"] <= cranes[1]
        if s not in out and fits and component_count(params) <= max_components:
            out.append(s)
    return out


def train_scenario(seed: int) -> Scenario:
    """A site drawn from the ``train`` distribution."""
    return train_member(seed).scenario()


def members(name: str) -> list[Member]:
    """The members of a held-out set (no generation)."""
    if name not in HELD_OUT:
        raise ValueError(
            f"unknown scenario set {name!r}; held-out sets: {', '.join(HELD_OUT)} "
            "(train is a distribution: train_scenario(seed))"
        )
    rule = HELD_OUT[name]
    return [_member(name, seed, rule) for seed in rule.seeds]


@lru_cache(maxsize=4)
def scenario_set(name: str) -> tuple[tuple[str, Scenario], ...]:
    """The (name, Scenario) pairs of a held-out set, generated once per process."""
    return tuple((m.name, m.scenario()) for m in members(name))


def is_set_ref(text: str) -> bool:
    """True for a command-line scenario argument naming a set (``set:test-small``)."""
    return str(text).startswith(SET_PREFIX)


def resolve_set(text: str) -> tuple[tuple[str, Scenario], ...]:
    """The scenarios of ``set:NAME`` (``set:train:A-B``: train seeds A..B-1)."""
    name = str(text)[len(SET_PREFIX) :]
    if name.startswith("train:"):
        return tuple((m.name, m.scenario()) for m in set_members(text))
    return scenario_set(name)


def set_members(text: str) -> list[Member]:
    """The members of ``set:NAME`` or ``set:train:A-B``, not generated yet (a worker that
    plays a few of the sites generates only those)."""
    name = str(text)[len(SET_PREFIX) :]
    if name.startswith("train:"):
        try:
            a, b = (int(v) for v in name[len("train:") :].split("-"))
        except ValueError:
            raise ValueError(f"{text!r}: write set:train:FIRST-END (seeds FIRST..END-1)") from None
        return [train_member(seed) for seed in range(a, b)]
    return members(name)
