"""What each target holds up: the longest chain of targets above it and how many depend on it.

A target's *dependents* are the targets that need it assembled first, directly or through
others (``Site.target_supports``, read upwards); its *chain* is the number of targets in the
longest sequence of dependents that starts on it and goes up, itself not counted (0: nothing
waits on it). Filling a target with a long chain early is what critical-path scheduling does:
the chain bounds the makespan of whatever stands on it. Both are fixed by the site.
"""

from __future__ import annotations

import weakref

import numpy as np

_OF_SITE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def site_chains(site) -> tuple[np.ndarray, np.ndarray]:
    """``support_chains`` of a ``multicrane.sim.site.Site``, computed once per site."""
    if site not in _OF_SITE:
        _OF_SITE[site] = support_chains(site.target_supports)
    return _OF_SITE[site]


def support_chains(target_supports: list[list[int]]) -> tuple[np.ndarray, np.ndarray]:
    """``(chain, dependents)`` per target, int64 arrays (module doc). Raises a ValueError if
    the supports form a cycle (a site's loader refuses those)."""
    n = len(target_supports)
    above: list[list[int]] = [[] for _ in range(n)]
    for t, supports in enumerate(target_supports):
        for s in supports:
            above[s].append(t)
    order = _top_down(above, target_supports)
    chain = np.zeros(n, dtype=np.int64)
    reach: list[set[int]] = [set() for _ in range(n)]
    for t in order:  # every dependent of t comes before t
        for d in above[t]:
            chain[t] = max(chain[t], chain[d] + 1)
            reach[t].add(d)
            reach[t] |= reach[d]
    return chain, np.array([len(r) for r in reach], dtype=np.int64)


def _top_down(above: list[list[int]], below: list[list[int]]) -> list[int]:
    """The targets, each after every target that depends on it (Kahn's algorithm from the
    top: the targets nothing depends on come first)."""
    waiting = [len(a) for a in above]
    ready = [t for t, w in enumerate(waiting) if w == 0]
    order = []
    while ready:
        t = ready.pop()
        order.append(t)
        for s in below[t]:
            waiting[s] -= 1
            if waiting[s] == 0:
                ready.append(s)
    if len(order) != len(above):
        stuck = sorted(set(range(len(above))) - set(order))
        raise ValueError(f"the targets' supports form a cycle: targets {stuck[:8]} are on it "
                         "or under it")
    return order
