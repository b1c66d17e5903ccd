"""Seeds for the copies of an environment, derived from one run seed.

``seed + i`` (SB3's default) makes copy 1 of run seed 0 replay copy 0 of run seed 1; seeds
spawned from ``numpy.random.SeedSequence(seed)`` are independent across copies and runs.
"""

from __future__ import annotations

import numpy as np


def copy_seeds(seed: int | None, n: int) -> list[int | None]:
    """``n`` independent reset seeds from ``seed`` (``None`` -> ``n`` times ``None``)."""
    if seed is None:
        return [None] * n
    return [int(s.generate_state(1)[0]) for s in np.random.SeedSequence(int(seed)).spawn(n)]


VALIDATION_FIRST = 2_000_000  # validation episodes (model selection): never evaluation seeds


def evaluation_seeds(n: int, first: int = 1_000_000) -> list[int]:
    """Reset seeds of evaluation episodes: ``first .. first + n - 1``, far from any seed a
    training copy draws in practice, and the same for every algorithm and run seed."""
    return list(range(first, first + n))
