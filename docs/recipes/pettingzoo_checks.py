"""PettingZoo 1.27's own test utilities on one scenario (the suite runs them on all)."""

import functools
from types import SimpleNamespace

from pettingzoo.test import (
    api_test,
    max_cycles_test,
    parallel_api_test,
    parallel_seed_test,
    seed_test,
    state_test,
)

import multicrane

par = functools.partial(multicrane.parallel_env, "e3s2")
aec = functools.partial(multicrane.env, "e3s2")
api_test(aec(), num_cycles=20)
parallel_api_test(par(), num_cycles=20)
seed_test(aec, num_cycles=20)
parallel_seed_test(par, num_cycles=20)
max_cycles_test(SimpleNamespace(parallel_env=par, env=aec))
state_test(aec(), par(), num_cycles=20)
