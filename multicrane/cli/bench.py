"""``multicrane bench``: environment throughput (joint steps per second, random legal actions)."""

from __future__ import annotations

import argparse
import time

import numpy as np

from multicrane.cli.common import formatter
from multicrane.envs.decision_modes import DECISION_MODES, DEFAULT_DECISIONS, decision_mode
from multicrane.episodes.random_actions import random_legal_policy
from multicrane.episodes.rollout import Stopwatch, play, play_seeds

DESCRIPTION = """Environment throughput: joint steps per second under random legal actions.

    multicrane bench --scenario e2s2 --cranes 1
    multicrane bench --scenario hall-4c --cranes 4 --steps 50000
    multicrane bench --all          # every shipped scenario, 1 and 4 cranes
    multicrane bench --paper E1S1   # the single-agent paper mode (Gymnasium)
    multicrane bench --vector       # the vector paper and motion envs (numba) beside them
    multicrane bench --train        # training steps/s: the lean PPO beside SB3's MaskablePPO
    multicrane bench --decisions task --scenario hall-4c --cranes 4   # task-level rounds
    multicrane bench --scenario set:test-small --steps 2000   # every site of a named set
    multicrane bench --scaling      # costs of generated sites of 3-121 components, 1-16 cranes
    multicrane bench --scaling --full --plot scaling.png   # 3-490 components (needs [bench])

Each joint step includes the observations and masks the environment returns and the choice of
a random legal action per crane (from the mask, as a masked policy would). Resets are
included when episodes end. Run it on an otherwise idle core for stable figures.

With ``--decisions task`` it times task-level decision rounds instead: one round is the
policy's call (planning included: the prioritized rule's space-time searches) plus the
``env.step`` that starts the tasks and advances the simulator to the next decision. It
reports rounds per second and the mean and 95th percentile milliseconds per round, for the
task-level prioritized planner and for random legal tasks, over whole episodes (seeds 0, 1,
...) until ``--steps`` rounds have been timed (resets excluded), for the one-site env and then
for the compiled task env (``TaskVectorEnv`` with one copy, docs/vector.md: the same rounds
number for number, its planners compiled: ``env.propose()`` and uniform allowed tasks).

With ``--vector`` it times the vector paper env (``multicrane.vector``, docs/vector.md) beside
the one-site env, in one process on one core: steps per second for B = 1, 64, 1024 and 4096
copies under uniform random moves drawn by a compiled sampler, the bytes of state and
buffers per copy, and the seconds a fresh process needs to its first step, with an empty
numba cache (the compile) and with the cache the first left. Configurations: ``--paper``'s,
else E1S1 and E4S1; each figure is the median of three interleaved rounds. Then the same
for the vector motion env (``MotionVectorEnv``) on hall-4c with 4 cranes, joint steps per
second under uniform random legal actions, beside the one-site ``parallel_env``, with float32
observations (``vector``) and with ``obs_dtype=np.uint8`` (``vector-u8``: a quarter of the
observation memory; the kernels compile once more for it); with ``--events LEVEL`` both motion
envs play with site events of that level (docs/uncertainty.md). Last, the compiled task env
(``TaskVectorEnv``, hall-4c, 4 cranes) beside the one-site task env: decision rounds a second
for B = 1, 64 and 1024 copies under the prioritized rule and random allowed tasks, the
bytes of state and buffers per copy, and a fresh process's seconds to its first round.

With ``--train`` it times training, rollouts and updates (one torch thread), in the paper
mode (``--paper``'s first configuration, else E1S1; SB3's MaskablePPO at the paper's
settings) and in the multi-agent motion mode (hall-4c with 4 cranes, the multi-agent
defaults and shaping; a step is one crane's decision): MaskablePPO for ``--steps`` steps and
the lean PPO (``multicrane train --algo lean_ppo``) for ten times as many, in two
interleaved rounds, and prints each one's steps per second of wall time and of the process's
CPU time (the medians; on a shared machine the CPU figure is the steadier) and their ratios.

With ``--scaling`` it measures how the costs grow with the site (``multicrane.reports.scaling``):
load, reset, joint step per crane (200 random legal steps) and the prioritized planner's
time per decision (first 100 decisions) on generated halls. The default grid (3, 21, 121
components x 1, 4, 16 cranes) takes about a minute; ``--full`` runs 3-490 components x 1, 2,
4, 8, 16 cranes (several minutes). It prints a markdown table and the fitted exponents of
cost ~ components^b x cranes^c; ``--plot FILE.png`` draws the log-log plot (matplotlib: the
``bench`` extra, ``pip install 'multicrane[bench]'``).
"""


