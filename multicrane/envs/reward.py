"""The team reward: the paper's reward, generalised to several cranes.

For one crane in automatic mode this is exactly the reward behind the paper's Table I
(``docs/paper-spec.md`` section 5). With ``N`` the assembled components after the step
(pre-built included), ``k`` those assembled during this episode, and ``m`` a held component's
successful moves:

- a step in which components are assembled (or a pass-over happens) pays ``N`` for each;
  the step that completes the building pays ``completion`` instead;
- any other step costs ``over_limit_cost`` while some crane holds a component with
  ``m > move_limit``, and ``step_cost / (k + 1)`` otherwise.

``reward="makespan"`` (``makespan_reward``) is the other option of the environments: ``-1``
per simulated step for the team, plus ``completion`` on the step that finishes the building,
so an episode's return is ``completion - makespan``.

The cost is paid once per joint step, not once per crane, so finishing sooner (in parallel)
is what pays. ``split`` divides the team reward into per-crane terms that add up to it:
progress goes to the crane that made it; the over-limit cost to the cranes over the limit;
the plain step cost to all cranes equally.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from multicrane.core.schema import RewardSpec

if TYPE_CHECKING:
    from multicrane.sim.simulator import Simulator, StepOutcome


def step_reward(sim: Simulator, out: StepOutcome) -> tuple[float, list[int], list[int]]:
    """The team reward of the step the simulator just made, with the cranes that made
    progress and those past the move limit (for ``split``)."""
    progress_by = out.assembled_by + out.pass_over_by
    over = sim.over_limit()
    r = team_reward(
        sim.scenario.reward, len(progress_by), sim.state.n_assembled, sim.k, sim.done, bool(over)
    )
    return r, progress_by, over


def team_reward(
    spec: RewardSpec, n_progress: int, n_assembled: int, k: int, complete: bool, over_limit: bool
) -> float:
    if complete:
        return spec.completion
    if n_progress:
        return float(n_progress * n_assembled)
    if over_limit:
        return -spec.over_limit_cost
    return -spec.step_cost / (k + 1)


def makespan_reward(spec: RewardSpec, complete: bool) -> float:
    """The team reward of one simulated step under ``reward="makespan"``."""
    return -1.0 + (spec.completion if complete else 0.0)


def split(
    reward: float, n_cranes: int, progress_by: list[int], over_limit_by: list[int]
) -> list[float]:
    """Per-crane terms of a team reward (they sum to ``reward``)."""
    terms = [0.0] * n_cranes
    owners = progress_by or over_limit_by
    if owners:
        share = reward / len(owners)
        for crane in owners:
            terms[crane] += share
    else:
        share = reward / n_cranes
        terms = [share] * n_cranes
    return terms
