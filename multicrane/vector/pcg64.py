"""numpy's PCG64 generator and the draws ``draw_start`` makes, compiled, one state per copy.

A copy's generator is five ``uint64`` words in a row of an ``[B, 5]`` array: the 128-bit LCG
state (high, low), its increment (high, low) and numpy's 32-bit buffer (``has_uint32 << 32 |
uinteger``). ``state_of(generator)`` reads a ``np.random.Generator(np.random.PCG64(...))`` into
such a row and ``generator_of(row)`` gives one back, so a copy's stream continues exactly where
numpy's would. The kernels reproduce numpy (2.x) draw by draw:

- ``next_double``: ``Generator.random()`` (53 high bits of the next 64-bit output);
- ``bounded``: ``Generator.integers(n)`` for ``n <= 2**32`` (Lemire's method on 32-bit draws,
  which use and refill the buffer; ``n == 1`` draws nothing);
- ``pairwise_sum``: ``ndarray.sum()`` of a float64 vector (numpy's pairwise summation);
- ``choice``: ``Generator.choice(len(w), p=w / w.sum())``: ``p.cumsum()``, divided by its last
  entry, searched (``side="right"``) with one ``random()`` draw;
- ``permutation``: ``Generator.permutation(n)`` (a Fisher-Yates shuffle of ``arange(n)``
  from the last entry down, each swap index drawn by ``interval``, numpy's masked rejection).

tests/vector/test_pcg64.py checks each against numpy on millions of draws.
"""

from __future__ import annotations

import numpy as np

from multicrane.vector.compiled import kernel

RNG_WORDS = 5
_MASK64 = (1 << 64) - 1
_MUL_HI = np.uint64(2549297995355413924)
_MUL_LO = np.uint64(4865540595714422341)
_LOW32 = np.uint64(0xFFFFFFFF)
_U32 = np.uint64(32)
_U11 = np.uint64(11)
_U58 = np.uint64(58)
_U63 = np.uint64(63)
_ONE = np.uint64(1)
_ZERO = np.uint64(0)
_HAS_UINT32 = np.uint64(1 << 32)
_PW_BLOCK = 128  # numpy's PW_BLOCKSIZE
PAIRWISE_DEPTH = 64  # rows of the scratch stacks of pairwise_sum (numpy: n < 2**63)


def state_of(generator: np.random.Generator) -> np.ndarray:
    """The five words of a PCG64 generator's state (ValueError for another bit generator)."""
    s = generator.bit_generator.state
    if s["bit_generator"] != "PCG64":
        raise ValueError(f"a PCG64 generator is needed, got {s['bit_generator']}")
    state, inc = s["state"]["state"], s["state"]["inc"]
    buffer = (int(s["has_uint32"]) << 32) | int(s["uinteger"])
    words = (state >> 64, state & _MASK64, inc >> 64, inc & _MASK64, buffer)
    return np.array(words, dtype=np.uint64)


def seed_states(rng: np.ndarray, seed) -> None:
    """Seed every row of ``rng`` ([B, 5]) as the vector envs' ``reset(seed=...)`` does: an
    int or None gives copy ``i`` the ``i``-th child of ``np.random.SeedSequence(seed)``; a
    sequence of B seeds gives copy ``i`` the generator of ``np.random.default_rng(seed[i])``
    (what a one-site env's ``reset(seed=seed[i])`` uses)."""
    n = len(rng)
    if seed is None or isinstance(seed, int | np.integer):
        children = np.random.SeedSequence(seed).spawn(n)
    else:
        seeds = list(seed)
        if len(seeds) != n:
            raise ValueError(f"reset(): give one seed per copy ({n}), got {len(seeds)}")
        children = [np.random.SeedSequence(s) for s in seeds]
    for b, child in enumerate(children):
        rng[b] = state_of(np.random.Generator(np.random.PCG64(child)))


def generator_of(words: np.ndarray) -> np.random.Generator:
    """A numpy generator in the state these five words hold."""
    w = [int(v) for v in words]
    bit = np.random.PCG64()
    bit.state = {
        "bit_generator": "PCG64",
        "state": {"state": (w[0] << 64) | w[1], "inc": (w[2] << 64) | w[3]},
        "has_uint32": w[4] >> 32,
        "uinteger": w[4] & 0xFFFFFFFF,
    }
    return np.random.Generator(bit)


@kernel
def _mul_hi64(a, b):
    """The high 64 bits of the 128-bit product of two uint64."""
    a_lo, a_hi = a & _LOW32, a >> _U32
    b_lo, b_hi = b & _LOW32, b >> _U32
    lo_lo = a_lo * b_lo
    hi_lo = a_hi * b_lo
    lo_hi = a_lo * b_hi
    cross = (lo_lo >> _U32) + (hi_lo & _LOW32) + lo_hi
    return a_hi * b_hi + (hi_lo >> _U32) + (cross >> _U32)


@kernel
def next_uint64(rng, b):
    """Advance copy ``b``'s LCG and return its XSL-RR output (numpy's ``pcg64_next64``)."""
    hi, lo = rng[b, 0], rng[b, 1]
    new_lo = lo * _MUL_LO
    new_hi = _mul_hi64(lo, _MUL_LO) + hi * _MUL_LO + lo * _MUL_HI
    inc_lo = rng[b, 3]
    total_lo = new_lo + inc_lo
    carry = _ONE if total_lo < new_lo else _ZERO
    new_hi = new_hi + rng[b, 2] + carry
    rng[b, 0], rng[b, 1] = new_hi, total_lo
    x = new_hi ^ total_lo
    rot = new_hi >> _U58
    return (x >> rot) | (x << ((_U63 + _ONE - rot) & _U63))