def register(sub) -> None:
    p = sub.add_parser("bench", help="environment steps per second", description=DESCRIPTION,
                       **formatter())  # fmt: skip
    p.add_argument("--scenario", default="e2s2")
    p.add_argument("--cranes", type=int, default=None)
    p.add_argument("--steps", type=int, default=20000)
    p.add_argument("--auto", action="store_true", help="automatic claiming and assembly")
    p.add_argument("--all", action="store_true", help="every shipped scenario with 1 and 4 cranes")
    p.add_argument("--paper", metavar="CONFIG", nargs="*", help="paper mode configurations")
    p.add_argument("--decisions", choices=tuple(DECISION_MODES), default=DEFAULT_DECISIONS,
                   help="task: time task-level decision rounds (planning included)")
    p.add_argument("--vector", action="store_true",
                   help="the vector paper env (multicrane.vector) beside the one-site env")
    p.add_argument("--events", metavar="LEVEL", default=None,
                   help="with --vector: site events of this level in the motion envs "
                   "(none, low, medium, high)")
    p.add_argument("--train", action="store_true",
                   help="training steps/s: the lean PPO beside SB3's MaskablePPO")
    p.add_argument("--scaling", action="store_true",
                   help="costs of generated sites of growing size (multicrane.reports.scaling)")
    p.add_argument("--full", action="store_true", help="with --scaling: the full grid")
    p.add_argument("--plot", metavar="PNG", help="with --scaling: write the log-log plot")
    p.set_defaults(func=run)


def joint_steps_per_second(
    scenario,
    cranes: int | None,
    steps: int,
    seed: int = 0,
    auto: bool = False,
    events: str | None = None,
) -> float:
    """Joint steps per second of the PettingZoo parallel environment: the wall time of
    ``steps`` joint steps (each with its random legal joint action, drawn for all cranes at
    once by ``random_legal_policy``, and the resets when episodes end)."""
    import multicrane

    env = multicrane.parallel_env(scenario, n_cranes=cranes, auto=auto, events=events)
    policy = random_legal_policy(env.possible_agents, np.random.default_rng(seed))
    return _steps_per_second(env, policy, seed, steps)


def paper_steps_per_second(config: str, steps: int, seed: int = 0) -> float:
    """Steps per second of the single-agent paper mode: the wall time of ``steps`` steps of
    uniform random moves (drawn before the clock starts) and the resets when episodes end."""
    import multicrane

    env = multicrane.PaperAssemblyEnv(config)
    moves = iter(np.random.default_rng(seed).integers(6, size=steps).tolist())

    def policy(_observation) -> int:
        return next(moves)

    return _steps_per_second(env, policy, seed, steps)


def _steps_per_second(env, policy, seed: int, steps: int) -> float:
    """``steps`` over the wall time of ``play``ing them from ``reset(seed=seed)``: the clock
    starts after that first reset and counts the resets when episodes end."""
    begun: list[float] = []

    def start_clock(_env) -> None:
        if not begun:
            begun.append(time.perf_counter())

    play(env, policy, seed, steps=steps, repeat=True, on_reset=start_clock)
    return steps / (time.perf_counter() - begun[0])


