"""Policies for multicrane: baselines, planners and learned agents, made by name.

Every policy here acts through the environments' own interfaces (observations and masks, or
the simulator state they expose), so any of them can be evaluated and recorded the same way
(``multicrane.episodes.rollout``). ``make``, ``factory`` and ``names`` (``policies.registry``)
build them by name under one seeding rule; ``split_spec`` reads a name with its options
(``lookahead:candidates=20``).
"""

from policies.registry import (
    NAMES,
    Factory,
    PolicyError,
    factory,
    make,
    names,
    policy_seed,
    split_spec,
)

__all__ = ["NAMES", "Factory", "PolicyError", "factory", "make", "names", "policy_seed",
           "split_spec"]  # fmt: skip
