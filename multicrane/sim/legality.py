"""Legality: what each crane may do now (queries and action masks), kept incrementally.

``Legality`` is the half of ``multicrane.sim.simulator.Simulator`` that judges and never changes
the state: target readiness, claimability, blocked moves and the action masks. The masks are
computed by the same functions the step uses to judge actions. Target readiness changes only
when a component arrives or is assembled; claimability only where a move touched a pick-up
pose; both are cached and recomputed then (``_update_targets``, ``_recheck``).

**Reach** (``Site.reach``, tower cranes): a crane may claim (or, in automatic mode, be given)
a component only when its pick-up pose lies in the crane's zone and some compatible target
in the zone is free (for a beam or panel: ready); a move whose new cells leave the holder's
zone is not legal. Without reach (``_zones is None``) none of this runs.

**Site events** (``multicrane.sim.events``; only with a schedule): a component not yet delivered
cannot be claimed; a crane that is down may only wait; no component cell may enter a closed
cell (moves, lifts), a component with a cell in a closed cell cannot move or be lifted, and a
target with a closed cell is not ready. ``_closing`` is False while no cell is closed, so
without events the checks cost one attribute test.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from multicrane.core.codes import ASSEMBLE, CLAIM_BASE, N_MOVES, WAIT, Status
from multicrane.sim.site import FREE, NOBODY

if TYPE_CHECKING:
    from multicrane.sim.site import Site
    from multicrane.sim.state import SiteState

# Plain ints for the hot path: reading an IntEnum member costs a class __getattr__ in 3.11.
_INITIAL, _IN_TRANSIT, _ARRIVED, _ASSEMBLED = (int(s) for s in Status)


class Legality:
    """Queries over ``self.site`` and ``self.state`` (set by the Simulator that inherits it)."""

    site: Site
    state: SiteState
    auto: bool
    n_cranes: int
    _occ: memoryview  # memoryviews of the state's arrays (see Simulator._bind)
    _status: memoryview
    _moves: memoryview
    _holder: memoryview
    _filled_by: memoryview
    _delivered: memoryview
    _zones: list | None  # Site.reach: per crane, the cells it reaches; None: no reach
    _zone_targets: list[list[list[int]]]  # per crane, per component: compatible targets in zone
    _closing: bool  # some cell is closed now (see Simulator: site events)
    _closed: np.ndarray  # (P,) bool: cells closed now
    _down: list[bool]  # per crane: down now
    targets_version: int  # counts the changes of ``target_ready`` (never reset): a cache key

    # -- queries shared by the rules and the masks -------------------------------------------

    def _watch_pickups(self) -> None:
        """Claimability bookkeeping: which components' pick-up poses cover each cell."""
        self._watch: dict[int, list[int]] = {}
        self._watched_pickup = self.state.pickup
        for i, cells in enumerate(self.state.pickup):
            for j in cells:
                self._watch.setdefault(j, []).append(i)
        if self._zones is not None:
            # Per crane and component: the pick-up pose lies in the zone (fixed per start).
            self._pickup_in_zone = [
                [all(zone[j] for j in cells) for cells in self.state.pickup] for zone in self._zones
            ]

    # -- reach ------------------------------------------------------------------------------

    def in_reach(self, crane: int, comp: int) -> bool:
        """The crane may take this component: its pick-up pose is in the crane's zone and a
        compatible target in the zone is free (a beam's or panel's: ready). Always True
        without reach."""
        if self._zones is None:
            return True
        if not self._pickup_in_zone[crane][comp]:
            return False
        targets = self._zone_targets[crane][comp]
        if self.site.waits[comp]:
            ready = self.target_ready
            return any(ready[t] for t in targets)
        filled_by = self._filled_by
        return any(filled_by[t] == NOBODY for t in targets)

    def move_in_reach(self, crane: int, comp: int, move: int) -> bool:
        """The move keeps the component's cells in the crane's zone (always True without
        reach). An initial component is judged from its pick-up pose."""
        if self._zones is None:
            return True
        zone = self._zones[crane]
        d = self.site.move_delta[move]
        return all(zone[j + d] for j in self._from_cells(comp))

    @property
    def done(self) -> bool:
        return self.state.n_assembled == self.site.n_components

    @property
    def k(self) -> int:
        """Components assembled during this episode (pre-built ones excluded)."""
        return self.state.n_assembled - self.state.n_prebuilt

    def fits(self, comp: int, cells: list[int]) -> bool:
        """True when every cell is free or already held by ``comp``."""
        occ = self._occ
        own = comp + 1
        for j in cells:
            v = occ[j]
            if v != FREE and v != own:
                return False
        return True

    def open_cells(self, cells: list[int]) -> bool:
        """No cell is closed now (always True while nothing is closed)."""
        if not self._closing:
            return True
        closed = self._closed
        return not any(closed[j] for j in cells)

    def crane_up(self, crane: int) -> bool:
        """The crane is available now (not broken down)."""
        return not self._down[crane]

    def delivered(self, comp: int) -> bool:
        """The component is on site (always True without late deliveries)."""
        return bool(self.state.delivered[comp])

    def _lift_ok(self, comp: int) -> bool:
        """A delivered component's pick-up pose is free, and neither it nor its cells are
        closed."""
        st = self.state
        pick = st.pickup[comp]
        if not self.fits(comp, pick):
            return False
        if self._closing:
            return self.open_cells(pick) and self.open_cells(st.cells[comp])
        return True

    def _target_ready_now(self, t: int) -> bool:
        """A target can be filled: it is free, all its supports are assembled and none of
        its cells is closed."""
        filled_by = self._filled_by
        if filled_by[t] != NOBODY:
            return False
        if self._closing and not self.open_cells(self.site.target_cells[t]):
            return False
        for s in self.site.target_supports[t]:
            f = filled_by[s]
            if f == NOBODY or self._status[f] != _ASSEMBLED:
                return False
        return True

    def _refresh_targets(self) -> None:
        """Recompute target readiness from scratch (reset, restore); a step updates it
        incrementally (``_update_targets``) and every query reads the cache."""
        n = self.site.n_components
        if getattr(self, "_target_users", None) is None:
            # Inverses of the site's static tables: per target, the components that could
            # fill it, and the targets it supports.
            users: list[list[int]] = [[] for _ in range(n)]
            for c, targets in enumerate(self.site.compatible):
                for t in targets:
                    users[t].append(c)
            carried: list[list[int]] = [[] for _ in range(n)]
            for t, supports in enumerate(self.site.target_supports):
                for s in supports:
                    carried[s].append(t)
            self._target_users, self._supported_by = users, carried
        self.target_ready = [self._target_ready_now(t) for t in range(n)]
        self.targets_version += 1
        ready = self.target_ready
        compatible = self.site.compatible
        self._ready_count = [sum(1 for t in compatible[c] if ready[t]) for c in range(n)]
        self._has_ready = [k > 0 for k in self._ready_count]
        self._recheck.update(range(n))

    def _update_targets(self, targets: list[int]) -> None:
        """Re-judge the readiness of these targets only (a component arrived at one, or one
        carrying them was assembled); components whose ``_has_ready`` flips are rechecked.
        Equal to ``_refresh_targets`` (tests/sim/test_incremental.py), but linear in what
        changed."""
        ready, count, has = self.target_ready, self._ready_count, self._has_ready
        users, recheck = self._target_users, self._recheck
        for t in targets:
            now = self._target_ready_now(t)
            if now == ready[t]:
                continue
            ready[t] = now
            self.targets_version += 1
            step = 1 if now else -1
            for c in users[t]:
                count[c] += step
                if (count[c] > 0) != has[c]:
                    has[c] = not has[c]
                    recheck.add(c)

    def ready_targets(self, comp: int) -> list[int]:
        """Targets this component could arrive at now."""
        ready = self.target_ready
        return [t for t in self.site.compatible[comp] if ready[t]]

    def can_lift(self, comp: int) -> bool:
        return (
            self._status[comp] == _INITIAL and self._delivered[comp] and self._lift_ok(comp)
        )

    def claimable(self, comp: int) -> bool:
        """An initial, unclaimed component whose pick-up pose is free and that has somewhere
        to go (a beam or panel with no supported free target waits, as a beam does in the
        paper)."""
        return (
            self._status[comp] == _INITIAL
            and self._holder[comp] == NOBODY
            and self._delivered[comp]
            and self._lift_ok(comp)
            and (not self.site.waits[comp] or self._has_ready[comp])
        )

    def claimable_components(self) -> list[int]:
        """Every component a crane may claim now, in index order.

        Kept incrementally: ``_place`` marks the components whose pick-up pose it touched,
        and a change of target readiness marks them all; only those are judged again.
        """
        if self.auto:
            return []
        recheck = self._recheck
        if recheck:
            claimable = self._claimable
            # ``claimable(c)`` inlined: this runs for every component a step touched.
            status, holder, pickup = self._status, self._holder, self.state.pickup
            waits, has_ready, fits = self.site.waits, self._has_ready, self.fits
            delivered, closing, open_cells = self._delivered, self._closing, self.open_cells
            cells = self.state.cells
            for c in recheck:
                if (
                    status[c] == _INITIAL
                    and holder[c] == NOBODY
                    and fits(c, pickup[c])
                    and (not waits[c] or has_ready[c])
                    and delivered[c]
                    and (not closing or (open_cells(pickup[c]) and open_cells(cells[c])))
                ):
                    claimable.add(c)
                else:
                    claimable.discard(c)
            recheck.clear()
            self._claimable_list = sorted(self._claimable)
        return self._claimable_list

    def _from_cells(self, comp: int) -> list[int]:
        """Where a move starts from: an initial component is judged from its pick-up pose."""
        st = self.state
        return st.cells[comp] if self._status[comp] == _IN_TRANSIT else st.pickup[comp]

    def move_ok(self, comp: int, move: int) -> bool:
        """The move is not blocked. An initial component is judged from its pick-up pose."""
        cells = self._from_cells(comp)
        d = self.site.move_delta[move]
        occ = self._occ
        own = comp + 1
        for j in cells:
            v = occ[j + d]
            if v != FREE and v != own:
                return False
        if self._closing:
            closed = self._closed
            if any(closed[j] or closed[j + d] for j in cells):
                return False
            if self._status[comp] == _INITIAL and not self.open_cells(self.state.cells[comp]):
                return False
        return True

    def action_mask(self, crane: int) -> np.ndarray:
        """Legal actions of one crane (int8, length ``n_actions``); wait is always legal."""
        return self.action_masks()[crane]

    def action_masks(self) -> np.ndarray:
        """Legal actions of every crane, one int8 row each (a fresh array; written as bytes,
        which costs less than numpy item writes for rows this short)."""
        st = self.state
        n, width = self.n_cranes, self.site.n_actions
        masks = bytearray(n * width)
        claims = None
        assembling, pass_over, held = st.assembling, st.pass_over, st.held
        down = self._down
        for crane in range(n):
            row = crane * width
            masks[row + WAIT] = 1
            if assembling[crane] or pass_over[crane] or down[crane]:
                continue
            comp = held[crane]
            if comp == NOBODY:
                if not self.auto:
                    if claims is None:
                        claims = self.claimable_components()
                    for c in claims:
                        if self._zones is None or self.in_reach(crane, c):
                            masks[row + CLAIM_BASE + c] = 1
                continue
            status = self._status[comp]
            if status == _ARRIVED:
                masks[row + ASSEMBLE] = 1
            elif status == _IN_TRANSIT or (status == _INITIAL and self.can_lift(comp)):
                masks[row : row + N_MOVES] = bytes(self.moves_ok(comp))
                if self._zones is not None:
                    for move in range(N_MOVES):
                        if masks[row + move] and not self.move_in_reach(crane, comp, move):
                            masks[row + move] = 0
        return np.frombuffer(masks, dtype=np.int8).reshape(n, width)

    def moves_ok(self, comp: int) -> list[bool]:
        """``move_ok`` for the six moves at once."""
        cells = self._from_cells(comp)
        if self._closing:
            return [self.move_ok(comp, m) for m in range(N_MOVES)]
        occ = self._occ
        own = comp + 1
        out = []
        for d in self.site.move_delta:
            for j in cells:
                v = occ[j + d]
                if v != FREE and v != own:
                    out.append(False)
                    break
            else:
                out.append(True)
        return out

    def over_limit(self) -> list[int]:
        """Cranes holding a component that has made more moves than the move limit."""
        moves, limit = self._moves, self.site.move_limit
        return [
            crane
            for crane, comp in enumerate(self.state.held)
            if comp != NOBODY and moves[comp] > limit
        ]