def task_round_seconds(scenario, cranes: int | None, rounds: int, policy: str) -> np.ndarray:
    """Seconds of each task-level decision round (the policy's call + its ``env.step``, the
    resets not counted), whole episodes from seed 0 on, until ``rounds`` rounds are timed."""
    import multicrane
    import policies

    env = multicrane.parallel_env(scenario, n_cranes=cranes, decisions="task")
    calls, steps = Stopwatch(), Stopwatch()

    def make(env, seed):
        return calls.timing(policies.make(policy, env, seed=seed))

    play_seeds(env, make, rounds, step_watch=steps)
    return np.add(calls.seconds, steps.seconds)


def _runs(args: argparse.Namespace) -> list[tuple[str, object, int | None]]:
    """(label, scenario, cranes) of each run: every shipped scenario with 1 and 4 cranes
    (``--all``), each site of a named set (``set:NAME``), or the one scenario."""
    import multicrane
    from multicrane.scenario.named_sets import is_set_ref, resolve_set

    if args.all:
        return [(name, name, n) for name in multicrane.scenario_names() for n in (1, 4)]
    if is_set_ref(args.scenario):
        return [(name.split("/")[-1], s, args.cranes) for name, s in resolve_set(args.scenario)]
    return [(args.scenario, args.scenario, args.cranes)]


def run_task(args: argparse.Namespace) -> int:
    """Task-level decision rounds of the one-site env and of the compiled task env (one copy,
    ``multicrane.vector.task_vector_env``), the same planners, in turn."""
    import multicrane
    from multicrane.vector import bench as vector

    runs = _runs(args)
    rounds = min(args.steps, 2000) if args.steps == 20000 else args.steps
    print(f"{'scenario':<12} {'cranes':>6} {'policy':>12} {'env':>9} {'rounds/s':>10} "
          f"{'mean ms':>8} {'p95 ms':>8}")  # fmt: skip
    for name, scenario, n in runs:
        shown = n if n is not None else multicrane.load_scenario(scenario).cranes
        for policy in ("prioritized", "random"):
            times = {"one-site": task_round_seconds(scenario, n, rounds, policy)}
            try:
                times["compiled"] = vector.task_round_seconds(scenario, n, rounds, policy)
            except ValueError as unmodelled:  # site events: the one-site env only
                print(f"{name:<12} {shown:>6} {policy:>12} compiled: {unmodelled}")
            for env, t in times.items():
                print(f"{name:<12} {shown:>6} {policy:>12} {env:>9} {1 / t.mean():>10,.0f} "
                      f"{1000 * t.mean():>8.3f} {1000 * np.percentile(t, 95):>8.3f}")  # fmt: skip
    return 0


def run_scaling(args: argparse.Namespace) -> int:
    import policies
    from multicrane.reports import scaling

    def planner(env, seed):
        return policies.make("prioritized", env, seed=seed)

    rows = []
    for n, k in scaling.grid(args.full):
        rows.append(scaling.measure(n, k, planner))
        r = rows[-1]
        print(f"{r['components']:>4} components {k:>2} cranes: load {r['load_s']:.3f} s, "
              f"reset {1e3 * r['reset_s']:.1f} ms, step {r['step_ms']:.2f} ms, "
              f"plan {r['plan_ms']:.2f} ms (max {r['plan_ms_max']:.1f})", flush=True)  # fmt: skip
    print()
    print(scaling.table(rows))
    if args.plot:
        scaling.plot(rows, args.plot)
        print(f"\nwrote {args.plot}")
    return 0


VECTOR_COPIES = (1, 64, 1024, 4096)


