"""How short can a plan of one episode of a shipped scenario get? The suite's large-neighbourhood
search (``multicrane.suite.lns.improve``) started from a policy's episode.

    PYTHONPATH=. python tools/lns_episode.py hall-4c --cranes 4 --seconds 240 \\
        --start lookahead:candidates=20 --seeds 1000000 1000001 1000002

For each reset seed: the start policy's episode (task decisions) is recorded, its plan (each
crane's tasks in order) is improved by CP-SAT proposals judged by the simulator for
``--seconds``, and the start and best makespans are printed beside the proven lower bound of
the episode (``multicrane bound``, 10 s, 2 workers). The scenario is wrapped as a one-instance
suite (``Manifest``/``Instance`` of ``multicrane.suite.manifest``), so the search is the suite's
own, without events (the look-ahead refuses them). A developer program: it answers whether a
gap to the bound is the planner's or the bound's (docs/marl-results.md, "Search at decision
time").
"""

from __future__ import annotations

import argparse

import policies
from multicrane.bounds.makespan import lower_bound
from multicrane.replay.record import record_episode
from multicrane.scenario.catalog import scenarios_dir
from multicrane.suite.lns import improve
from multicrane.suite.manifest import Instance, Manifest, file_sha256
from multicrane.suite.play import make_env, makespan_of


def one_instance(name: str, cranes: int, seed: int) -> tuple[Manifest, Instance]:
    """The shipped scenario ``name`` as a suite of one instance (reset seed ``seed``)."""
    folder = scenarios_dir()
    file = f"{name}.toml"
    instance = Instance(id=f"{name}-{cranes}c-{seed}", file=file, track="episode", family=name,
                        components=0, cranes=cranes, seed=seed, events="none", reach=False,
                        sha256=file_sha256(folder / file), generator_seed=0, params=())  # fmt: skip
    return Manifest("episode", folder, "", (instance,)), instance


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("scenario", help="a shipped scenario name")
    p.add_argument("--cranes", type=int, required=True)
    p.add_argument("--seconds", type=float, default=120.0, help="search time per episode")
    p.add_argument("--start", default="lookahead", help="the start policy (task decisions)")
    p.add_argument("--seeds", type=int, nargs="+", default=[1_000_000])
    args = p.parse_args()
    make = policies.factory(args.start, paper=False)
    for seed in args.seeds:
        manifest, instance = one_instance(args.scenario, args.cranes, seed)
        env = make_env(manifest, instance, "task")
        start = record_episode(env, make(env, seed), seed, make.label)
        bound = lower_bound(args.scenario, args.cranes, seed, 10.0, workers=2).value
        out = improve(manifest, instance, args.seconds, start=start, bound=bound)
        print(f"{instance.id}: bound {bound}, {make.label} {makespan_of(start)}, "
              f"followed {out.start}, LNS {out.makespan} ({out.tries} proposals played, "
              f"{out.improved} shorter, {out.seconds:.0f} s)", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
