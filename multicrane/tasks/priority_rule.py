"""The prioritized assignment rule: ready (component, target) pairs ranked, given to idle cranes.

Shared by the motion-level planner (``policies.prioritized``), the task-level planner
(``policies.task_planners.TaskPrioritized``) and the planner's proposal that a set policy may
read beside its observation (``proposals``, ``multicrane.training.set_obs``). ``rank="list"``
ranks by the component's place in the scenario's list order, then by the distance from the
pick-up pose to the target; ``rank="nearest"`` by that distance alone (ties: component,
target); ``rank="chain"`` first by the target's chain, longest first (the most targets standing
on it one above the other, ``multicrane.tasks.support_graph``: a critical-path rule), then as
``"list"``. Each pair in rank order goes to the first idle crane that may take it and is kept
when the carrier's space-time search succeeds, at most ``max_searches`` searches per round.
"""

from __future__ import annotations

import numbers
import weakref
from collections.abc import Callable

import numpy as np

from multicrane.sim.simulator import NOBODY, Simulator
from multicrane.tasks.book import TaskBook
from multicrane.tasks.carrier import Carrier
from multicrane.tasks.support_graph import site_chains

RANKS = ("list", "nearest", "chain")


def list_ranks(scenario, order=None) -> dict[int, int]:
    """Component -> its place in the list order (the rule's ``list_rank``): the scenario's,
    or ``order``, every component index once (e.g. an assembly sequence planned elsewhere;
    the scenario's own order also draws the yard, so a new sequence goes here, not there)."""
    if order is None:
        return {c: i for i, c in enumerate(scenario.order)}
    odd = [c for c in order if not isinstance(c, numbers.Integral) or isinstance(c, bool)]
    if odd:
        raise ValueError(f"order must list component indices (integers), got {odd[:5]}")
    listed = [int(c) for c in order]
    n = scenario.n_components
    if sorted(listed) != list(range(n)):
        missing = sorted(set(range(n)) - set(listed))
        extra = sorted({c for c in listed if not 0 <= c < n or listed.count(c) > 1})
        raise ValueError(f"order must list every component index 0..{n - 1} once: "
                         f"missing {missing}, out of range or repeated {extra}")  # fmt: skip
    return {c: i for i, c in enumerate(listed)}


def ready_pairs(carrier: Carrier, candidates, taken: set[int]) -> tuple[np.ndarray, ...]:
    """The ready (component, target) pairs of a round as arrays ``(rows, comp, target,
    distance)``: each candidate's ready compatible targets not in ``taken`` that a pose of
    its shape covers (``Carrier.pair_distances``: from the pick-up pose to the target's
    pose); ``rows``: the component's place in ``candidates``."""
    comps = np.asarray(candidates, dtype=np.int64)
    dist = carrier.pair_distances()[comps]
    rows, targets = np.nonzero((dist >= 0) & _open_targets(carrier.sim, taken))
    return rows, comps[rows], targets, dist[rows, targets]


def pair_tuples(order, distance, comp, target) -> list[tuple[int, int, int]]:
    """The pairs in ``order`` as ``ranked_pairs`` lists them: ``(distance, comp, target)``."""
    ranked = (distance[order].tolist(), comp[order].tolist(), target[order].tolist())
    return list(zip(*ranked, strict=True))


def ranked_pairs(carrier: Carrier, candidates, taken: set[int], rank: str, list_rank: dict):
    """Ready pairs (``ready_pairs``), best first, as ``(distance, comp, target)`` tuples:
    ranked by (list rank, distance, target), (distance, component, target) or (longest
    chain, list rank, distance, target). Each key orders every pair strictly, so the
    round's pairs are the episode's ranking (``_episode_ranking``) with the others left out."""
    if not candidates:
        return []
    sim = carrier.sim
    comp, targets, d = _episode_ranking(carrier, rank, list_rank)
    chosen = np.zeros(sim.site.n_components, dtype=bool)
    chosen[candidates] = True
    keep = np.flatnonzero(chosen[comp] & _open_targets(sim, taken)[targets])
    return pair_tuples(keep, d, comp, targets)


# id of a distance table -> rank -> (the list ranks it was built with, (comp, target,
# distance)); an entry leaves with its table
_RANKINGS: dict[int, dict[str, tuple[dict, tuple[np.ndarray, ...]]]] = {}


