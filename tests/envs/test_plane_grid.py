"""The plane grid's planes equal a column maximum over the cells' bits, after any painting."""

from __future__ import annotations

import numpy as np

import multicrane
from multicrane.envs.observation import MULTI_AGENT_PLANES
from multicrane.envs.paper_env import PAPER_PLANES
from multicrane.envs.plane_grid import HEIGHT, N_BITS, PlaneGrid


def column_maximum(bits: np.ndarray, spec, height: int) -> np.ndarray:
    """The planes the former numpy refresh computed: per column and plane, the largest value
    of a cell whose bits meet the plane's mask."""
    X, Y, Hp = bits.shape
    z = np.arange(Hp, dtype=np.float32) / (height if spec.normalise else 1)
    out = np.zeros((X * Y, spec.n), dtype=np.float32)
    for f, (mask, kind) in enumerate(zip(spec.masks, spec.values, strict=True)):
        value = z if kind == HEIGHT else (z > 0).astype(np.float32)
        has = (bits.reshape(X * Y, Hp) & mask) != 0
        out[:, f] = (has * value).max(axis=1)
    return out


def test_random_painting_matches_the_column_maximum():
    sim = multicrane.parallel_env("e3s2").sim
    X, Y, H = sim.scenario.size
    rng = np.random.default_rng(5)
    inside = [
        sim.site.lin(x, y, z) for x in range(X) for y in range(Y) for z in range(1, H + 1)
    ]
    for spec in (MULTI_AGENT_PLANES, PAPER_PLANES):
        grid = PlaneGrid(sim.site, spec)
        grid.reset()
        bits = np.zeros((X, Y, H + 1), dtype=np.uint8)  # the reference: one byte per cell
        planes = np.zeros(X * Y * spec.n, dtype=np.float32)
        for _ in range(300):
            cells = rng.choice(inside, size=rng.integers(1, 6)).tolist()
            new_cells = rng.choice(inside, size=rng.integers(0, 6)).tolist()
            clear, put = (int(v) for v in rng.integers(0, 1 << N_BITS, size=2))
            grid.paint(cells, clear, put, new_cells)
            for j in cells:
                x, y, z = sim.site.cell(j)
                bits[x, y, z] &= ~clear & 0xFF
            for j in new_cells:
                x, y, z = sim.site.cell(j)
                bits[x, y, z] |= put
            grid.refresh(memoryview(planes))
            expected = column_maximum(bits, spec, H)
            np.testing.assert_array_equal(planes.reshape(X * Y, spec.n), expected)


def test_cells_outside_the_site_are_ignored():
    sim = multicrane.parallel_env("e3s2").sim
    grid = PlaneGrid(sim.site, MULTI_AGENT_PLANES)
    grid.reset()
    planes = np.zeros(sim.scenario.size[0] * sim.scenario.size[1] * 7, dtype=np.float32)
    ground = sim.site.lin(0, 0, 0)  # the ground layer below the site
    grid.paint([], 0, 0b1111111, [ground])
    grid.refresh(memoryview(planes))
    assert not planes.any()
