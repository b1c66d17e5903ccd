"""The scenario generator: random buildable sites of four families, deterministic by seed.

``generate(family, seed, **params)`` returns a validated :class:`~multicrane.core.schema.Scenario`
(the strict loader has read it, so it passes every load check, solvability included);
``to_toml(scenario)`` (``multicrane.scenario.writer``) gives its file, byte for byte the same for
the same arguments. Families (``FAMILIES``): ``frame`` (steel frames: n x m bays, a few
storeys), ``hall`` (long spans, one or two storeys), ``tower`` (a small footprint, many
storeys), and in ``PANEL_FAMILIES`` ``precast`` (a precast frame one bay deep: beams along x
only, and per bay and storey a floor slab resting on the two beams under its edges; kept
apart from ``FAMILIES`` so that the named sets, drawn from those, stay as they are). A
building is a grid of column positions ``span`` cells apart; storey 1's columns stand on
foundations, storey k's on storey k-1's; a beam (``span - 1`` cells) joins each pair
of neighbouring columns at the top of the storey. The list order is buildable: storey by
storey, its columns before the beams they carry. Every parameter left out is drawn from the
family's range with ``random.Random(seed)``. Beams are lifted to the top of the site
(``rules.beam_lift_z``), above the finished building, so that no built part ever blocks a
beam's (or slab's) pick-up pose; the yard (``layout``: components lying in lanes,
or ``[random_start]`` bands) is ``multicrane.scenario.generator_yard``'s job. Obstacle boxes are
placed in the yard and kept only if the scenario still loads (so is still solvable); tower
cranes (``reach=True``) stand evenly around the construction area with the smallest whole
radius for which ``multicrane.sim.reach`` finds every component carriable. Reach is only
generated with own targets (interchangeable targets under reach can deadlock planners).
"""

from __future__ import annotations

import hashlib
import math
import random
from dataclasses import replace
from typing import Any

from multicrane.core.codes import Kind
from multicrane.core.kinds import kind_spec
from multicrane.core.schema import (
    Box,
    ComponentSpec,
    CraneSpec,
    RewardSpec,
    Scenario,
    ScenarioError,
)
from multicrane.scenario import generator_yard as yard
from multicrane.scenario.limits import MAX_SITE_CELLS
from multicrane.scenario.loader import parse_scenario
from multicrane.scenario.writer import to_toml
from multicrane.sim import geometry
from multicrane.sim.reach import uncarriable

# Each family's parameter ranges (inclusive), drawn from when a parameter is not given.
FAMILIES: dict[str, dict[str, tuple[int, int]]] = {
    "frame": {"bays_x": (1, 3), "bays_y": (1, 2), "storeys": (1, 3), "column_height": (3, 4),
              "span": (3, 5)},
    "hall": {"bays_x": (2, 5), "bays_y": (1, 2), "storeys": (1, 2), "column_height": (4, 5),
             "span": (6, 8)},
    "tower": {"bays_x": (1, 1), "bays_y": (1, 2), "storeys": (3, 8), "column_height": (3, 4),
              "span": (3, 4)},
}  # fmt: skip
# Families with panels: slabs need fixed starts (the random start rule draws straight poses).
PANEL_FAMILIES: dict[str, dict[str, tuple[int, int]]] = {
    "precast": {"bays_x": (1, 3), "bays_y": (1, 1), "storeys": (1, 2), "column_height": (3, 4),
                "span": (3, 5)},
}  # fmt: skip
YARDS = ("one", "two", "around")
OPTIONS = ("yard", "obstacles", "cranes", "reach", "interchangeable", "random_start")
MAX_HEIGHT = 64
MAX_CRANES = 16


def draw_params(family: str, seed: int, **params: Any) -> dict[str, Any]:
    """Every parameter of ``generate``: those given, the rest drawn from the family's ranges."""
    ranges = FAMILIES.get(family) or PANEL_FAMILIES.get(family)
    if ranges is None:
        names = ", ".join([*FAMILIES, *PANEL_FAMILIES])
        raise ValueError(f"unknown family {family!r}; families: {names}")
    unknown = sorted(set(params) - set(ranges) - set(OPTIONS))
    if unknown:
        allowed = ", ".join([*ranges, *OPTIONS])
        raise ValueError(f"unknown generator parameter(s) {', '.join(unknown)}; known: {allowed}")
    rng = random.Random(f"{family}:{seed}")
    out: dict[str, Any] = {}
    for key, (lo, hi) in ranges.items():
        drawn = rng.randint(lo, hi)  # always drawn, so one parameter given changes no other
        out[key] = params.get(key, drawn)
    drawn_opts = {
        "yard": rng.choice(YARDS),
        "obstacles": rng.randint(0, 3),
        "cranes": rng.randint(1, 4),
        "reach": False,
        "interchangeable": rng.random() < 0.5,
        "random_start": rng.random() < 0.5,
    }
    if params.get("reach"):
        drawn_opts["interchangeable"] = False  # reach is only generated with own targets
    if family in PANEL_FAMILIES:
        drawn_opts["random_start"] = False
    for key, drawn in drawn_opts.items():
        out[key] = params.get(key, drawn)
    _check_params(out)
    if family in PANEL_FAMILIES:
        _check_panel_params(out)
    return out