def _episode_ranking(carrier: Carrier, rank: str, list_rank: dict) -> tuple[np.ndarray, ...]:
    """Every pair a pose of its shape covers, best first, as arrays ``(comp, target,
    distance)``; built once per episode's pick-up poses (``Carrier.pair_distances``), rank
    and list order."""
    dist = carrier.pair_distances()
    per_rank = _RANKINGS.get(id(dist))
    if per_rank is None:
        per_rank = _RANKINGS[id(dist)] = {}
        weakref.finalize(dist, _RANKINGS.pop, id(dist), None)
    kept = per_rank.get(rank)
    if kept is not None and kept[0] == list_rank:
        return kept[1]
    chains = site_chains(carrier.sim.site)[0] if rank == "chain" else None
    ranking = rank_pairs(dist, rank, list_rank, chains)
    per_rank[rank] = (dict(list_rank), ranking)
    return ranking


def rank_pairs(dist: np.ndarray, rank: str, list_rank: dict, chains=None) -> tuple[np.ndarray, ...]:
    """Every pair with a distance (``dist``: components x targets, -1 none), best first, as
    arrays ``(comp, target, distance)``; ``chains``: each target's chain (``rank="chain"``)."""
    comp, targets = np.nonzero(dist >= 0)
    d = dist[comp, targets]
    if rank in ("list", "chain"):
        by_comp = np.zeros(dist.shape[0], dtype=np.int64)
        by_comp[list(list_rank)] = list(list_rank.values())
        keys = [targets, d, by_comp[comp]]
        if rank == "chain":
            keys.append(-np.asarray(chains)[targets])
        order = np.lexsort(keys)
    else:
        order = np.lexsort((targets, comp, d))
    return comp[order], targets[order], d[order]


def _open_targets(sim: Simulator, taken: set[int]) -> np.ndarray:
    """(targets,) bool: ready and not in ``taken``."""
    open_ = np.asarray(sim.target_ready, dtype=bool)
    open_[list(taken)] = False
    return open_


def check_rank(rank: str) -> str:
    if rank not in RANKS:
        raise ValueError(f"rank must be one of {', '.join(RANKS)}, got {rank!r}")
    return rank


def assign_in_rank(
    sim: Simulator,
    carrier: Carrier,
    idle: list[int],
    rank: str,
    list_rank: dict[int, int],
    max_searches: int,
    eligible: Callable[[int, int, int], bool],
    start: Callable[[int, int, int], bool],
) -> None:
    """The prioritized rule, shared by both decision levels: ready (component, target) pairs
    best first; each goes to the first idle crane ``eligible(crane, comp, target)`` for it,
    and ``start(crane, comp, target)`` (a space-time search) decides; each component, target
    and crane is used once, and at most ``max_searches`` searches run in a round."""
    candidates = [c for c in sim.claimable_components() if c not in carrier.plans]
    if not candidates:
        return
    pairs = ranked_pairs(carrier, candidates, carrier.taken_targets(), rank, list_rank)
    used_c: set[int] = set()
    used_t: set[int] = set()
    for _, comp, t in pairs:
        if not idle or carrier.round_searches >= max_searches:
            break
        if comp in used_c or t in used_t:
            continue
        crane = next((k for k in idle if eligible(k, comp, t)), NOBODY)
        if crane == NOBODY:
            continue
        if start(crane, comp, t):
            idle.remove(crane)
            used_c.add(comp)
            used_t.add(t)


def propose(book: TaskBook, list_rank: dict[int, int], rank: str = "list",
            max_searches: int = 8) -> list[int]:  # fmt: skip
    """Per crane, the task (``p``) the rule starts for it in this round (``NOBODY``: none),
    each found by ``TaskBook.feasible``, whose plan stays with the crane until ``choose``."""
    sim, carrier = book.sim, book.carrier
    out = [NOBODY] * sim.n_cranes
    idle = book.idle_cranes()
    if not idle or not carrier.may_start(sim.state.step_count):
        return out
    allowed = book.allowed()
    index = book.tasks.index

    def start(crane: int, comp: int, target: int) -> bool:
        p = index[(comp, target)]
        if not book.feasible(crane, p):
            return False
        out[crane] = p
        return True

    assign_in_rank(
        sim, carrier, idle, rank, list_rank, max_searches,
        lambda k, comp, target: bool(allowed[k, index[(comp, target)]]), start,
    )  # fmt: skip
    return out


def proposals(book: TaskBook, list_rank: dict[int, int], rank: str = "list",
              max_searches: int = 8) -> list[int]:  # fmt: skip
    """``propose`` as a dry run (``TaskBook.trial``): the round's answer, with the book and
    the carrier left as they were, so asking it changes no episode."""
    with book.trial() as scratch:
        return propose(scratch, list_rank, rank, max_searches)
