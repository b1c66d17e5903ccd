"""The mutable state of one episode: ``SiteState``, one dataclass of arrays and lists.

Shapes use ``C`` for the number of components (targets share their indices), ``N`` for the
number of cranes and ``P`` for the number of cells of the padded grid (``Site.size``). Cells
are linear indices into that grid (see ``multicrane.sim.site``); ``-1`` (``NOBODY``) marks "none".
The simulator (``multicrane.sim.simulator``) is the only writer; everything else reads.
``copy`` gives an independent value (what ``Simulator.snapshot`` returns) and ``assign``
copies one back in place (``Simulator.restore``), so arrays bound elsewhere stay valid.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from multicrane.core.codes import Status
from multicrane.sim import geometry
from multicrane.sim.site import FREE, NOBODY, Site

if TYPE_CHECKING:
    from multicrane.sim.start import Start

_ARRAYS = ("occ", "status", "moves", "holder", "filled", "filled_by", "delivered")
_LISTS = ("cells", "held", "assembling", "pass_over")
_SCALARS = ("pointer", "n_assembled", "step_count")
# Set by reset and never changed during the episode: copies share them.
_EPISODE = ("prebuilt", "pickup", "n_prebuilt")


class StateViews(NamedTuple):
    """Memoryviews of a ``SiteState``'s per-component arrays, for hot paths: an item is a
    plain int (a bool for ``delivered``), read without making a numpy scalar."""

    status: memoryview
    moves: memoryview
    holder: memoryview
    filled: memoryview
    filled_by: memoryview
    delivered: memoryview

    @classmethod
    def of(cls, state: SiteState) -> StateViews:
        return cls(*(memoryview(getattr(state, name)) for name in cls._fields))


@dataclass(eq=False)
class SiteState:
    """Every mutable value of an episode (``multicrane.core.codes.Status`` for the statuses)."""

    # -- the site ------------------------------------------------------------------------
    occ: np.ndarray  # (P,) int16: FREE, WALL or component index + 1 per padded cell
    # -- per component -------------------------------------------------------------------
    status: np.ndarray  # (C,) int8 Status
    moves: np.ndarray  # (C,) int32: successful moves since the component was lifted
    holder: np.ndarray  # (C,) int16: crane holding the component, or NOBODY
    filled: np.ndarray  # (C,) int16: target the component fills (arrived/assembled), or NOBODY
    filled_by: np.ndarray  # (C,) int16, per target: component filling it, or NOBODY
    cells: list[list[int]]  # C lists of cell indices, node 1 first (a move replaces a list)
    delivered: np.ndarray  # (C,) bool: on site (False: late, off site; ``cells`` is where it
    #                        will appear, and ``occ`` does not hold it)
    prebuilt: np.ndarray  # (C,) bool: assembled from the start (fixed for the episode)
    pickup: list[list[int]]  # C lists: cells of the pick-up pose ([] if pre-built; fixed)
    # -- per crane -----------------------------------------------------------------------
    held: list[int]  # N ints: the component each crane holds (or has been assigned), or NOBODY
    assembling: list[int]  # N ints: assembly steps left (0: not assembling)
    pass_over: list[bool]  # N bools: automatic mode, the next step is a pass-over
    # -- the automatic mode's list pointer -------------------------------------------------
    pointer: int  # position in the scenario's list order the next assignment starts at
    passed_over: set[int]  # pre-built components whose list entry has been passed over
    # -- counters ------------------------------------------------------------------------
    n_assembled: int  # assembled components, pre-built included
    n_prebuilt: int  # pre-built components (fixed for the episode)
    step_count: int  # steps taken this episode

    @classmethod
    def at_start(
        cls, site: Site, start: Start, n_cranes: int, arrival: np.ndarray | None = None
    ) -> SiteState:
        """The state at the start of an episode: components where ``start`` puts them
        (pre-built ones assembled on their targets, the others initial in the yard); with
        ``arrival`` (``multicrane.sim.events``), those due later are off site (not delivered)."""
        scenario = site.scenario
        n = site.n_components
        occ = site.static.copy()
        status = np.full(n, Status.INITIAL, dtype=np.int8)
        filled = np.full(n, NOBODY, dtype=np.int16)
        filled_by = np.full(n, NOBODY, dtype=np.int16)
        prebuilt = np.zeros(n, dtype=bool)
        cells: list[list[int]] = [[] for _ in range(n)]
        pickup: list[list[int]] = [[] for _ in range(n)]
        delivered = np.ones(n, dtype=bool) if arrival is None else np.asarray(arrival) <= 0
        for i, c in enumerate(scenario.components):
            t = start.prebuilt_target[i]
            if t >= 0:  # pre-built: assembled from the start, not a transition
                cells[i] = list(site.target_cells[t])
                status[i] = Status.ASSEMBLED
                prebuilt[i] = True
                filled[i] = t
                filled_by[t] = i
            else:
                pose = start.initial[i]
                assert pose is not None
                cells[i] = site.lin_pose(pose)
                pickup[i] = site.lin_pose(geometry.pickup_pose(c, scenario.beam_lift_z, pose))
            if not delivered[i]:
                continue
            for j in cells[i]:
                assert occ[j] == FREE, "the loader and the start draw guarantee free cells"
                occ[j] = i + 1
        n_prebuilt = int(prebuilt.sum())
        return cls(
            occ=occ,
            status=status,
            moves=np.zeros(n, dtype=np.int32),
            holder=np.full(n, NOBODY, dtype=np.int16),
            filled=filled,
            filled_by=filled_by,
            cells=cells,
            delivered=delivered,
            prebuilt=prebuilt,
            pickup=pickup,
            held=[NOBODY] * n_cranes,
            assembling=[0] * n_cranes,
            pass_over=[False] * n_cranes,
            pointer=0,
            passed_over=set(),
            n_assembled=n_prebuilt,
            n_prebuilt=n_prebuilt,
            step_count=0,
        )

    def copy(self) -> SiteState:
        """An independent copy (the episode's fixed values are shared, not copied)."""
        new = SiteState.__new__(SiteState)
        d = new.__dict__
        src = self.__dict__
        for name in _ARRAYS:
            d[name] = src[name].copy()
        for name in _LISTS:
            d[name] = list(src[name])  # a move replaces a component's cell list, never edits it
        d["passed_over"] = set(self.passed_over)
        for name in _SCALARS + _EPISODE:
            d[name] = src[name]
        return new

    def assign(self, other: SiteState) -> None:
        """Make this state equal to ``other``, in place: arrays and lists keep their identity."""
        src = other.__dict__
        d = self.__dict__
        for name in _ARRAYS:
            np.copyto(d[name], src[name])
        for name in _LISTS:
            d[name][:] = src[name]
        self.passed_over.clear()
        self.passed_over.update(other.passed_over)
        for name in _SCALARS + _EPISODE:
            d[name] = src[name]

    def equals(self, other: SiteState) -> bool:
        """True when every field holds the same values."""
        return all(
            np.array_equal(a, b) if isinstance(a, np.ndarray) else a == b
            for a, b in zip(self.values(), other.values(), strict=True)
        )

    def values(self) -> tuple:
        """The fields in declaration order."""
        return tuple(getattr(self, name) for name in self.__dataclass_fields__)
