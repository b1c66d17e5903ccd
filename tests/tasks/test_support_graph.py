"""``multicrane.tasks.support_graph``: chains and dependents against hand-worked graphs and a
brute-force reference on random acyclic graphs."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import multicrane
from multicrane.sim.site import Site
from multicrane.tasks.support_graph import support_chains

# target_supports (per target, the targets below it), chain, dependents
CASES = [
    ([], [], []),
    ([[]], [0], [0]),
    ([[], [0], [1]], [2, 1, 0], [2, 1, 0]),  # a column of three
    ([[], [], [0, 1]], [1, 1, 0], [1, 1, 0]),  # a beam on two columns
    # two columns, a beam on both, a slab on the beam, a third column alone
    ([[], [], [0, 1], [2], []], [2, 2, 1, 0, 0], [2, 2, 1, 0, 0]),
    # a diamond: 0 under 1 and 2, both under 3; 3 counted once among 0's dependents
    ([[], [0], [0], [1, 2]], [2, 1, 1, 0], [3, 1, 1, 0]),
    ([[], [0, 0]], [1, 0], [1, 0]),  # a support named twice
]


@pytest.mark.parametrize(("supports", "chain", "dependents"), CASES)
def test_chains_and_dependents_of_small_graphs(supports, chain, dependents):
    got_chain, got_dependents = support_chains(supports)
    assert got_chain.tolist() == chain
    assert got_dependents.tolist() == dependents


def test_a_cycle_is_refused_with_its_targets():
    with pytest.raises(ValueError, match=r"cycle: targets \[0, 1, 2\] are on it or under it"):
        support_chains([[], [0, 2], [1]])


def _reference(supports):
    """Depth-first search over the dependents of each target, no shared work."""
    n = len(supports)
    above = [[t for t in range(n) if s in supports[t]] for s in range(n)]

    def chain(t):
        return max((1 + chain(d) for d in above[t]), default=0)

    def reach(t):
        out = set()
        for d in above[t]:
            out |= {d} | reach(d)
        return out

    return [chain(t) for t in range(n)], [len(reach(t)) for t in range(n)]


@st.composite
def acyclic(draw):
    n = draw(st.integers(1, 14))
    # a target only stands on targets with smaller indices, then the indices are shuffled
    below = [draw(st.lists(st.integers(0, t - 1), max_size=3)) if t else [] for t in range(n)]
    perm = draw(st.permutations(range(n)))
    out = [[] for _ in range(n)]
    for t in range(n):
        out[perm[t]] = [perm[s] for s in below[t]]
    return out


@settings(max_examples=200, deadline=None)
@given(acyclic())
def test_random_acyclic_graphs_match_the_brute_force_reference(supports):
    chain, dependents = support_chains(supports)
    assert (chain.tolist(), dependents.tolist()) == _reference(supports)


@pytest.mark.parametrize("name", multicrane.scenario_names())
def test_every_shipped_site_has_acyclic_supports_and_some_chain(name):
    site = Site(multicrane.load_scenario(name))
    chain, dependents = support_chains(site.target_supports)
    assert (chain <= dependents).all() and (dependents < len(chain)).all()
    if any(site.target_supports):
        assert chain.max() >= 1
