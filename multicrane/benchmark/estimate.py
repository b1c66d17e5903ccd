"""How long runs take: a CPU-time estimate per run, the wall time of a sweep on n workers, and
the longest-first order the backends use.

Training sets the pace (the environment itself runs at 25,000+ steps/s in every
configuration), so the estimate is the learner's measured throughput plus pessimistic
evaluations (every episode at the step limit).
"""

from __future__ import annotations

import heapq
from collections.abc import Iterable, Sequence

from multicrane.benchmark.profiles import LEAN_ALGOS, STANDARD_SETTINGS, RunSpec, jsonable

# Training steps per second of one process with one torch thread, measured on the 2-core
# development machine (paper settings; the environment itself runs at 25,000+ steps/s in
# every configuration, so the learner sets the pace).
THROUGHPUT = {"dqn": 450, "double_dqn": 450, "a2c": 5000, "ppo": 3000, "maskable_ppo": 2500}
# lean_ppo by (the width of its first layer, copies, minibatch); a setting not listed: the
# slowest. End to end (rollouts, updates, checkpoints) in 1,000,000-step runs with another
# process on the 2 cores: the defaults (64, 256, 1024) 21,078 steps/s on E1S4 (multicrane
# bench --train: 33,772 for the training loop alone, quiet machine); a 256-256 network 8,986 on
# E1S4, 9,286 on E2S1, 7,482 on E3S1, 7,595 on E4S1; paper-budget's (64, 64, 256, shaped
# with the path potential) 1.35x the 256-256 network's rate (learn() of 65,536 steps on E3S1,
# three interleaved pairs, load 10-11: medians 7,760 and 5,743 steps per CPU second); the
# same with the 256-256 network (paper-budget's on E4S3): 4,140 and 4,114 in two
# 1,000,000-step E4S1 runs of the sweep side by side, nothing else on the 2 cores (load 2);
# with the 128-128 network (paper-budget's elsewhere) 4,100 times the 256-256 network's CPU
# seconds over the 128-128 network's in single 1,000,000-step runs, same configuration and
# seed, one at a time (load 2-4): 1.60 (median; E4S1 134.9/84.2, E4S2 130.6/85.7, E4S3 seed 1
# 132.2/72.2; 1.53 would give 6,250), so ~6,500 (learn() of 65,536 steps on E3S1, three
# interleaved rounds: 1.93 quiet, 1.86 at load 3, medians of steps per CPU second).
LEAN_THROUGHPUT = {(64, 256, 1024): 20000, (256, 256, 1024): 7500, (64, 64, 256): 10000,
                   (128, 64, 256): 6500, (256, 64, 256): 4100}  # fmt: skip
LEAN_DEFAULTS = (64, 256, 1024)  # net_arch[0], copies, batch_size of default_hyperparameters
# Greedy evaluation: seconds per environment step (model prediction + environment; lean_ppo's
# measured 0.43 ms in that run, the exact planner's gap included), and the step limit of an
# episode (an untrained policy runs to it).
EVAL_STEP_SECONDS = 0.00025
LEAN_EVAL_STEP_SECONDS = 0.0005
EPISODE_LIMIT = {"E1": 100, "E2": 100, "E3": 300, "E4": 600}
RUN_OVERHEAD_SECONDS = 1.0  # building the environments and model, writing files
# The standard profile's settings (profiles.STANDARD_SETTINGS), measured on the same machine
# while five other jobs shared its two cores (CPU seconds of the process, which such load
# inflates: the paper-settings double DQN measured 200 steps/s there against 450 above), and
# its evaluation steps (model prediction with SB3's predict, one observation at a time).
# MaskablePPO: 16 copies x 128 steps, minibatch 128, path-potential shaping; 200,704-step
# runs took 97-156 CPU-s with their evaluations (docs/benchmark-experiments.md, fourth
# session; median ~130), i.e. about 1,600 training steps/s.
STANDARD_THROUGHPUT = {"double_dqn": 1400, "maskable_ppo": 1600}
STANDARD_EVAL_STEP_SECONDS = 0.001


def _standard(spec: RunSpec) -> bool:
    settings = STANDARD_SETTINGS.get(spec.algo)
    return bool(settings) and (
        spec.train.get("n_envs") == settings["n_envs"]
        and spec.train.get("hyperparams") == jsonable(settings["hyperparams"])
    )


def estimate_seconds(spec: RunSpec, done_steps: int = 0) -> float:
    """CPU seconds of one run (of what is left after ``done_steps``): training at
    ``THROUGHPUT``, plus curve points and the final evaluation with every episode at the
    step limit (the pessimistic case)."""
    t = spec.train
    left = max(0, t["total_steps"] - done_steps)
    limit = EPISODE_LIMIT[spec.config[:2]]
    if _standard(spec):
        train = left / STANDARD_THROUGHPUT[spec.algo]
        evaluation = _episodes(t, left) * limit * STANDARD_EVAL_STEP_SECONDS
    elif spec.algo in LEAN_ALGOS:
        train = left / LEAN_THROUGHPUT.get(_lean_setting(t), min(LEAN_THROUGHPUT.values()))
        evaluation = _episodes(t, left) * limit * LEAN_EVAL_STEP_SECONDS
    else:
        train = left / THROUGHPUT[spec.algo]
        points = (left // t["eval_every"] + 2) if t["eval_every"] else 1
        evaluation = points * t["eval_episodes"] * limit * EVAL_STEP_SECONDS
    return train + evaluation + RUN_OVERHEAD_SECONDS


def _lean_setting(t: dict) -> tuple[int, int, int]:
    """A lean PPO run's (first layer width, copies, minibatch), defaults filled in."""
    width, copies, batch = LEAN_DEFAULTS
    hp = t["hyperparams"]
    net = hp.get("policy_kwargs", {}).get("net_arch", [width])
    return net[0], t.get("n_envs") or copies, hp.get("batch_size", batch)


def _episodes(t: dict, left: int) -> int:
    """Evaluation episodes: curve points at 0, every, ..., the end; then the final ones."""
    points = (left // t["eval_every"] + 1) if t["eval_every"] else 0
    return points * t["eval_episodes"] + (t["final_episodes"] or t["eval_episodes"])


def estimate_wall(
    specs: Sequence[RunSpec], workers: int, done_steps: dict[RunSpec, int] | None = None
) -> float:
    """Wall seconds with ``workers`` processes, longest runs first (as the backends order
    them), each process starting up once (~3 s: importing torch). ``done_steps``: steps
    already in the checkpoints of partial runs."""
    done_steps = done_steps or {}
    loads = [3.0] * max(1, min(workers, len(specs)))
    heapq.heapify(loads)
    costs = (estimate_seconds(s, done_steps.get(s) or 0) for s in specs)
    for cost in sorted(costs, reverse=True):
        heapq.heappush(loads, heapq.heappop(loads) + cost)
    return max(loads) if specs else 0.0


def longest_first(
    specs: Iterable[RunSpec], done_steps: dict[RunSpec, int] | None = None
) -> list[RunSpec]:
    done_steps = done_steps or {}
    return sorted(specs, key=lambda s: estimate_seconds(s, done_steps.get(s) or 0), reverse=True)


def format_duration(seconds: float) -> str:
    seconds = int(round(seconds))
    if seconds < 120:
        return f"{seconds} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    if seconds < 3 * 86400:
        return f"{seconds / 3600:.1f} h"
    return f"{seconds / 86400:.1f} days"
