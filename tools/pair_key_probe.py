"""Probe: the prioritized rule with a learned pair key that sees the round, trained by ES.

    .venv/bin/python tools/pair_key_probe.py --generations 60 --out runs/pair-key/train-s0
    .venv/bin/python tools/pair_key_probe.py --evaluate runs/pair-key/train-s0 --set test-small

The learned rule (``prioritized:rank=chain,scorer=NAME``) ranks the ready (component, target)
pairs of a round by the target's chain, then the scorer's list place, then the distance. This
probe replaces that lexicographic key by a linear one over ``PAIR_FEATURES`` of each pair in
each round (the ranking ``multicrane.tasks.priority_rule.ranked_pairs`` returns, swapped
inside ``keyed_ranking``; ties as before): what the static order knows (the scorer's place,
the target's chain, dependents and height, the distance over the site's mean shortest
distance) and what only the round knows (the tasks under way with a target within 4 cells of
this one, how many open targets the component fits, how many ready components the target
takes, the time). ``start_weights`` rank exactly as the chain rank. The weights follow
``tools/order_es.py``'s ES (``es_step``, Adam) on ``--sites`` ``train`` sites a generation of
a pool drawn from ``--seed``, validated every ``--val-every`` generations on ``--val-sites``
others (or with ``--fit-set NAME``, a diagnostic, on a held-out set's own episodes); the best
goes to ``OUT/pair_key.json``, each generation to ``OUT/log.jsonl``. ``--evaluate OUT`` plays
the kept key, the start key and the chain rank on a held-out set against the planner. It
met issue 33's target 3 on test-small in two seeds of five and lost on test-large and
test-other (docs/marl-results.md), so it stays a probe, outside the library. Base install
only.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
from multiprocessing import Pool
from pathlib import Path

import numpy as np

import multicrane
import multicrane.tasks.priority_rule as priority_rule
from multicrane.episodes.rollout import run_episode
from multicrane.scenario.named_sets import draw_train_seeds, members
from multicrane.tasks.support_graph import site_chains
from policies.task_planners import TaskPrioritized, load_scorer

sys.path.insert(0, str(Path(__file__).parent))  # tools/ is not a package
from order_es import Adam, es_step, site_episode  # noqa: E402

PAIR_FEATURES = (
    "list_place", "chain", "distance", "dependents", "target_height", "busy_near",
    "component_options", "target_options", "cranes_x_chain", "cranes_x_distance", "time",
)  # fmt: skip


class PairKey:
    """A linear key over ``PAIR_FEATURES`` (lower ranks first), with ``order_es``'s
    ``parameters`` / ``with_parameters`` so that its ES step can probe it."""

    def __init__(self, weights):
        self.weights = np.asarray(weights, dtype=np.float64)

    def parameters(self) -> np.ndarray:
        return self.weights.copy()

    def with_parameters(self, vector) -> PairKey:
        return PairKey(vector)


def start_weights() -> np.ndarray:
    """The chain rank's order: chain first (it moves the key by 2 a level, the place by less
    than 1), then the place; the ties of the key break as the library's (place, distance,
    target)."""
    weights = np.zeros(len(PAIR_FEATURES))
    weights[:2] = (1.0, -2.0)
    return weights


_CONSTANTS: dict = {}


def _site_constants(sim) -> tuple:
    """Per target its chain, dependents over the targets and centre, and the site's longest
    side (computed once per site)."""
    site = sim.site
    if site not in _CONSTANTS:
        _CONSTANTS[site] = _constants(sim)
    return _CONSTANTS[site]


def _constants(sim) -> tuple:
    site = sim.site
    chain, dependents = site_chains(site)
    centres = np.array([np.mean([site.cell(x) for x in cells], axis=0)
                        for cells in site.target_cells])  # fmt: skip
    return chain.astype(float), dependents / len(centres), centres, float(max(sim.scenario.size))


def pair_features(carrier, comp, targets, dist, rows, list_rank) -> np.ndarray:
    """(pairs, ``PAIR_FEATURES``) for the ready pairs ``comp[i], targets[i]`` at ``dist[i]``,
    ``rows[i]`` the component's row among the round's candidates."""
    sim = carrier.sim
    chain, dependents, centres, side = _site_constants(sim)
    every = carrier.pair_distances().astype(float)
    every[every < 0] = np.nan
    covered = ~np.isnan(every).all(axis=1)  # components with some pose on a target
    scale = float(np.nanmin(every[covered], axis=1).mean()) if covered.any() else 1.0
    n, cranes = sim.site.n_components, sim.n_cranes / 16
    place = np.array([list_rank[c] for c in comp.tolist()], dtype=float) / n
    busy = [plan.target for plan in carrier.plans.values()]
    near = np.zeros(len(targets))
    if busy:
        gaps = np.abs(centres[targets][:, None, :] - centres[busy][None, :, :]).sum(-1)
        near = (gaps <= 4).sum(axis=1)
    distance = dist / (scale or 1.0)
    return np.stack([
        place, chain[targets], distance, dependents[targets], centres[targets, 2] / side,
        near / 4, np.bincount(rows)[rows] / n, np.bincount(targets)[targets] / n,
        chain[targets] * cranes, distance * cranes,
        np.full(len(targets), sim.state.step_count / (10 * scale + 1)),
    ], axis=1)  # fmt: skip


@contextlib.contextmanager
def keyed_ranking(key: PairKey | None):
    """Within it, the rule ranks ready pairs by ``key`` (``None``: as the library does)."""
    library = priority_rule.ranked_pairs

    def ranked(carrier, candidates, taken, rank, list_rank):
        if not candidates:
            return []
        rows, comp, targets, d = priority_rule.ready_pairs(carrier, candidates, taken)
        features = pair_features(carrier, comp, targets, d, rows, list_rank)
        order = np.lexsort((targets, d, features[:, 0], features @ key.weights))
        return priority_rule.pair_tuples(order, d, comp, targets)

    priority_rule.ranked_pairs = library if key is None else ranked
    try:
        yield
    finally:
        priority_rule.ranked_pairs = library


def site_spans(site, scorer_name: str, keys: list[PairKey | None]) -> list:
    """On one site (``order_es.site_episode``), the planner's makespan and the learned rule's
    with each key (``None``: the chain rank); ``None`` for an unfinished episode."""
    scenario, seed = site_episode(site)
    env = multicrane.parallel_env(scenario, decisions="task")
    spans = [run_episode(env, TaskPrioritized(env, rank="list"), seed)["makespan"]]
    scorer = load_scorer(scorer_name)
    for key in keys:
        with keyed_ranking(key):
            rule = TaskPrioritized(env, rank="chain", scorer=scorer)
            spans.append(run_episode(env, rule, seed)["makespan"])
    return spans


def site_ratios(site, scorer_name: str, keys: list[PairKey | None]) -> list[float]:
    """``site_spans``' makespans over the planner's (an unfinished episode, either: 2)."""
    base, *spans = site_spans(site, scorer_name, keys)
    return [2.0 if span is None or base is None else span / base for span in spans]


def _job(args) -> list[float]:
    return site_ratios(*args)


def train(args, mapper) -> dict:
    """The ES loop of the module doc; returns the kept key's record."""
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(args.seed)
    if args.fit_set:
        pool = val = [f"{args.fit_set}:{i}" for i in range(len(members(args.fit_set)))]
    else:
        drawn = draw_train_seeds(np.random.default_rng([args.seed, 1]),
                                 args.val_sites + args.pool, 40, (1, 4))  # fmt: skip
        val, pool = drawn[: args.val_sites], drawn[args.val_sites :]
    key, adam, kept = PairKey(start_weights()), Adam(len(PAIR_FEATURES)), None
    # es_step's jobs are (site, args.rank, probes): here the rank's place holds the scorer
    es = argparse.Namespace(pairs=args.pairs, sigma=args.sigma, rank=args.scorer)
    trained = np.arange(len(PAIR_FEATURES))
    with (out / "log.jsonl").open("w") as log:
        for gen in range(args.generations + 1):
            row = {"generation": gen}
            if gen:
                picked = rng.choice(len(pool), min(args.sites, len(pool)), replace=False)
                sites = [pool[i] for i in sorted(picked.tolist())]
                grad, row["ratio"] = es_step(mapper, key, trained, sites, rng, es, job=_job)
                key = PairKey(key.weights - args.lr * adam.step(grad))
            if gen % args.val_every == 0:
                jobs = [(s, args.scorer, [key]) for s in val]
                row["validation"] = float(np.mean(mapper(_job, jobs, chunksize=1)))
                if kept is None or row["validation"] < kept["validation"]:
                    kept = {**row, "weights": key.weights.tolist(), "scorer": args.scorer}
            row["weights"] = key.weights.round(4).tolist()
            log.write(json.dumps(row) + "\n")
            print(json.dumps(row), flush=True)
    (out / "pair_key.json").write_text(json.dumps(kept, indent=1) + "\n")
    return kept


