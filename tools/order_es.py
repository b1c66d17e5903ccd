"""Learns the prioritized rule's list order on ``train`` sites: a scorer, by ES or policy gradient.

    .venv/bin/python tools/order_es.py --seed 0 --generations 160 --out runs/order-es21/es-s0
    multicrane evaluate --scenario set:test-small --decisions task --episodes 1 \\
        --policy prioritized:rank=chain prioritized:rank=chain,scorer=runs/order-es21/es-s0

The policy is ``TaskPrioritized(rank=--rank, scorer=...)``: the rule with the components in the
order of a score of their static features (``multicrane.tasks.order_scorer``: linear, or with
``--hidden`` tanh units beside it), computed once at reset; nothing is searched when it plays
beyond what the rule itself asks of the carrier. The weights start at the scenario's list order
(the plain rule) and follow OpenAI-style evolution strategies: each generation draws
``--sites`` sites of the ``train`` distribution with at most ``--max-components`` components
and ``--cranes`` cranes (the reset seed is the site's seed) and ``--pairs`` Gaussian
directions; each direction is played at plus and minus ``--sigma`` on every site; the fitness
is the mean over the sites of the makespan divided by the rule's own (``rank=--rank``, the
scenario's order; an unfinished episode counts twice the rule's); the difference of each pair,
over the spread of the generation, weighs its direction, and Adam (``--lr``) takes the step.
Every ``--val-every`` generations the weights play ``--val-sites`` other train sites; the best
of them is written to ``OUT/scorer.json`` at the end (its meta: the rank, the seed, the
generation, the validation ratio, the training range), and every generation to
``OUT/log.jsonl`` (episodes played, wall seconds, the generation's mean ratio, the validation
ratio). All draws come from ``--seed``; ``--workers`` processes play the episodes (the result
does not depend on their number). ``--features K`` trains the first K features only (16: the
first recipe's). ``--hidden H`` adds H tanh units to the linear score (``OrderScorer``'s hidden
layer; input weights drawn from the seed, outputs starting at 0, so the start is still the
plain rule), trained with the rest. ``--average B`` validates, and keeps, a running average of
the iterates instead of the iterate itself (the search is the same; the average smooths the
generation-to-generation noise of ES). ``--estimator reinforce`` replaces ES by the policy
gradient of the scorer's own orders: each generation plays ``--samples`` orders per site drawn
from the Plackett-Luce distribution of the scores at ``--temperature`` (as the rule's
``samples`` option draws them), weighs the gradient of each order's log-probability by its
ratio minus the mean ratio of its site, and Adam takes the step. ``--estimator best`` draws the
same orders but learns from each site's shortest ones only (expert iteration over the scorer's
own search at reset, or the cross-entropy method): the step climbs the log-probability of each
site's shortest sample (tied shortest samples share it). ``--fit-set NAME`` is a
diagnostic, never a held-out result: the scorer fitted to a held-out set's own episodes, to
see how far it can go there. Base install only.
"""

from __future__ import annotations

import argparse
import json
import time
from multiprocessing import Pool
from pathlib import Path

import numpy as np

import multicrane
from multicrane.episodes.rollout import run_episode
from multicrane.scenario.named_sets import (
    draw_train_seeds,
    members,
    scenario_set,
    train_member,
)
from multicrane.tasks.order_scorer import FEATURES, OrderScorer, component_features
from multicrane.training.seeding import evaluation_seeds
from policies.task_planners import TaskPrioritized


def site_episode(site: int | str):
    """A site's scenario and reset seed: a train seed (reset seed: the site's own), or
    ``NAME:I``, member I of a held-out set, played from the first evaluation seed (the
    episode ``multicrane evaluate --episodes 1`` plays)."""
    if isinstance(site, str):
        name, index = site.rsplit(":", 1)
        return scenario_set(name)[int(index)][1], evaluation_seeds(1)[0]
    return train_member(site).scenario(), site


def site_ratios(site: int | str, rank: str, scorers: list[OrderScorer]) -> list[float]:
    """On one site (``site_episode``), each scorer's makespan over the rule's own with the
    scenario's order (an unfinished episode: 2)."""
    scenario, seed = site_episode(site)
    env = multicrane.parallel_env(scenario, decisions="task")
    base = run_episode(env, TaskPrioritized(env, rank=rank), seed)["makespan"]
    out = []
    for scorer in scorers:
        span = run_episode(env, TaskPrioritized(env, rank=rank, scorer=scorer), seed)["makespan"]
        out.append(_ratio(span, base))
    return out


