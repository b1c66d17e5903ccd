"""The shared plan-view planes, kept up to date cell by cell: one height mask per column and bit.

Every cell of the site carries up to eight bits (``multicrane.envs.observation``: obstacle,
initial, ready, in transit, at target, free target, over the limit, any target). A plane of a
``PlaneSpec`` holds, per (x, y) column, the value of the highest cell whose bits meet the
plane's mask (its height, or a 0/1 mark). ``PlaneGrid`` keeps, per column and bit, an int
whose bit ``z`` is set when the cell at height ``z`` carries that bit; painting sets and
clears those bits and notes the (column, bit) pairs it touched, and ``refresh`` rewrites
only the plane entries of those pairs: a column's top cell for a plane is the highest set
bit of the OR of its bits' masks (``int.bit_length``), so no column is scanned.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from multicrane.sim.site import Site

N_SHARED = 7
# Bits of a cell; the first seven are also the shared channels, in this order.
OBSTACLE, INITIAL, READY, IN_TRANSIT, AT_TARGET, FREE_TARGET, OVER_LIMIT = range(N_SHARED)
ANY_TARGET = 7  # a target cell, free or filled (never changes)
N_BITS = 8

HEIGHT, MARK = 0, 1  # what a plane holds: the top cell's height, or 1 where any cell qualifies


@dataclass(frozen=True)
class PlaneSpec:
    """Which plan-view planes an Observer keeps: per plane, the grid bits that qualify a
    cell, and whether it holds the top height (``HEIGHT``) or a 0/1 mark (``MARK``)."""

    masks: tuple[int, ...]
    values: tuple[int, ...]
    normalise: bool  # heights divided by the site height

    @property
    def n(self) -> int:
        return len(self.masks)


class PlaneGrid:
    """Bits per cell of a site's plan, and the planes of ``spec`` derived from them."""

    def __init__(self, site: Site, spec: PlaneSpec):
        X, Y, H = site.scenario.size
        # Per padded linear cell index: the key of its column's bit 0 (column * N_BITS; -1
        # outside the site, the ground and the sky included) and 1 << its height.
        column = np.full(site.shape, -1, dtype=np.int64)
        column[1 : X + 1, 1 : Y + 1, 1 : H + 1] = np.arange(X * Y).reshape(X, Y, 1) * N_BITS
        self._key = column.reshape(-1).tolist()
        z = np.broadcast_to(np.arange(H + 2), site.shape).reshape(-1)
        self._zbit = [1 << int(v) for v in z]
        self._size = X * Y * N_BITS
        self._bits_of = [tuple(b for b in range(N_BITS) if v >> b & 1) for v in range(256)]
        # A plane's value for a column whose top qualifying cell is at height z, indexed by
        # z + 1 (the mask's bit length; 0: no such cell): the height or the mark, in float32.
        z_value = np.arange(H + 1, dtype=np.float32) / (H if spec.normalise else 1)
        by_length = [
            (0.0, *(float(v) for v in (z_value if kind == HEIGHT else z_value > 0)))
            for kind in spec.values
        ]
        # Per bit: (plane, its values by bit length, the plane's other bits) of each plane
        # the bit feeds.
        self._feeds = [
            tuple(
                (f, by_length[f], tuple(o for o in self._bits_of[m] if o != b))
                for f, m in enumerate(spec.masks)
                if m >> b & 1
            )
            for b in range(N_BITS)
        ]
        self._n_planes = spec.n

    def reset(self) -> None:
        """No bit on any cell (the planes must be zero too)."""
        self._mask = [0] * self._size
        self._touched: set[int] = set()

    def paint(
        self, cells: list[int], bits: int, new_bits: int, new_cells: list[int] | None = None
    ) -> None:
        """Clear ``bits`` on ``cells``, then set ``new_bits`` on ``new_cells`` (default: same)."""
        key, zbit, mask, touched = self._key, self._zbit, self._mask, self._touched
        if bits:
            clear = self._bits_of[bits]
            for j in cells:
                k = key[j]
                if k >= 0:
                    keep = ~zbit[j]
                    for b in clear:
                        mask[k + b] &= keep
                        touched.add(k + b)
        if new_bits:
            put = self._bits_of[new_bits]
            for j in cells if new_cells is None else new_cells:
                k = key[j]
                if k >= 0:
                    zb = zbit[j]
                    for b in put:
                        mask[k + b] |= zb
                        touched.add(k + b)

    def refresh(self, planes: memoryview) -> None:
        """Rewrite the plane entries of every (column, bit) painted since the last call into
        ``planes`` (flat float32, ``(X * Y, n)`` row-major)."""
        mask, feeds, n = self._mask, self._feeds, self._n_planes
        for k in self._touched:
            bit = k % N_BITS
            base = k - bit
            row = base // N_BITS * n
            for f, values, others in feeds[bit]:
                m = mask[k]
                for b in others:
                    m |= mask[base + b]
                planes[row + f] = values[m.bit_length()]
        self._touched.clear()
