"""``multicrane marl-bench``: the set policy's decision latency and training rows per second."""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from multicrane.cli.common import error, formatter

DESCRIPTION = """Measure the shared task-level policy (needs the 'train' extra); one torch thread.

    multicrane marl-bench --latency --scenario hall-4c --cranes 4
    multicrane marl-bench --latency --policy runs/hall-set   # a trained run's model
    multicrane marl-bench --throughput --scenario hall-4c --cranes 4 --steps 8192

--latency: milliseconds per crane decision of the set policy (greedy, the SB3 predict call
with padding and masks, all cranes of a round in one batch), over the decision rounds of
whole episodes (seeds 0, 1, ...; the environment's step is not counted), untrained weights
unless --policy names a run. --throughput: training rows (crane decisions) per second of
MaskablePPO on the scenario in task mode, for today's MLP defaults ('before') and the set
policy's defaults ('after'), each for --steps rows in this process (after one warm-up
update), with the share of the wall time spent in PPO's update; --workers 1 2 4 repeats the
set policy's settings with the environment copies in that many processes (CPU time then
counts this process only). Both also report CPU time
(this process's), steadier than wall time on a shared machine; run on an idle core for
stable wall-time figures.
"""


def register(sub) -> None:
    p = sub.add_parser("marl-bench", help="set policy latency and training rows/s",
                       description=DESCRIPTION, **formatter())  # fmt: skip
    p.add_argument("--scenario", default="hall-4c")
    p.add_argument("--cranes", type=int, default=4)
    p.add_argument("--latency", action="store_true")
    p.add_argument("--throughput", action="store_true")
    p.add_argument("--policy", default=None, help="a run directory (latency of its model)")
    p.add_argument("--rounds", type=int, default=500, help="decision rounds timed (latency)")
    p.add_argument("--steps", type=int, default=8192, help="rows trained per setting")
    p.add_argument(
        "--workers",
        type=int,
        nargs="+",
        default=[1],
        help="throughput of the set policy with these numbers of environment processes "
        "(e.g. 1 2 4)",
    )
    p.add_argument(
        "--which",
        nargs="+",
        default=["before", "after"],
        help="throughput settings: before, after, after-attention (set policy "
        "with one attention block), after-makespan (the makespan reward, no shaping)",
    )
    p.set_defaults(func=run)


def latency(scenario: str, cranes: int, rounds: int, run_dir: str | None) -> dict:
    """Milliseconds per crane decision of a set policy on ``scenario``: the wall and CPU
    time of its calls (not the environment's steps) over ``rounds`` decision rounds of
    episodes on seeds 0, 1, ... (the first 5 rounds left out when there are more than 10)."""
    import torch as th

    from multicrane.envs.crane_env import MultiCraneEnv
    from multicrane.episodes.rollout import Stopwatch, play_seeds
    from multicrane.training.model_policy import SetModelPolicy, load_run
    from multicrane.training.set_obs import SetLimits
    from multicrane.training.set_training import make_set_model, set_hyperparameters
    from multicrane.training.set_vec_env import SetVecEnv

    th.set_num_threads(1)
    env = MultiCraneEnv(scenario, n_cranes=cranes, decisions="task")
    if run_dir:
        model, _ = load_run(run_dir)
    else:
        limits = SetLimits.of(env.observation_layout)
        venv = SetVecEnv(lambda i: MultiCraneEnv(scenario, n_cranes=cranes, decisions="task"),
                         1, limits)  # fmt: skip
        model = make_set_model(venv, 0, set_hyperparameters({}), None)
    wall, cpu = Stopwatch(), Stopwatch(time.process_time)
    policy = cpu.timing(wall.timing(SetModelPolicy(model, env)))  # the policy's calls only
    play_seeds(env, lambda env, seed: policy, rounds)
    n = len(env.possible_agents)
    times, cpu_times = wall.seconds, cpu.seconds
    ms = np.array(times[5:] if len(times) > 10 else times) * 1e3 / n
    cpu_ms = np.array(cpu_times[5:] if len(cpu_times) > 10 else cpu_times) * 1e3 / n
    return {"decisions": len(ms) * n, "mean_ms": float(ms.mean()),
            "p95_ms": float(np.percentile(ms, 95)), "cpu_ms": float(cpu_ms.mean())}  # fmt: skip