def _ratio(span, base) -> float:
    """A makespan over the rule's own (an unfinished episode, either of them: 2)."""
    return 2.0 if span is None or base is None else span / base


def _job(args) -> list[float]:
    return site_ratios(*args)


def es_step(mapper, scorer, trained, sites, rng, args, job=_job) -> tuple[np.ndarray, float]:
    """One generation: the gradient estimate of the mean ratio (lower is better) over the
    parameters ``trained`` (indices into ``scorer.parameters()``) and the generation's mean
    ratio. ``job((site, rank, probes))`` gives each probe's ratio on a site (``site_ratios``;
    the probes are ``scorer.with_parameters`` of the perturbed parameters)."""
    eps = rng.standard_normal((args.pairs, len(trained)))
    params = scorer.parameters()
    probes = []
    for e in eps:
        for sign in (1.0, -1.0):
            probe = params.copy()
            probe[trained] += sign * args.sigma * e
            probes.append(scorer.with_parameters(probe))
    jobs = [(s, args.rank, probes) for s in sites]
    ratios = np.array(mapper(job, jobs, chunksize=1)).mean(axis=0).reshape(args.pairs, 2)
    spread = max(float(ratios.std()), 1e-3)
    grad = ((ratios[:, 0] - ratios[:, 1])[:, None] * eps).sum(0)
    return grad / (2 * args.pairs * args.sigma * spread), float(ratios.mean())


class Adam:
    """Adam's step direction (decay 0.9 and 0.999) for a gradient estimate, call by call."""

    def __init__(self, size: int):
        self.m, self.v, self.calls = np.zeros(size), np.zeros(size), 0

    def step(self, grad: np.ndarray) -> np.ndarray:
        self.calls += 1
        self.m = 0.9 * self.m + 0.1 * grad
        self.v = 0.999 * self.v + 0.001 * grad**2
        m_hat, v_hat = self.m / (1 - 0.9**self.calls), self.v / (1 - 0.999**self.calls)
        return m_hat / (np.sqrt(v_hat) + 1e-8)


def site_samples(site: int | str, rank: str, scorer: OrderScorer, samples: int,
                 temperature: float, seed: int) -> tuple[list[float], np.ndarray]:  # fmt: skip
    """On one site: ``samples`` orders drawn from the scorer's Plackett-Luce distribution
    (``OrderScorer.sampled_orders``, from ``seed``): each one's makespan over the rule's own
    (as ``site_ratios``) and the gradient of its log-probability."""
    scenario, reset_seed = site_episode(site)
    env = multicrane.parallel_env(scenario, decisions="task")
    base = run_episode(env, TaskPrioritized(env, rank=rank), reset_seed)["makespan"]
    env.reset(seed=reset_seed)
    features = component_features(env.unwrapped.mode.task_book(), scenario)
    orders = scorer.sampled_orders(features, scenario, samples + 1, temperature,
                                   np.random.default_rng(seed))[1:]  # fmt: skip
    ratios, grads = [], []
    for order in orders:
        span = run_episode(env, TaskPrioritized(env, rank=rank, order=order), reset_seed)
        ratios.append(_ratio(span["makespan"], base))
        grads.append(scorer.log_probability_gradient(features, order, temperature))
    return ratios, np.array(grads)


def _samples_job(args) -> tuple[list[float], np.ndarray]:
    return site_samples(*args)


def reinforce_step(mapper, scorer, trained, sites, rng, args) -> tuple[np.ndarray, float]:
    """One generation of the policy gradient (``--estimator reinforce``): ``--samples``
    orders per site from the scorer's Plackett-Luce distribution at ``--temperature``, each
    weighed by its ratio minus the site's mean ratio (the shared baseline), over the spread
    of the generation; returns, as ``es_step``, the estimate of the gradient of the mean
    ratio over the ``trained`` parameters and the generation's mean ratio. With
    ``--estimator best`` the direction is instead minus the mean over the sites of the
    gradient of the log-probability of each site's shortest sample (ties share it)."""
    seeds = rng.integers(0, 2**63, len(sites))
    jobs = [(s, args.rank, scorer, args.samples, args.temperature, int(seed))
            for s, seed in zip(sites, seeds, strict=True)]  # fmt: skip
    rows = mapper(_samples_job, jobs, chunksize=1)
    ratios = np.array([r for r, _ in rows])
    if args.estimator == "best":
        best = ratios == ratios.min(axis=1, keepdims=True)
        weights = -best.astype(float) / best.sum(axis=1, keepdims=True)
        grad = sum(w @ g[:, trained] for w, (_, g) in zip(weights, rows, strict=True))
        return grad / len(sites), float(ratios.mean())
    advantages = ratios - ratios.mean(axis=1, keepdims=True)
    spread = max(float(advantages.std()), 1e-3)
    grad = sum(a @ g[:, trained] for a, (_, g) in zip(advantages, rows, strict=True))
    return grad / (ratios.size * spread), float(ratios.mean())