@kernel
def next_uint32(rng, b):
    """numpy's ``pcg64_next32``: the buffered high half, else the low half of a new draw."""
    buffer = rng[b, 4]
    if buffer & _HAS_UINT32:
        rng[b, 4] = buffer & _LOW32  # numpy clears the flag and keeps the value
        return buffer & _LOW32
    x = next_uint64(rng, b)
    rng[b, 4] = _HAS_UINT32 | (x >> _U32)
    return x & _LOW32


@kernel
def next_double(rng, b):
    """``Generator.random()``."""
    return np.float64(next_uint64(rng, b) >> _U11) * (1.0 / 9007199254740992.0)


@kernel
def bounded(rng, b, n):
    """``Generator.integers(n)`` for ``1 <= n <= 2**32`` (Lemire's method, 32-bit draws)."""
    if n == 1:
        return 0
    span = np.uint64(n)
    if span == _LOW32 + _ONE:
        return np.int64(next_uint32(rng, b))
    m = next_uint32(rng, b) * span
    leftover = m & _LOW32
    if leftover < span:
        threshold = (_LOW32 - (span - _ONE)) % span
        while leftover < threshold:
            m = next_uint32(rng, b) * span
            leftover = m & _LOW32
    return np.int64(m >> _U32)


@kernel
def interval(rng, b, top):
    """numpy's ``random_interval(top)`` for ``0 <= top < 2**32``: a uniform integer in
    ``0..top``, 32-bit draws masked to the smallest all-ones mask covering ``top`` and
    rejected while above it."""
    if top == 0:
        return 0
    mask = np.uint64(top)
    mask |= mask >> _ONE
    mask |= mask >> np.uint64(2)
    mask |= mask >> np.uint64(4)
    mask |= mask >> np.uint64(8)
    mask |= mask >> np.uint64(16)
    value = next_uint32(rng, b) & mask
    while value > np.uint64(top):
        value = next_uint32(rng, b) & mask
    return np.int64(value)


@kernel
def permutation(rng, b, out, n):
    """``Generator.permutation(n)`` into ``out[:n]`` (``n < 2**32``)."""
    for i in range(n):
        out[i] = i
    for i in range(n - 1, 0, -1):
        j = interval(rng, b, i)
        out[i], out[j] = out[j], out[i]


@kernel
def _block_sum(a, start, n):
    """numpy's pairwise sum of a block of at most ``PW_BLOCKSIZE`` entries."""
    if n < 8:
        res = 0.0
        for i in range(n):
            res += a[start + i]
        return res
    r0, r1, r2, r3 = a[start], a[start + 1], a[start + 2], a[start + 3]
    r4, r5, r6, r7 = a[start + 4], a[start + 5], a[start + 6], a[start + 7]
    i = 8
    while i < n - (n % 8):
        j = start + i
        r0, r1, r2, r3 = r0 + a[j], r1 + a[j + 1], r2 + a[j + 2], r3 + a[j + 3]
        r4, r5, r6, r7 = r4 + a[j + 4], r5 + a[j + 5], r6 + a[j + 6], r7 + a[j + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[start + i]
        i += 1
    return res


@kernel
def pairwise_sum(a, n, frames, partial):
    """numpy's pairwise sum of ``a[:n]`` (float64, contiguous): blocks of at most
    ``PW_BLOCKSIZE`` entries summed as ``_block_sum``, longer runs split in two (the first
    part a multiple of 8) and the two sums added. numpy recurses; here the recursion runs on
    the scratch stacks ``frames`` ((64, 3) int64: start, length, stage) and ``partial``
    ((64,) float64), since a kernel neither allocates nor recurses across cached modules."""
    top, n_partial = 0, 0
    frames[0, 0], frames[0, 1], frames[0, 2] = 0, n, 0
    while top >= 0:
        s, m, stage = frames[top, 0], frames[top, 1], frames[top, 2]
        half = m // 2 - (m // 2) % 8
        if m <= _PW_BLOCK:
            partial[n_partial] = _block_sum(a, s, m)
            n_partial += 1
            top -= 1
        elif stage == 0:  # the first part next
            frames[top, 2] = 1
            top += 1
            frames[top, 0], frames[top, 1], frames[top, 2] = s, half, 0
        elif stage == 1:  # then the second
            frames[top, 2] = 2
            top += 1
            frames[top, 0], frames[top, 1], frames[top, 2] = s + half, m - half, 0
        else:  # both done: their sum replaces them
            n_partial -= 1
            partial[n_partial - 1] = partial[n_partial - 1] + partial[n_partial]
            top -= 1
    return partial[0]


@kernel
def choice(rng, b, weights, n, cdf, frames, partial):
    """``Generator.choice(n, p=w / w.sum())`` for ``w = weights[:n]`` (some weight > 0);
    ``cdf`` is scratch space of at least ``n`` entries, ``frames`` and ``partial`` that of
    ``pairwise_sum``."""
    total = 0.0 + pairwise_sum(weights, n, frames, partial)  # add.reduce starts from 0.0
    acc = 0.0
    for i in range(n):
        acc += weights[i] / total
        cdf[i] = acc
    last = cdf[n - 1]
    u = next_double(rng, b)
    lo, hi = 0, n  # the first index whose normalised cdf exceeds u (searchsorted, right)
    while lo < hi:
        mid = (lo + hi) >> 1
        if u < cdf[mid] / last:
            hi = mid
        else:
            lo = mid + 1
    return lo
