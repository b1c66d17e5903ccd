"""The solvability check's flood fill (run sweeps) equals a plain one-cell-a-step flood fill."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from multicrane.scenario.solvable import _flood


def _reference_flood(fits: np.ndarray, start: tuple[int, int, int]) -> np.ndarray:
    """Grow the reached set by one unit move per round until nothing new fits."""
    seen = np.zeros_like(fits)
    seen[start] = True
    frontier = seen.copy()
    while frontier.any():
        grown = frontier.copy()
        for axis in range(3):
            lo = [slice(None)] * 3
            hi = [slice(None)] * 3
            lo[axis], hi[axis] = slice(1, None), slice(None, -1)
            grown[tuple(lo)] |= frontier[tuple(hi)]
            grown[tuple(hi)] |= frontier[tuple(lo)]
        frontier = grown & fits & ~seen
        seen |= frontier
    return seen


@settings(max_examples=300, derandomize=True, deadline=None)
@given(
    shape=st.tuples(*[st.integers(1, 8)] * 3),
    density=st.floats(0.0, 1.0),
    seed=st.integers(0, 2**32 - 1),
    where=st.tuples(*[st.floats(0.0, 0.999)] * 3),
)
def test_flood_equals_the_reference(shape, density, seed, where):
    fits = np.random.default_rng(seed).random(shape) < density
    start = tuple(int(w * n) for w, n in zip(where, shape, strict=True))
    fits[start] = True  # the solvability check floods from fitting positions only
    assert np.array_equal(_flood(fits, start), _reference_flood(fits, start))


def test_flood_follows_a_winding_corridor():
    fits = np.zeros((7, 7, 1), dtype=bool)
    fits[0, :, 0] = fits[:, 6, 0] = fits[6, :, 0] = fits[2:, 0, 0] = True  # a spiral arm
    fits[3, 3, 0] = True  # an island: not reached
    reached = _flood(fits, (0, 0, 0))
    assert reached.sum() == fits.sum() - 1 and not reached[3, 3, 0]
