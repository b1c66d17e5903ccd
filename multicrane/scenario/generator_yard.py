"""The generator's yard layout: site size, construction area, start poses or random-start bands.

The building (a column grid ``footprint`` cells wide) sits in a construction area one cell
larger on every side; yard strips lie on one side (low y), two sides (low and high y) or all
around it. With fixed starts the components lie flat at ``z = 1`` in lanes two cells apart
(one free line between lanes, one free cell between components), the strips made just deep
enough to hold them all, components dealt to the strips in turn; a margin of half the longest
beam keeps every pick-up pose (a beam is turned about its centre when lifted) inside the
site. With ``random_start`` the strips are made three times as deep and become the bands of
a ``[random_start]`` table (bands' x ranges may not overlap, so with a yard on several sides
the bands share the strips' x range out). ``free_boxes`` are candidate obstacle boxes in the
yard, for the generator to try. Panels (slabs) lie in a strip of their own on the low-x side
(``add_panel_strip``).
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass, field
from typing import Any

from multicrane.core.kinds import kind_spec
from multicrane.core.schema import Band, Box, ComponentSpec, Pose, RandomStart


@dataclass
class Yard:
    """Where everything is: the site, the construction area, the starts or bands."""

    size: tuple[int, int, int]
    area: tuple[int, int, int, int]
    offset: tuple[int, int]  # where the building's grid origin (0, 0) lies
    starts: dict[int, Pose] = field(default_factory=dict)  # fixed starts by component index
    random_start: RandomStart | None = None
    free_boxes: list[Box] = field(default_factory=list)


def lay_out(comps: list[ComponentSpec], p: dict[str, Any], rng: random.Random) -> Yard:
    """The yard of ``comps`` (targets relative to the grid origin) under parameters ``p``."""
    width = p["bays_x"] * p["span"] + 1
    depth = p["bays_y"] * p["span"] + 1
    height = (p["storeys"] + 1) * p["column_height"]
    lengths = [c.length for c in comps]
    turned = [c.length // 2 for c in comps if kind_spec(c.kind).lifted_about_centre]
    margin = max(turned + [1]) + 1
    longest = max(lengths)
    sides = {"one": 1, "two": 2, "around": 4}[p["yard"]]
    lanes = 1
    while True:
        yard = _try(comps, p, width, depth, height, margin, longest, sides, lanes)
        if yard is not None:
            break
        lanes += 1
    if p["random_start"]:
        yard = _bands(comps, p, width, depth, height, margin, longest, sides, 2 * lanes + 1)
    yard.free_boxes = _spots(yard, rng, 4 * p["obstacles"] + 8)
    return yard


def _geometry(width, depth, height, margin, longest, sides, lanes, reach_len=0):
    """Site size, construction area, grid offset and strip thickness for ``lanes`` lanes."""
    thick = margin + 2 * (lanes - 1) + 2  # lanes, the margin to the edge, one cell to the area
    if sides == 4:
        thick = max(thick, longest + margin + 1)  # side strips must hold a lane's length
    left = thick if sides == 4 else 2
    bottom = thick
    top = thick if sides >= 2 else 2
    if sides < 4:  # a wider site keeps the yard from growing into a long thin strip
        left = max(left, (2 * margin + reach_len - width - 2 + 1) // 2)
        left = max(left, (2 * margin + longest - width - 2 + 1) // 2)  # a lane holds the longest
    X = left + width + 2 + left
    Y = bottom + depth + 2 + top
    area = (left, bottom, left + width + 1, bottom + depth + 1)
    return (X, Y, height), area, (left + 1, bottom + 1), thick


def _lane_length(comps: list[ComponentSpec], sides: int, room: int) -> int:
    """A lane length for a roughly square yard: ``room`` times the components' lengths
    (plus gaps) over ``sides`` strips, lanes two cells apart."""
    total = room * sum(c.length + 1 for c in comps)
    return math.ceil(2 * math.sqrt(total / sides))


def _try(comps, p, width, depth, height, margin, longest, sides, lanes) -> Yard | None:
    size, area, offset, thick = _geometry(
        width, depth, height, margin, longest, sides, lanes, _lane_length(comps, sides, 1)
    )
    X, Y, _ = size
    strips: list[list[list]] = []  # per strip: lanes as [axis, fixed, cursor, end]
    bottom = [["x", margin + 2 * i, margin, X - 1 - margin] for i in range(lanes)]
    strips.append(bottom)
    if sides >= 2:
        strips.append([["x", Y - 1 - margin - 2 * i, margin, X - 1 - margin] for i in range(lanes)])
    if sides == 4:
        lo, hi = area[1], area[3]
        n_side = (thick - margin - 1) // 2
        strips.append([["y", margin + 2 * i, lo, hi] for i in range(n_side)])
        strips.append([["y", X - 1 - margin - 2 * i, lo, hi] for i in range(n_side)])
    starts: dict[int, Pose] = {}
    for i, c in enumerate(comps):
        placed = False
        for k in range(len(strips)):
            for lane in strips[(i + k) % len(strips)]:
                axis, fixed, cur, end = lane
                if cur + c.length - 1 > end:
                    continue
                a, b = cur + c.length - 1, cur
                starts[i] = ((a, fixed, 1), (b, fixed, 1)) if axis == "x" else (
                    (fixed, a, 1), (fixed, b, 1))  # fmt: skip
                lane[2] = cur + c.length + 1
                placed = True
                break
            if placed:
                break
        if not placed:
            return None
    return Yard(size, area, offset, starts)


def _bands(comps, p, width, depth, height, margin, longest, sides, lanes) -> Yard:
    size, area, offset, thick = _geometry(
        width, depth, height, margin, longest, sides, lanes, _lane_length(comps, sides, 3)
    )
    X, Y, _ = size
    x_lo, x_hi = margin + longest - 1, X - 1 - margin
    bottom_y = (margin, thick - 2)
    top_y = (Y - thick + 1, Y - 1 - margin)
    if sides == 1:
        bands = [Band((x_lo, x_hi), bottom_y)]
    elif sides == 2:
        mid = (x_lo + x_hi) // 2
        bands = [Band((x_lo, mid), bottom_y), Band((mid + 1, x_hi), top_y)]
    else:
        ylo, yhi = margin + longest - 1, Y - 1 - margin
        left = Band((margin + longest - 1, thick - 2), (ylo, yhi))
        right = Band((X - thick + 1, X - 1 - margin), (ylo, yhi))
        mid = (thick - 1 + X - thick) // 2
        bands = [left, Band((thick - 1, mid), bottom_y), Band((mid + 1, X - thick), top_y), right]
    rs = RandomStart(z=1, bands=tuple(bands), directions=((-1, 0, 0), (0, -1, 0)))
    return Yard(size, area, offset, random_start=rs)


def _spots(yard: Yard, rng: random.Random, count: int) -> list[Box]:
    """``count`` small boxes at random yard positions (outside the construction area)."""
    X, Y, H = yard.size
    x0, y0, x1, y1 = yard.area
    out: list[Box] = []
    for _ in range(50 * count):
        if len(out) == count:
            break
        dx, dy, dz = rng.randint(1, 2), rng.randint(1, 2), rng.randint(1, min(2, H))
        x, y = rng.randint(0, X - dx), rng.randint(0, Y - dy)
        if x + dx - 1 >= x0 - 1 and x <= x1 + 1 and y + dy - 1 >= y0 - 1 and y <= y1 + 1:
            continue  # in or next to the construction area
        out.append(Box((x, y, 1), (x + dx - 1, y + dy - 1, dz)))
    return out


def add_panel_strip(site: Yard, panels: dict[int, tuple[int, int]]) -> Yard:
    """Room for panels (component index -> its target's sides along x and y): a strip added
    on the low-x side, where they lie flat at ``z = 1`` in columns along y, one free cell
    around each, each oriented as its target (so its pick-up pose is straight above it);
    everything else moves along x to make room. No panels: the site as it is."""
    if not panels:
        return site
    X, Y, H = site.size
    wide = max(w for w, _ in panels.values())
    if max(d for _, d in panels.values()) > Y - 2:
        raise ValueError(f"a panel {max(panels.values())} does not fit the yard's depth {Y}")
    starts: dict[int, Pose] = {}
    x, y = 1, 1
    for i, (w, d) in sorted(panels.items()):
        if y + d - 1 > Y - 2:
            x, y = x + wide + 1, 1
        starts[i] = ((x, y, 1), (x + w - 1, y + d - 1, 1))
        y += d + 1
    dx = x + wide + 1

    def shift(cell):
        return (cell[0] + dx, *cell[1:])

    x0, y0, x1, y1 = site.area
    for i, (a, b) in site.starts.items():
        starts[i] = (shift(a), shift(b))
    boxes = [Box(shift(b.lo), shift(b.hi)) for b in site.free_boxes]
    return Yard((X + dx, Y, H), (x0 + dx, y0, x1 + dx, y1), shift(site.offset), starts,
                site.random_start, boxes)  # fmt: skip
