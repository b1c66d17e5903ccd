"""The single-agent benchmark mode: the paper's MDP as a Gymnasium environment."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from multicrane.core.codes import N_MOVES
from multicrane.core.schema import Scenario
from multicrane.envs.boundary import as_integer, require_reset
from multicrane.envs.infos import event_counts
from multicrane.envs.observation import (
    ANY_TARGET,
    AT_TARGET,
    HEIGHT,
    IN_TRANSIT,
    INITIAL,
    MARK,
    OBSTACLE,
    OVER_LIMIT,
    Observer,
    PlaneSpec,
)
from multicrane.envs.reward import step_reward
from multicrane.render.image import SiteImage
from multicrane.render.text import render_ansi
from multicrane.scenario.loader import load_scenario
from multicrane.sim.simulator import NOBODY, Simulator

PAPER_CONFIGS = tuple(f"E{e}S{s}" for e in range(1, 5) for s in range(1, 5))
PAPER_ENV_VERSION = 0
N_PAPER_CHANNELS = 6

# docs/paper-spec.md section 6's channels as observer planes (channel 5: a mark, times k).
PAPER_PLANES = PlaneSpec(
    masks=(
        1 << ANY_TARGET,
        (1 << OBSTACLE) | (1 << INITIAL),
        (1 << IN_TRANSIT) | (1 << AT_TARGET),
        1 << ANY_TARGET,
        1 << OVER_LIMIT,
        1 << AT_TARGET,
    ),
    values=(MARK, HEIGHT, HEIGHT, HEIGHT, MARK, MARK),
    normalise=False,
)


def paper_env_id(config: str) -> str:
    return f"multicrane/PaperAssembly-{config.upper()}-v{PAPER_ENV_VERSION}"


def scenario_of(config: str) -> str:
    """``"E2S3"`` -> the shipped scenario ``"e2s3"``."""
    name = config.upper()
    if name not in PAPER_CONFIGS:
        raise ValueError(
            f"unknown paper configuration {config!r}: one of {', '.join(PAPER_CONFIGS)}"
        )
    return name.lower()


class PaperAssemblyEnv(gym.Env):
    """The benchmark of Zhu et al. (Table I), as ``docs/paper-spec.md`` specifies it.

    **Process.** One crane works on one component at a time; the agent only moves it. The
    current component comes from a cyclic pointer over the scenario's list order (beams
    with no supported free target are skipped); the first action lifts it to its pick-up pose
    and applies the move; it is assembled on arrival. In Env1 the pre-built column's list
    entry costs one pass-over step whose action is ignored. This is ``MultiCraneEnv`` with
    one crane and ``auto=True``, on the same simulator core.

    **Actions.** ``Discrete(6)``: ``0`` x-1, ``1`` y-1, ``2`` x+1, ``3`` y+1, ``4`` up,
    ``5`` down. A move into the site's edge, the ground, an obstacle or another component is
    blocked: nothing moves and the step still costs.

    **Observation.** ``Box(0, high, (1350,), float32)``: the (15, 15, 6) array over
    (x, y, channel) of section 6, flattened in that order. For each (x, y), looking up:
    0 a target is there (free or filled); 1 top z of a component in the yard or an obstacle;
    2 top z of the component in transit or of an arrived one (pre-built included); 3 top z
    of a target; 4 one on the component in transit once it has made more than 15 moves;
    5 ``k`` on the cells of arrived components.

    **Reward.** Section 5: ``+N`` when the current component arrives (``N`` arrived
    components, pre-built included), ``+10`` instead when it is the last; ``+N`` on the
    pass-over step; otherwise ``-2`` once the current component has made more than 15
    moves, else ``-1 / (k + 1)`` with ``k`` the components arrived this episode.

    **Termination / truncation.** Terminated when every component has arrived; truncated at
    the step limit (100 Env1/Env2, 300 Env3, 600 Env4) if not terminated.

    **Arguments.** ``config`` ("E1S1" … "E4S4"), or ``scenario`` (a shipped name, path or
    ``Scenario`` of your own with one crane); ``mask_blocked_moves`` (False): when True,
    ``action_masks()`` and ``info["action_mask"]`` mark the moves that would be blocked (when
    all six would be, or during the pass-over step, all are allowed); when False they allow
    all six, so the default MDP stays the paper's. ``render_mode``: None, ``"ansi"`` or
    ``"rgb_array"`` (an isometric picture of the site, ``multicrane.render.image``).

    **Infos.** Numbers only by default (every batching library takes them): ``event_counts``
    (per ``EventType``, see ``multicrane.envs.infos``), ``component_index`` (the current
    component's scenario index, -1 when none) and, on the last step, ``is_success``.
    ``info_events=True`` adds ``events`` (``Event`` tuples) and ``component`` (its id or None);
    ``info_mask=True`` adds ``action_mask``. ``env.last_events`` keeps the last step's events.

    **Version history.** v0: the corrected environment of ``docs/paper-spec.md`` section 7.
    """

    metadata = {"render_modes": ["ansi", "rgb_array"], "render_fps": 4}

    def __init__(
        self,
        config: str | None = "E1S1",
        scenario: str | Scenario | None = None,
        mask_blocked_moves: bool = False,
        render_mode: str | None = None,
        info_events: bool = False,
        info_mask: bool = False,
    ):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            # Gymnasium's convention: warn, do not fail; render() then returns None.
            supported = self.metadata["render_modes"]
            gym.logger.warn(f"render_mode {render_mode!r} is not supported (only {supported})")
        if scenario is None:
            if config is None:
                raise ValueError("give a paper configuration (config=) or a scenario (scenario=)")
            scenario = scenario_of(config)
        self.config = config.upper() if config is not None else None
        self.scenario = load_scenario(scenario)
        self.sim = Simulator(self.scenario, n_cranes=1, auto=True)
        self.observer = Observer(self.sim, PAPER_PLANES)
        self.mask_blocked_moves = mask_blocked_moves
        self.info_events = bool(info_events)
        self.info_mask = bool(info_mask)
        self.last_events: tuple = ()
        self.render_mode = render_mode
        self._image: SiteImage | None = None
        X, Y, H = self.scenario.size
        self.plan_shape = (X, Y, N_PAPER_CHANNELS)
        high = float(max(H, self.scenario.n_components))
        self.observation_space = spaces.Box(0.0, high, (X * Y * N_PAPER_CHANNELS,), np.float32)
        self.action_space = spaces.Discrete(N_MOVES)

    # -- episode -----------------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self.sim.reset(self.np_random)
        self.observer.reset(self.scenario.step_limit)
        self.observer.update(self.sim.take_changed(), ())
        return self._observation(), self._info(())

    def step(self, action):
        sim = self.sim
        require_reset(sim.state is not None, "step")
        a = as_integer(action, "action")  # ints and numpy integers; not floats, bools, str
        if not 0 <= a < N_MOVES:
            raise ValueError(f"action must be 0..5 (x-1, y-1, x+1, y+1, up, down), got {action!r}")
        out = sim.step([a])
        reward, _, _ = step_reward(sim, out)
        terminated = sim.done
        truncated = not terminated and sim.state.step_count >= self.scenario.step_limit
        self.observer.update(sim.take_changed(), ())
        info = self._info(out.events)
        if terminated or truncated:
            info["is_success"] = terminated
        return self._observation(), reward, terminated, truncated, info

    def _observation(self) -> np.ndarray:
        obs = self.observer.planes.copy()  # (X * Y, 6), kept up to date incrementally
        k = self.sim.k
        if k != 1:
            obs[:, 5] *= k
        return obs.reshape(-1)

    def _info(self, events) -> dict[str, Any]:
        comp = int(self.sim.state.held[0])
        self.last_events = tuple(events)
        info: dict[str, Any] = {
            "event_counts": event_counts(self.last_events),
            "component_index": comp if comp != NOBODY else -1,
        }
        if self.info_events:
            info["events"] = self.last_events
            info["component"] = self.scenario.components[comp].id if comp != NOBODY else None
        if self.info_mask:
            info["action_mask"] = self.action_masks()
        return info

    def action_masks(self) -> np.ndarray:
        """Moves that would not be blocked (with ``mask_blocked_moves``); else all six."""
        require_reset(self.sim.state is not None, "action_masks")
        if not self.mask_blocked_moves:
            return np.ones(N_MOVES, dtype=np.int8)
        moves = self.sim.action_masks()[0, :N_MOVES]
        return moves if moves.any() else np.ones(N_MOVES, dtype=np.int8)

    def render(self) -> str | np.ndarray | None:
        require_reset(self.sim.state is not None, "render")
        if self.render_mode == "ansi":
            return render_ansi(self.sim)
        if self.render_mode == "rgb_array":
            if self._image is None:
                self._image = SiteImage(self.sim)
            return self._image.draw(self.sim)
        return None
