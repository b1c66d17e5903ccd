"""CPU seconds of a task-level policy's first decision on one site, and of the reset before it.

    PYTHONPATH=. python tools/first_decision.py test-large/tower-s2000047 \\
        "prioritized:rank=chain,samples=16,guard=true,scorer=order-es21-s0"
    git worktree add /tmp/wt 14669db                        # an older tree
    PYTHONPATH=/tmp/wt python tools/first_decision.py test-large/tower-s2000047 POLICY

``SITE``: a shipped scenario, a scenario file, or a member of a held-out set by its name
(``SET/FAMILY-sSEED``, as ``multicrane evaluate`` lists them). The first ``reset`` of a site
(``seed``, default 0) builds the site's caches (every task's static path length per crane);
the policy is then made and asked for its first joint action, which for the search at reset
(``samples``, ``guard``) plays every candidate order to the end on copies of the site.
Prints the CPU seconds (``time.process_time``) of the reset and of the policy's making and
first call, and the process's peak memory (docs/performance.md, "Planning on large sites").
"""

from __future__ import annotations

import argparse
import resource
import time

import multicrane
import policies
from multicrane.scenario.named_sets import HELD_OUT, members


def site(name: str):
    """A held-out set's member by its name, else whatever ``parallel_env`` loads."""
    set_name = name.split("/")[0]
    if set_name in HELD_OUT:
        for member in members(set_name):
            if member.name == name:
                return member.scenario()
        raise SystemExit(f"{name!r}: no such member of {set_name}")
    return name


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("site")
    parser.add_argument("policy")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    env = multicrane.parallel_env(site(args.site), decisions="task")
    began = time.process_time()
    observations, _ = env.reset(seed=args.seed)
    reset = time.process_time() - began
    began = time.process_time()
    policy = policies.make(args.policy, env, seed=args.seed)
    policy(observations)
    decision = time.process_time() - began
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{args.site}: reset {reset:.2f} s, first decision {decision:.2f} s (CPU), "
          f"peak memory {peak:.0f} MiB")  # fmt: skip


if __name__ == "__main__":
    main()