def _check_panel_params(p: dict[str, Any]) -> None:
    if p["random_start"]:
        raise ValueError("random_start = True: panels need fixed starts (the random start "
                         "rule draws straight components only)")  # fmt: skip
    if p["bays_y"] != 1:
        raise ValueError(f"bays_y = {p['bays_y']!r}: a precast frame is one bay deep (its "
                         "slabs span it between two beam lines)")  # fmt: skip
    if p["span"] < 3:
        raise ValueError(f"span = {p['span']!r}: a slab between columns needs a span >= 3")


def _check_params(p: dict[str, Any]) -> None:
    for key in ("bays_x", "storeys"):
        if not isinstance(p[key], int) or p[key] < 1:
            raise ValueError(f"{key} = {p[key]!r}: must be an integer >= 1")
    if not isinstance(p["bays_y"], int) or p["bays_y"] < 0:  # 0: one row of columns
        raise ValueError(f"bays_y = {p['bays_y']!r}: must be an integer >= 0")
    if not isinstance(p["column_height"], int) or p["column_height"] < 2:
        raise ValueError(f"column_height = {p['column_height']!r}: must be an integer >= 2")
    if not isinstance(p["span"], int) or not 2 <= p["span"] <= 12:
        raise ValueError(f"span = {p['span']!r}: must be an integer in 2..12")
    if p["yard"] not in YARDS:
        raise ValueError(f"yard = {p['yard']!r}: must be one of {', '.join(YARDS)}")
    if not isinstance(p["cranes"], int) or not 1 <= p["cranes"] <= MAX_CRANES:
        raise ValueError(f"cranes = {p['cranes']!r}: must be an integer in 1..{MAX_CRANES}")
    if not isinstance(p["obstacles"], int) or not 0 <= p["obstacles"] <= 20:
        raise ValueError(f"obstacles = {p['obstacles']!r}: must be an integer in 0..20")
    if p["reach"] and p["interchangeable"]:
        raise ValueError(
            "reach = True needs interchangeable = False: interchangeable targets under "
            "limited reach can deadlock planners, so the generator does not make them"
        )
    height = (p["storeys"] + 1) * p["column_height"]
    if height > MAX_HEIGHT:
        raise ValueError(
            f"storeys = {p['storeys']}, column_height = {p['column_height']}: the site would "
            f"be {height} cells high ((storeys + 1) x column_height); at most {MAX_HEIGHT}"
        )


def site_cells(family: str, seed: int, **params: Any) -> int:
    """The cell count (X * Y * height) of the site ``generate`` would make, without making
    it (for choosing parameters that stay within ``MAX_SITE_CELLS``)."""
    p = draw_params(family, seed, **params)
    comps, _, _ = _building(p)
    size = yard.lay_out(comps, p, random.Random(f"{family}:{seed}:layout")).size
    return size[0] * size[1] * size[2]


def generate(family: str, seed: int, **params: Any) -> Scenario:
    """A validated, solvable scenario of ``family``; the same arguments give the same one."""
    p = draw_params(family, seed, **params)
    rng = random.Random(f"{family}:{seed}:layout")
    name = f"{family}-s{seed}"
    comps, order, foundations = _building(p, slabs=family in PANEL_FAMILIES)
    panel = [kind_spec(c.kind).panel for c in comps]
    straight = [i for i in range(len(comps)) if not panel[i]]
    site = yard.lay_out([comps[i] for i in straight], p, rng)
    site.starts = {straight[k]: pose for k, pose in site.starts.items()}
    site = yard.add_panel_strip(
        site, {i: geometry.extent(*c.target)[:2] for i, c in enumerate(comps) if panel[i]}
    )
    comps = [replace(c, target=_shift(c.target, site.offset)) for c in comps]
    foundations = [(x + site.offset[0], y + site.offset[1]) for x, y in foundations]
    if site.size[0] * site.size[1] * site.size[2] > MAX_SITE_CELLS:
        raise ValueError(
            f"{name}: the site would have {site.size[0] * site.size[1] * site.size[2]} cells "
            f"(size {list(site.size)}); at most {MAX_SITE_CELLS}: choose fewer bays or storeys"
        )
    n = len(comps)
    desc = (
        f"Generated by multicrane.scenario.generator: family {family}, seed {seed}, "
        + ", ".join(f"{k} = {p[k]}" for k in sorted(p))
        + f"; {n} components."
    )
    draft = Scenario(
        name=name, description=desc, source=f"<generated {name}>", sha256="",
        size=site.size, construction_area=site.area, foundations=tuple(foundations),
        obstacles=(), components=tuple(replace(c, initial=site.starts.get(i))
                                       for i, c in enumerate(comps)),
        order=tuple(order), cranes=p["cranes"], step_limit=max(1000, 150 * n),
        interchangeable_targets=p["interchangeable"], assembly_steps=1, beam_lift_z=site.size[2],
        reward=RewardSpec(), random_start=site.random_start,
    )  # fmt: skip
    # Caches keyed by the file hash (``multicrane.sim.start``) must not mix up drafts: hash the
    # text.
    draft = replace(draft, sha256=hashlib.sha256(to_toml(draft).encode()).hexdigest())
    if p["reach"]:
        draft = _with_reach(draft, p["cranes"])
    draft = _with_obstacles(draft, p["obstacles"], site.free_boxes, rng)
    return _parse(draft)


