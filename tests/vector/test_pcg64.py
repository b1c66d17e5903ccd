"""The compiled generator equals numpy's, draw by draw (``multicrane.vector.pcg64``).

Millions of raw outputs and doubles, interleaved bounded integers and doubles (numpy's 32-bit
buffer included), ``choice`` with renormalised weights, numpy's pairwise sum and the state
after every run, against ``np.random.Generator(np.random.PCG64(...))``.
"""

from __future__ import annotations

import numba
import numpy as np
import pytest

from multicrane.vector import pcg64
from multicrane.vector.pcg64 import PAIRWISE_DEPTH, generator_of, state_of


@numba.njit(cache=True)
def _raw(rng, out):
    for i in range(len(out)):
        out[i] = pcg64.next_uint64(rng, 0)


@numba.njit(cache=True)
def _mixed(rng, ns, out):
    """``ns[i] == 0``: a double; else ``integers(ns[i])``."""
    for i in range(len(ns)):
        out[i] = pcg64.next_double(rng, 0) if ns[i] == 0 else pcg64.bounded(rng, 0, ns[i])


@numba.njit(cache=True)
def _choices(rng, weights, sizes, out, cdf, frames, partial):
    start = 0
    for i in range(len(sizes)):
        n = sizes[i]
        out[i] = pcg64.choice(rng, 0, weights[start : start + n], n, cdf, frames, partial)
        start += n


@numba.njit(cache=True)
def _sum(a, frames, partial):
    return 0.0 + pcg64.pairwise_sum(a, len(a), frames, partial)


def _scratch():
    return np.zeros((PAIRWISE_DEPTH, 3), dtype=np.int64), np.zeros(PAIRWISE_DEPTH)


def _pair(seed: int):
    g = np.random.Generator(np.random.PCG64(seed))
    return g, state_of(g)[None].copy()


@pytest.mark.parametrize("seed", [0, 12345, 2**63 + 7])
def test_raw_outputs_and_doubles(seed):
    g, rng = _pair(seed)
    out = np.empty(1_000_000, dtype=np.uint64)
    _raw(rng, out)
    assert np.array_equal(out, g.bit_generator.random_raw(len(out)))
    ns = np.zeros(1_000_000, dtype=np.int64)
    doubles = np.empty(len(ns))
    _mixed(rng, ns, doubles)
    assert np.array_equal(doubles, g.random(len(ns)))
    assert np.array_equal(rng[0], state_of(g))


def test_bounded_integers_share_numpys_32_bit_buffer():
    g, rng = _pair(11)
    draw = np.random.default_rng(0)
    ns = draw.integers(1, 50, size=200_000) * (draw.random(200_000) < 0.7)
    ns[::97] = draw.choice([2**32, 2**31 + 12345, 2**32 - 1, 1_000_003], size=len(ns[::97]))
    out = np.empty(len(ns))
    _mixed(rng, ns, out)
    expected = [g.random() if n == 0 else g.integers(n) for n in ns.tolist()]
    assert np.array_equal(out, expected)
    assert np.array_equal(rng[0], state_of(g))


def test_pairwise_sum_is_numpys():
    draw = np.random.default_rng(1)
    frames, partial = _scratch()
    for n in [*range(300), 511, 1000, 1024, 1350, 4097, 8191, 100_003]:
        for _ in range(5):
            a = draw.random(n) * 10.0 ** draw.integers(-8, 8, size=n)
            assert _sum(a, frames, partial) == a.sum(), n


def test_choice_with_renormalised_weights():
    """``Generator.choice(n, p=w / w.sum())``, as ``draw_start`` calls it, 20,000 times."""
    g, rng = _pair(5)
    draw = np.random.default_rng(2)
    sizes = draw.integers(1, 700, size=20_000)
    tables = []
    for n in sizes:
        w = draw.random(n) * (draw.random(n) < 0.7)
        if draw.random() < 0.5:  # equal weights, as the start rule's bands give
            w = (w > 0) / float(draw.integers(1, 1000))
        w[draw.integers(n)] = 0.5 if not w.any() else w.max()
        tables.append(w)
    out = np.empty(len(sizes), dtype=np.int64)
    _choices(rng, np.concatenate(tables), sizes, out, np.empty(sizes.max()), *_scratch())
    expected = [int(g.choice(len(w), p=w / w.sum())) for w in tables]
    assert out.tolist() == expected
    assert np.array_equal(rng[0], state_of(g))


def test_state_round_trip_and_other_bit_generators():
    g, rng = _pair(3)
    g.integers(2)  # leaves a 32-bit half in the buffer
    again = generator_of(state_of(g))
    assert again.bit_generator.state == g.bit_generator.state
    assert again.integers(2**32, size=5).tolist() == g.integers(2**32, size=5).tolist()
    with pytest.raises(ValueError, match="PCG64"):
        state_of(np.random.Generator(np.random.MT19937(1)))