def run_vector(args: argparse.Namespace) -> int:
    """The vector paper env beside the one-site env (see DESCRIPTION)."""
    from multicrane.vector import bench as vector

    print(f"{'config':<8} {'env':<9} {'copies':>6} {'steps/s':>12} {'bytes/copy':>11}")
    configs = args.paper or ("E1S1", "E4S1")
    for config in configs:
        rounds: dict[int, list[float]] = {0: [], **{b: [] for b in VECTOR_COPIES}}
        for _ in range(3):  # interleaved: one-site, then each B, three times
            rounds[0].append(paper_steps_per_second(config, args.steps))
            for b in VECTOR_COPIES:
                rounds[b].append(vector.steps_per_second(config, b))
        print(f"{config:<8} {'one-site':<9} {1:>6} {np.median(rounds[0]):>12,.0f}")
        for b in VECTOR_COPIES:
            print(f"{config:<8} {'vector':<9} {b:>6} {np.median(rounds[b]):>12,.0f} "
                  f"{vector.bytes_per_copy(config, b):>11,.0f}")  # fmt: skip
    first, second = vector.start_seconds(configs[0])  # the kernels are the same for all
    print(f"first step of a fresh process: {first:.1f} s with an empty numba cache (the "
          f"compile), {second:.2f} s with the cache it left")  # fmt: skip
    return run_vector_motion(args)