def _parse(draft: Scenario) -> Scenario:
    return parse_scenario(to_toml(draft), source=draft.source, default_name=draft.name)


def _building(
    p: dict[str, Any], slabs: bool = False
) -> tuple[list[ComponentSpec], list[int], list[tuple[int, int]]]:
    """Columns and beams at grid origin (0, 0): components, buildable order, foundations.
    With ``slabs``: beams along x only, and a slab per bay on the storey's top, resting on
    the two beams under its edges (its supports)."""
    nx, ny, s, h = p["bays_x"], p["bays_y"], p["span"], p["column_height"]
    cols = [(i * s, j * s) for j in range(ny + 1) for i in range(nx + 1)]
    comps: list[ComponentSpec] = []
    order: list[int] = []
    for k in range(1, p["storeys"] + 1):
        z0, top = (k - 1) * h + 1, k * h
        here: dict[tuple[int, int], int] = {}
        for n, (x, y) in enumerate(cols, 1):
            here[(x, y)] = len(comps)
            order.append(len(comps))
            target = ((x, y, z0), (x, y, top))
            comps.append(ComponentSpec(f"c{k}-{n}", Kind.COLUMN, h, None, target, (), False, ()))
        pairs = [((x, y), (x + s, y)) for (x, y) in cols if (x + s, y) in here]
        if not slabs:
            pairs += [((x, y), (x, y + s)) for (x, y) in cols if (x, y + s) in here]
        beam_of: dict[tuple, int] = {}
        for n, (a, b) in enumerate(pairs, 1):
            beam_of[(a, b)] = len(comps)
            dx, dy = (1, 0) if b[0] > a[0] else (0, 1)
            start = (a[0] + dx, a[1] + dy, top)
            end = (b[0] - dx, b[1] - dy, top)
            order.append(len(comps))
            comps.append(ComponentSpec(f"b{k}-{n}", Kind.BEAM, s - 1, None, (start, end),
                                       (here[a], here[b]), False, ()))  # fmt: skip
        bays = [(i * s, j * s) for j in range(ny) for i in range(nx)] if slabs else []
        for n, (x, y) in enumerate(bays, 1):
            target = ((x + 1, y, top + 1), (x + s - 1, y + s, top + 1))
            under = (beam_of[((x, y), (x + s, y))], beam_of[((x, y + s), (x + s, y + s))])
            order.append(len(comps))
            comps.append(ComponentSpec(f"s{k}-{n}", Kind.SLAB, (s - 1) * (s + 1), None, target,
                                       under, False, ()))  # fmt: skip
    return comps, order, cols


def _shift(pose, offset: tuple[int, int]):
    return tuple((x + offset[0], y + offset[1], z) for x, y, z in pose)


def _with_reach(draft: Scenario, n: int) -> Scenario:
    """Tower cranes evenly around the construction area, radius grown until all is carried."""
    x0, y0, x1, y1 = draft.construction_area
    X, Y, _ = draft.size
    ring = [(x, y0 - 1) for x in range(x0, x1 + 1)] + [(x1 + 1, y) for y in range(y0, y1 + 1)]
    ring += [(x, y1 + 1) for x in range(x1, x0 - 1, -1)]
    ring += [(x0 - 1, y) for y in range(y1, y0 - 1, -1)]
    ring = [(min(max(x, 0), X - 1), min(max(y, 0), Y - 1)) for x, y in ring]
    bases = [ring[(i * len(ring)) // n] for i in range(n)]

    def with_radius(radius: int) -> Scenario:
        return replace(draft, crane_specs=tuple(CraneSpec(b, float(radius)) for b in bases))

    # Reach only grows with the radius: binary search for the smallest that carries all;
    # the site's diagonal reaches every cell from every base, which always works.
    lo, hi = 3, math.ceil(math.hypot(X, Y))
    while lo < hi:
        mid = (lo + hi) // 2
        if uncarriable(with_radius(mid)) is None:
            hi = mid
        else:
            lo = mid + 1
    return with_radius(hi)


def _with_obstacles(draft: Scenario, count: int, spots: list[Box], rng: random.Random) -> Scenario:
    """Up to ``count`` boxes from the yard's free spots, each kept only if the site loads."""
    rng.shuffle(spots)
    kept: list[Box] = []
    for box in spots:
        if len(kept) == count:
            break
        candidate = replace(draft, obstacles=tuple(sorted([*kept, box], key=_box_key)))
        try:
            _parse(candidate)
        except ScenarioError:
            continue  # it would make the site unsolvable (or break a load rule): drop it
        kept.append(box)
    return replace(draft, obstacles=tuple(sorted(kept, key=_box_key)))


def _box_key(b: Box) -> tuple:
    return (b.lo, b.hi)