def site_draws(args, rng: np.random.Generator):
    """The validation sites and a function drawing a generation's sites: ``train`` seeds
    within the limits, or with ``--fit-set`` every member validates and each generation
    draws ``--sites`` of them."""
    if args.fit_set:
        every = [f"{args.fit_set}:{i}" for i in range(len(members(args.fit_set)))]

        def some() -> list[str]:
            picked = rng.choice(len(every), min(args.sites, len(every)), replace=False)
            return [every[i] for i in sorted(picked.tolist())]

        return every, some
    limits = (args.max_components, tuple(args.cranes))
    val_sites = draw_train_seeds(np.random.default_rng([args.seed, 1]), args.val_sites, *limits)
    return val_sites, lambda: draw_train_seeds(rng, args.sites, *limits)


def train(args) -> OrderScorer:
    """The ES loop of the module doc; returns the best scorer by validation (also saved)."""
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(args.seed)
    val_sites, draw = site_draws(args, rng)
    scorer = OrderScorer.list_order(args.hidden, np.random.default_rng([args.seed, 2]))
    trained = scorer.trainable(args.features)
    adam = Adam(len(trained))
    best, episodes, start = (np.inf, scorer, 0), 0, time.perf_counter()
    mean = scorer.parameters()  # the running average of the iterates (--average)
    pool = Pool(args.workers) if args.workers > 1 else None
    mapper = pool.map if pool else (lambda f, jobs, chunksize: list(map(f, jobs)))
    with (out / "log.jsonl").open("w") as log:

        def validate(candidate: OrderScorer) -> float:
            jobs = [(s, args.rank, [candidate]) for s in val_sites]
            rows = mapper(_job, jobs, chunksize=1)
            return float(np.mean(rows))

        for gen in range(args.generations + 1):
            row = {"generation": gen}
            if gen:
                sites = draw()
                if args.estimator == "es":
                    grad, row["ratio"] = es_step(mapper, scorer, trained, sites, rng, args)
                    episodes += len(sites) * (2 * args.pairs + 1)
                else:
                    grad, row["ratio"] = reinforce_step(mapper, scorer, trained, sites, rng, args)
                    episodes += len(sites) * (args.samples + 1)
                step = adam.step(grad)
                params = scorer.parameters()
                params[trained] -= args.lr * step
                scorer = scorer.with_parameters(params)
                mean = args.average * mean + (1 - args.average) * params
            if gen % args.val_every == 0:
                played = scorer.with_parameters(mean) if args.average else scorer
                row["validation"] = validate(played)
                episodes += 2 * len(val_sites)
                if row["validation"] < best[0]:
                    best = (row["validation"], played, gen)
            row |= {"episodes": episodes, "seconds": round(time.perf_counter() - start, 1)}
            log.write(json.dumps(row) + "\n")
            log.flush()
            print(json.dumps(row), flush=True)
    if pool:
        pool.close()
    meta = {"rank": args.rank, "seed": args.seed, "generation": best[2],
            "validation_ratio": best[0], "max_components": args.max_components,
            "cranes": list(args.cranes), "features": args.features, "hidden": args.hidden,
            "average": args.average, "fit_set": args.fit_set,
            "estimator": args.estimator, "samples": args.samples,
            "temperature": args.temperature}  # fmt: skip
    kept = best[1].with_parameters(best[1].parameters(), meta)
    kept.save(out / "scorer.json")
    return kept


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", help="the run directory (scorer.json, log.jsonl)")
    p.add_argument("--curves", nargs="+", metavar="RUN",
                   help="print these runs' validation curves (their log.jsonl) and exit")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--generations", type=int, default=140)
    p.add_argument("--pairs", type=int, default=8, help="directions per generation (x2 probes)")
    p.add_argument("--sites", type=int, default=16, help="train sites per generation")
    p.add_argument("--estimator", default="es", choices=("es", "reinforce", "best"),
                   help="es: evolution strategies over the weights; reinforce: the policy "
                        "gradient of the scorer's sampled orders; best: the log-probability "
                        "of each site's shortest sampled order (expert iteration)")
    p.add_argument("--sigma", type=float, default=0.05)
    p.add_argument("--samples", type=int, default=16,
                   help="reinforce, best: orders sampled per site (x1 episode each)")
    p.add_argument("--temperature", type=float, default=0.5,
                   help="reinforce, best: the sampling temperature (as the rule's samples option)")
    p.add_argument("--lr", type=float, default=0.02)
    p.add_argument("--rank", default="chain", choices=("list", "chain", "nearest"))
    p.add_argument("--max-components", type=int, default=40)
    p.add_argument("--cranes", type=int, nargs=2, default=(1, 4), metavar=("LO", "HI"),
                   help="train (and validate) on sites with LO..HI cranes (train draws 1-4)")
    p.add_argument("--val-sites", type=int, default=48)
    p.add_argument("--val-every", type=int, default=10)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--features", type=int, default=len(FEATURES), metavar="K",
                   help=f"train the first K of the {len(FEATURES)} features, the rest stay 0 "
                        "(16: the features before the yard and crane terms)")
    p.add_argument("--hidden", type=int, default=0, metavar="H",
                   help="H tanh units beside the linear score (0: linear; their input weights "
                        "start from --seed, their outputs at 0)")
    p.add_argument("--average", type=float, default=0.0, metavar="B",
                   help="validate (and keep) the running average of the iterates, each "
                        "generation mean = B * mean + (1 - B) * weights (0: the iterate itself)")
    p.add_argument("--fit-set", metavar="NAME",
                   help="a diagnostic, never a held-out result: fit to the sites of this "
                        "held-out set (test-small, ...) and validate on all of them, the "
                        "episodes multicrane evaluate plays: how far this scorer can go there")
    return p