def _spans_job(args) -> list:
    return site_spans(*args)


def evaluate(run: str, set_name: str, mapper) -> str:
    """The kept key, the start key and the chain rank on every site of a held-out set: the
    mean makespan, its ratio to the planner's, the mean of per-site ratios and the sites
    longer than the planner (an unfinished episode is named, not averaged)."""
    kept = json.loads((Path(run) / "pair_key.json").read_text())
    keys = [PairKey(kept["weights"]), PairKey(start_weights()), None]
    jobs = [(f"{set_name}:{i}", kept["scorer"], keys) for i in range(len(members(set_name)))]
    rows = mapper(_spans_job, jobs, chunksize=1)
    unfinished = [i for i, row in enumerate(rows) if None in row]
    spans = np.array([row for row in rows if None not in row], dtype=float)
    base = spans[:, 0]
    lines = [f"{set_name}, kept generation {kept['generation']} (validation "
             f"{kept['validation']:.4f}); planner {base.mean():.1f}"]  # fmt: skip
    if unfinished:
        lines.append(f"  unfinished (left out): sites {unfinished}")
    for name, column in zip(("pair key", "start key", "chain rank"), spans[:, 1:].T, strict=True):
        ratios = column / base
        lines.append(f"  {name}: {column.mean():.1f} ({column.mean() / base.mean():.4f}; per "
                     f"site {ratios.mean():.4f}), longer than the planner on "
                     f"{int((ratios > 1).sum())} sites (worst {ratios.max():.3f})")  # fmt: skip
    return "\n".join(lines)


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", help="the run directory (pair_key.json, log.jsonl)")
    p.add_argument("--evaluate", metavar="RUN", help="play RUN's key on --set and exit")
    p.add_argument("--set", default="test-small", help="--evaluate: the held-out set")
    p.add_argument("--scorer", default="order-es21-s0", help="the learned list order")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--generations", type=int, default=60)
    p.add_argument("--pairs", type=int, default=8, help="directions per generation (x2 probes)")
    p.add_argument("--sigma", type=float, default=0.1)
    p.add_argument("--lr", type=float, default=0.03)
    p.add_argument("--sites", type=int, default=32, help="train sites per generation")
    p.add_argument("--pool", type=int, default=336, help="train sites drawn from")
    p.add_argument("--val-sites", type=int, default=64)
    p.add_argument("--val-every", type=int, default=5)
    p.add_argument("--fit-set", metavar="NAME",
                   help="a diagnostic, never a held-out result: train and validate on this "
                        "held-out set's own episodes")  # fmt: skip
    p.add_argument("--workers", type=int, default=2)
    return p


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    if not (args.evaluate or args.out):
        parser().error("give --out to train or --evaluate RUN")
    if args.evaluate and not (Path(args.evaluate) / "pair_key.json").is_file():
        parser().error(f"--evaluate: {args.evaluate}/pair_key.json: no such file (a run "
                       "directory of this tool)")  # fmt: skip
    for name in filter(None, (args.fit_set, args.evaluate and args.set)):
        try:
            members(name)
        except ValueError as exc:
            parser().error(str(exc))
    pool = Pool(args.workers) if args.workers > 1 else None
    mapper = pool.map if pool else (lambda f, jobs, chunksize: list(map(f, jobs)))
    try:
        if args.evaluate:
            print(evaluate(args.evaluate, args.set, mapper))
        else:
            kept = train(args, mapper)
            print(f"kept generation {kept['generation']}, validation {kept['validation']:.4f}")
    finally:
        if pool:
            pool.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