def run_vector_motion(args: argparse.Namespace) -> int:
    """The vector motion env (hall-4c, 4 cranes) beside the one-site env (see DESCRIPTION)."""
    from multicrane.vector import bench as vector

    scenario, cranes = "hall-4c", 4
    if args.events is not None:
        print(f"site events: {args.events}")
    print(f"{'scenario':<8} {'env':<9} {'copies':>6} {'joint steps/s':>13} {'bytes/copy':>11}")
    kinds = {"vector": np.float32, "vector-u8": np.uint8}  # the observations' dtype
    rounds: dict[tuple[str, int], list[float]] = {("one-site", 1): []}
    rounds.update({(kind, b): [] for b in VECTOR_COPIES for kind in kinds})
    for _ in range(3):  # interleaved, as above
        rounds["one-site", 1].append(
            joint_steps_per_second(scenario, cranes, args.steps // 4, events=args.events)
        )
        for b in VECTOR_COPIES:
            for kind, dtype in kinds.items():
                rounds[kind, b].append(vector.motion_steps_per_second(
                    scenario, cranes, b, events=args.events, obs_dtype=dtype))  # fmt: skip
    print(f"{scenario:<8} {'one-site':<9} {1:>6} {np.median(rounds['one-site', 1]):>13,.0f}")
    for b in VECTOR_COPIES:
        for kind, dtype in kinds.items():
            size = vector.motion_bytes_per_copy(scenario, cranes, b, obs_dtype=dtype)
            print(f"{scenario:<8} {kind:<9} {b:>6} {np.median(rounds[kind, b]):>13,.0f} "
                  f"{size:>11,.0f}")  # fmt: skip
    first, second = vector.start_seconds(scenario, cranes)
    print(f"motion env, first step of a fresh process: {first:.1f} s with an empty numba "
          f"cache, {second:.2f} s with the cache it left")  # fmt: skip
    return run_vector_task(args)


TASK_COPIES = (1, 64, 1024)  # the task env's copy counts in ``--vector``


def run_vector_task(args: argparse.Namespace) -> int:
    """The compiled task env (hall-4c, 4 cranes) beside the one-site task env: decision
    rounds a second under the prioritized rule and random tasks (see DESCRIPTION)."""
    from multicrane.vector import bench as vector

    scenario, cranes = "hall-4c", 4
    print(f"{'scenario':<8} {'env':<9} {'copies':>6} {'policy':>12} {'rounds/s':>10} "
          f"{'bytes/copy':>11}")  # fmt: skip
    for policy in ("prioritized", "random"):
        rates: dict[int, list[float]] = {0: [], **{b: [] for b in TASK_COPIES}}
        for _ in range(3):  # interleaved, as above
            rates[0].append(1 / task_round_seconds(scenario, cranes, 600, policy).mean())
            for b in TASK_COPIES:
                t = vector.task_round_seconds(scenario, cranes, max(8, 2000 // b), policy, b)
                rates[b].append(b / t.mean())
        print(f"{scenario:<8} {'one-site':<9} {1:>6} {policy:>12} {np.median(rates[0]):>10,.0f}")
        for b in TASK_COPIES:
            size = vector.task_bytes_per_copy(scenario, cranes, b)
            print(f"{scenario:<8} {'vector':<9} {b:>6} {policy:>12} "
                  f"{np.median(rates[b]):>10,.0f} {size:>11,.0f}")  # fmt: skip
    first, second = vector.start_seconds(scenario, cranes, task=True)
    print(f"task env, first round of a fresh process: {first:.1f} s with an empty numba "
          f"cache, {second:.2f} s with the cache it left")  # fmt: skip
    return 0


TRAIN_MOTION = ("hall-4c", 4)  # --train's multi-agent motion mode: scenario, cranes


def run_train(args: argparse.Namespace) -> int:
    """Training throughput, the lean PPO beside MaskablePPO, in the paper mode and the
    multi-agent motion mode (see DESCRIPTION)."""
    from multicrane.training.lean_ppo_bench import training_steps_per_second

    scenario, cranes = TRAIN_MOTION
    modes = {(args.paper or ["E1S1"])[0]: None, f"{scenario}-{cranes}c": TRAIN_MOTION}
    budgets = {"maskable_ppo": args.steps, "lean_ppo": 10 * args.steps}
    rates = {(mode, name): [] for mode in modes for name in budgets}
    for _ in range(2):  # interleaved rounds
        for mode, motion in modes.items():
            config, cranes = motion or (mode, None)
            for name, steps in budgets.items():
                rates[mode, name].append(
                    training_steps_per_second(name, config, steps, n_cranes=cranes)
                )
    median = {key: np.median(r, axis=0) for key, r in rates.items()}  # (wall, CPU)
    print(f"{'mode':<10} {'algorithm':<13} {'steps':>9} {'steps/s':>10} {'steps/CPU-s':>12}")
    for mode in modes:
        for name, steps in budgets.items():
            wall, cpu = median[mode, name]
            print(f"{mode:<10} {name:<13} {steps:>9,} {wall:>10,.0f} {cpu:>12,.0f}")
    for mode in modes:
        wall, cpu = median[mode, "lean_ppo"] / median[mode, "maskable_ppo"]
        print(f"{mode}: lean_ppo / maskable_ppo {wall:.1f}x per wall second, {cpu:.1f}x per "
              "CPU second (rollouts and updates, one torch thread)")  # fmt: skip
    print("motion mode: a step is one crane's decision (joint steps x cranes)")
    return 0


def run(args: argparse.Namespace) -> int:
    import multicrane

    if args.train:
        return run_train(args)
    if args.scaling:
        return run_scaling(args)
    if args.events is not None and not args.vector:
        from multicrane.cli.common import error

        return error("--events goes with --vector (the motion envs' site events)")
    if args.vector:
        return run_vector(args)
    if decision_mode(args.decisions).task_level:
        return run_task(args)

    if args.paper is not None:
        print(f"{'config':<12} {'mode':>7} {'steps/s':>14}")
        for config in args.paper or multicrane.PAPER_CONFIGS:
            rate = paper_steps_per_second(config, args.steps)
            print(f"{config:<12} {'paper':>7} {rate:>14,.0f}")
        return 0
    try:
        runs = _runs(args)
    except ValueError as e:  # an unknown set name
        from multicrane.cli.common import error

        return error(str(e))
    print(f"{'scenario':<12} {'cranes':>6} {'mode':>7} {'joint steps/s':>14}")
    for name, scenario, n in runs:
        from multicrane.sim.reach import crane_count_problem

        loaded = multicrane.load_scenario(scenario)
        problem = None if n is None else crane_count_problem(loaded, n)
        if problem is not None:  # crane reach: a tower-crane scenario needs its own cranes
            print(f"{name:<12} {n:>6} skipped: {problem}")
            continue
        rate = joint_steps_per_second(scenario, n, args.steps, auto=args.auto)
        shown = n if n is not None else loaded.cranes
        mode = "auto" if args.auto else "claims"
        print(f"{name:<12} {shown:>6} {mode:>7} {rate:>14,.0f}")
    return 0