def curves(runs: list[str]) -> str:
    """A table: per validation point, each run's validation ratio, and the episodes and wall
    seconds the first run had taken by then."""
    logs = []
    for run in runs:
        path = Path(run) / "log.jsonl"
        if not path.is_file():
            raise SystemExit(f"order_es: {path}: no such log (a run directory of this tool)")
        logs.append([r for r in map(json.loads, path.read_text().splitlines())
                     if "validation" in r])  # fmt: skip
    names = [Path(r).name for r in runs]
    lines = ["| generation | episodes | seconds | " + " | ".join(names) + " |",
             "|---:|---:|---:|" + "---:|" * len(runs)]  # fmt: skip
    for i, row in enumerate(logs[0]):
        cells = [f"{log[i]['validation']:.4f}" if i < len(log) else "" for log in logs]
        lines.append(f"| {row['generation']} | {row['episodes']:,} | {row['seconds']:.0f} | "
                     + " | ".join(cells) + " |")  # fmt: skip
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    if not 1 <= args.features <= len(FEATURES):
        parser().error(f"--features must be 1..{len(FEATURES)}, got {args.features}")
    if args.hidden < 0:
        parser().error(f"--hidden must be 0 or more, got {args.hidden}")
    if args.estimator != "es" and (args.samples < 2 or not args.temperature > 0):
        parser().error(f"--samples must be 2 or more and --temperature positive, got "
                       f"{args.samples} and {args.temperature}")  # fmt: skip
    if not 0 <= args.average < 1:
        parser().error(f"--average must be in [0, 1), got {args.average}")
    if args.fit_set:
        try:
            members(args.fit_set)
        except ValueError as exc:
            parser().error(f"--fit-set: {exc}")
    if args.curves:
        print(curves(args.curves))
        return 0
    if not args.out:
        parser().error("--out is required to train (or give --curves)")
    scorer = train(args)
    named = ", ".join(f"{n} {w:+.3f}" for n, w in zip(FEATURES, scorer.weights, strict=True))
    print(f"best validation ratio {scorer.meta['validation_ratio']:.4f} at generation "
          f"{scorer.meta['generation']}; weights: {named}"
          f"{f' and {scorer.hidden_units} hidden units' if scorer.hidden_units else ''}\n"
          f"play it: --policy prioritized:rank={args.rank},scorer={args.out}")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