# before: the MLP defaults on the flat observation; after: the set policy's defaults;
# after-attention: with one attention block; after-makespan: the makespan reward without
# shaping (what the imitation recipe trains on, docs/training.md)
SETTINGS = ("before", "after", "after-attention", "after-makespan")


def throughput(scenario: str, cranes: int, steps: int, which: str, workers: int = 1) -> dict:
    """Training rows per second and the update's share of the wall time for one setting."""
    import torch as th

    from multicrane.training.config import TrainConfig
    from multicrane.training.trainer import Run, make_vec_env

    th.set_num_threads(1)
    policy = "mlp" if which == "before" else "set"
    hyper = {"policy_kwargs": {"features_extractor_kwargs": {"heads": 4}}}
    if which not in SETTINGS:
        raise ValueError(f"--which {which!r}: one of {', '.join(SETTINGS)}")
    reward = {"reward": "makespan", "shaping": 0.0} if which == "after-makespan" else {}
    cfg = TrainConfig(scenario, paper=False, n_cranes=cranes, algo="maskable_ppo",
                      decisions="task", policy=policy,
                      hyperparams=hyper if which == "after-attention" else {},
                      workers=1 if which == "before" else workers, **reward)  # fmt: skip
    run = Run(cfg, "unused", log=lambda *a: None)
    venv = make_vec_env(cfg, run.algo, run.params)
    if policy == "set":
        from multicrane.training.set_training import make_set_model

        model = make_set_model(venv, 0, run.params, None)
        model.policy.claim_rows = venv.n_agents  # as the training run samples (claims.py)
    else:
        from multicrane.training.algorithms import make_model

        model = make_model(run.algo, venv, 0, run.params, None)
    spent = {"update": 0.0}
    inner = model.train

    def timed_train(*args, **kwargs):
        start = time.perf_counter()
        inner(*args, **kwargs)
        spent["update"] += time.perf_counter() - start

    model.train = timed_train
    per_update = model.n_steps * venv.num_envs
    model.learn(per_update)  # warm-up: one update, not timed
    spent["update"] = 0.0
    start, start_cpu = time.perf_counter(), time.process_time()
    model.learn(max(steps, per_update), reset_num_timesteps=False)
    wall, cpu = time.perf_counter() - start, time.process_time() - start_cpu
    rows = model.num_timesteps - per_update
    venv.close()
    label = which if which == "before" or workers == 1 else f"{which}-w{workers}"
    return {"setting": label, "rows": int(rows), "seconds": wall, "rows_per_s": rows / wall,
            "rows_per_cpu_s": rows / cpu, "update_share": spent["update"] / wall,
            "rows_per_update": per_update}  # fmt: skip


def run(args: argparse.Namespace) -> int:
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    if not (args.latency or args.throughput):
        return error(ValueError("choose --latency and/or --throughput"))
    try:
        if args.latency:
            r = latency(args.scenario, args.cranes, args.rounds, args.policy)
            print(f"{args.scenario}, {args.cranes} cranes, set policy: {r['decisions']} crane "
                  f"decisions, per crane decision: {r['mean_ms']:.3f} ms mean, {r['p95_ms']:.3f} "
                  f"ms p95 (wall), {r['cpu_ms']:.3f} ms CPU time (one thread)")  # fmt: skip
        if args.throughput:
            out = [
                throughput(args.scenario, args.cranes, args.steps, w, k)
                for w in args.which
                for k in ([1] if w == "before" else args.workers)
            ]
            print(f"{'setting':<12}{'rows':>8}{'seconds':>9}{'rows/s':>9}{'rows/CPU-s':>12}"
                  f"{'update %':>10}")  # fmt: skip
            for r in out:
                print(f"{r['setting']:<12}{r['rows']:>8}{r['seconds']:>9.1f}"
                      f"{r['rows_per_s']:>9.0f}{r['rows_per_cpu_s']:>12.0f}"
                      f"{100 * r['update_share']:>9.0f}%")  # fmt: skip
            if len(out) > 1:
                base = out[0]["rows_per_s"]
                print(
                    "speed-up vs "
                    + out[0]["setting"]
                    + ": "
                    + ", ".join(f"{r['setting']} {r['rows_per_s'] / base:.2f}x" for r in out[1:])
                )
    except (ValueError, FileNotFoundError, OSError) as exc:
        return error(exc)
    return 0
