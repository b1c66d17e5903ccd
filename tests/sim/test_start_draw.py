"""``weighted_index`` (the random start's draw) against ``Generator.choice`` with ``p``: the
same index and the same generator state afterwards, for any weights and seed."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from multicrane.sim.start import weighted_index

weights = st.lists(st.floats(0.0, 1.0, allow_nan=False), min_size=1, max_size=60).filter(
    lambda w: sum(w) > 1e-6
)


@settings(max_examples=300, deadline=None)
@given(weights, st.integers(0, 2**32 - 1), st.integers(1, 5))
def test_weighted_index_is_generator_choice(w, seed, draws):
    w = np.asarray(w, dtype=np.float64)
    p = w / w.sum()
    ours, numpys = np.random.default_rng(seed), np.random.default_rng(seed)
    for _ in range(draws):
        assert weighted_index(ours, p) == int(numpys.choice(len(p), p=p))
    assert ours.random() == numpys.random()  # the streams stay in step
