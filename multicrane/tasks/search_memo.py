"""Answers of the carrier's space-time searches, kept for the copies of one episode's site.

Rollout planners play many copies of one site from one state (``multicrane.envs.rollout_copy``:
the guarded search, sampled orders, the look-ahead), and the copies ask the same searches again
and again: on a large hall, a third of a first decision's searches had been asked before. A
search's answer (its path, or none, and the states it expanded) is a function of its inputs:

- the reservation rows in use (``ReservationArrays``), byte for byte;
- the component, its shape, start, start time, goal, stop poses, the crane's zone, whether it is
  lifted, and the carrier's slack and expansion cap;
- the fit and the distances to the goal (``multicrane.tasks.distance_oracle``), read from the
  site, the yard and the cells of the arrived and assembled components: within one episode the
  yard is fixed (the pick-up poses) and those cells follow from the statuses and filled
  targets.

``SearchMemo`` keeps the answers under 16 bytes of a SHA-256 digest of those inputs. It
serves one yard: a site whose pick-up poses differ (another episode) empties it. Sites with
events get none (a late delivery changes the yard without a status change;
``Carrier.share_searches``). It holds at most ``capacity`` answers and starts afresh when
full.
"""

from __future__ import annotations

import hashlib

import numpy as np

from multicrane.tasks.reservation_arrays import ReservationArrays


class SearchMemo:
    """Search answers by a digest of their inputs (module doc), for one yard."""

    def __init__(self, pickup: list[list[int]], capacity: int = 50_000):
        self.capacity = int(capacity)
        self._answers: dict[bytes, tuple[tuple[int, ...] | None, int]] = {}
        self._yard = [list(p) for p in pickup]
        self._checked = pickup  # the pick-up list last found equal to the yard
        self.hits = 0

    def key(
        self, state, res: ReservationArrays, rel: tuple[int, ...], stops: set[int],
        scalars: tuple[int, ...],
    ) -> bytes:  # fmt: skip
        """The digest of one search's inputs: ``state`` the site's ``SiteState``, ``scalars``
        the component, start, start time, goal, zone, lift flag, slack and cap."""
        if state.pickup is not self._checked:
            if state.pickup != self._yard:  # another yard: nothing kept applies
                self._answers.clear()
                self._yard = [list(p) for p in state.pickup]
            self._checked = state.pickup
        digest = hashlib.sha256()  # (SHA-256 has hardware help: twice BLAKE2b's speed here)
        digest.update(np.array(scalars + (len(rel),) + rel, dtype=np.int64).tobytes())
        digest.update(np.array(sorted(stops), dtype=np.int64).tobytes())
        digest.update(state.status.tobytes())
        digest.update(state.filled.tobytes())
        digest.update(res.rows[: res.n].tobytes())
        return digest.digest()[:16]

    def get(self, key: bytes) -> tuple[list[int] | None, int] | None:
        """``(path, expansions)`` of the search with this digest, or None if not kept."""
        kept = self._answers.get(key)
        if kept is None:
            return None
        self.hits += 1
        path, expansions = kept
        return (None if path is None else list(path)), expansions

    def put(self, key: bytes, path: list[int] | None, expansions: int) -> None:
        if len(self._answers) >= self.capacity:
            self._answers.clear()
        self._answers[key] = (None if path is None else tuple(path), expansions)

    def __len__(self) -> int:
        return len(self._answers)


def remembered(memo: SearchMemo | None, search, state, res: ReservationArrays,
               rel: tuple[int, ...], stops: set[int], scalars: tuple[int, ...]):  # fmt: skip
    """``search()`` (``(path, expansions)``), or its kept answer when ``memo`` has one for
    these inputs (``SearchMemo.key``); without a memo, ``search()``."""
    if memo is None:
        return search()
    key = memo.key(state, res, rel, stops, scalars)
    kept = memo.get(key)
    if kept is None:
        kept = search()
        memo.put(key, *kept)
    return kept
