"""Where each part of a crane's flat motion observation lies (``ObservationLayout``).

The parts, in order (``multicrane.envs.observation`` builds them): the shared planes (X, Y,
``N_SHARED``), the crane's own planes (X, Y, ``N_OWN``: its component, the targets it could
fill now), the component table (C, ``COMPONENT_FEATURES``), the crane vector
(``CRANE_FEATURES``, the last value the clock), and with site events the events block
(per component ``delivered``, per crane ``available``, the ``closed`` plan X x Y).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from multicrane.envs.plane_grid import N_SHARED

N_OWN = 2
COMPONENT_FEATURES = 14
CRANE_FEATURES = 9
MINE, MY_TARGETS = N_SHARED, N_SHARED + 1  # the own planes' channels in ``split``'s planes


@dataclass(frozen=True)
class ObservationLayout:
    """Where each part lies in the flat observation vector."""

    plan: tuple[int, int]  # (X, Y)
    n_components: int
    n_shared: int = N_SHARED
    n_cranes: int = 0  # > 0: the events block is present (see the module doc)

    @property
    def shared(self) -> slice:
        return slice(0, self.plan[0] * self.plan[1] * self.n_shared)

    @property
    def own(self) -> slice:
        start = self.shared.stop
        return slice(start, start + self.plan[0] * self.plan[1] * N_OWN)

    @property
    def components(self) -> slice:
        start = self.own.stop
        return slice(start, start + self.n_components * COMPONENT_FEATURES)

    @property
    def crane(self) -> slice:
        start = self.components.stop
        return slice(start, start + CRANE_FEATURES)

    @property
    def clock(self) -> slice:
        """The crane vector's last value: the fraction of the step limit used."""
        return slice(self.crane.stop - 1, self.crane.stop)

    @property
    def events(self) -> slice:
        start = self.crane.stop
        n = self.n_components + self.n_cranes + self.plan[0] * self.plan[1] if self.n_cranes else 0
        return slice(start, start + n)

    @property
    def size(self) -> int:
        return self.events.stop

    def split(self, obs: np.ndarray) -> dict[str, np.ndarray]:
        """The flat vector as ``planes`` (X, Y, 9), ``components`` (C, 14) and ``crane`` (9,)."""
        X, Y = self.plan
        planes = np.concatenate(
            [obs[self.shared].reshape(X, Y, N_SHARED), obs[self.own].reshape(X, Y, N_OWN)],
            axis=-1,
        )
        out = {
            "planes": planes,
            "components": obs[self.components].reshape(self.n_components, COMPONENT_FEATURES),
            "crane": obs[self.crane],
        }
        if self.n_cranes:
            ev = obs[self.events]
            C, N = self.n_components, self.n_cranes
            out["delivered"] = ev[:C]
            out["available"] = ev[C : C + N]
            out["closed"] = ev[C + N :].reshape(X, Y)
        return out
