"""Where a task-level decision round's time goes: the planner, the simulated steps, the observation.

    PYTHONPATH=. python tools/round_split.py                      # hall-4c, 4 cranes, 4,000 rounds
    PYTHONPATH=. python tools/round_split.py e3s2 --cranes 2 --rounds 500 --policy random

Plays whole episodes from seed 0 on as ``multicrane bench --decisions task`` does (300 rounds
of warm-up first) with ``time.perf_counter`` around the parts of a round, and prints the mean
microseconds of each per round, with how many calls a round makes: the planner's call, the
environment's step and, inside it, the task mode's step (the simulated steps: the
simulator, the carrier's motions and the book's updates, the reward), the observation with
the masks, and the compiled space-time search wherever it runs. The timers cost about a
microsecond a call, so the parts add up to a little more than the bench's round.
"""

from __future__ import annotations

import argparse

import multicrane
import policies
from multicrane.envs import motion_mode
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.envs.task_mode import TaskMode
from multicrane.episodes.rollout import Stopwatch, play_seeds
from multicrane.sim.simulator import Simulator
from multicrane.tasks import carrier_planning
from multicrane.tasks.book import TaskBook

_PARTS = [  # (label, owner, attribute): timed where they are looked up
    ("env.step", MultiCraneEnv, "step"),
    ("  task mode: simulated steps", TaskMode, "step"),
    ("    Simulator.step", Simulator, "step"),
    ("    TaskBook.motion (carrier)", TaskBook, "motion"),
    ("    TaskBook.after_step", TaskBook, "after_step"),
    ("    TaskBook.any_open", TaskBook, "any_open"),
    ("    step reward", motion_mode.reward_rules, "step_reward"),
    ("  task mode: observation, masks", TaskMode, "observe"),
    ("space-time search (compiled)", carrier_planning, "compiled_search"),
]


def split(scenario: str, cranes: int | None, rounds: int, policy: str) -> list[tuple]:
    """``(label, microseconds a round, calls a round)`` of each part, the planner's first."""
    watches = {label: Stopwatch() for label in ["planner's call"] + [p[0] for p in _PARTS]}
    originals = [(owner, name, getattr(owner, name)) for _, owner, name in _PARTS]
    for (label, owner, name), (_, _, fn) in zip(_PARTS, originals, strict=True):
        setattr(owner, name, watches[label].timing(fn))
    env = multicrane.parallel_env(scenario, n_cranes=cranes, decisions="task")

    def make(env, seed):
        return watches["planner's call"].timing(policies.make(policy, env, seed=seed))

    try:
        play_seeds(env, make, 300)
        for watch in watches.values():
            watch.seconds.clear()
        play_seeds(env, make, rounds)
    finally:
        for owner, name, fn in originals:
            setattr(owner, name, fn)
    return [(label, 1e6 * sum(w.seconds) / rounds, len(w.seconds) / rounds)
            for label, w in watches.items()]  # fmt: skip


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("scenario", nargs="?", default="hall-4c")
    p.add_argument("--cranes", type=int, default=4)
    p.add_argument("--rounds", type=int, default=4000)
    p.add_argument("--policy", default="prioritized")
    args = p.parse_args(argv)
    print(f"{args.scenario}, {args.cranes} cranes, {args.policy}, {args.rounds} rounds")
    print(f"{'part':<36} {'us a round':>10} {'calls a round':>14}")
    for label, us, n in split(args.scenario, args.cranes, args.rounds, args.policy):
        print(f"{label:<36} {us:>10.1f} {n:>14.2f}")


if __name__ == "__main__":
    main()
