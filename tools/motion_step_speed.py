"""Joint steps per second of the one-site motion step, hall-4c with 4 cranes, public API only.

    PYTHONPATH=. python tools/motion_step_speed.py 20000
    git worktree add /tmp/wt9b 9b1d279                      # the code of issue 31's baseline
    PYTHONPATH=/tmp/wt9b python tools/motion_step_speed.py 20000

``multicrane.parallel_env("hall-4c", n_cranes=4, obs_format="flat")`` (older trees have no
``obs_format``: their default dict observations) stepped ``steps`` times from
``reset(seed=0)`` with uniformly random legal joint actions drawn from ``action_masks()``
(resets when episodes end included). Prints the steps per wall second and per CPU second
(``time.process_time``, less sensitive to other jobs). It imports nothing but ``multicrane``
and numpy, so it runs on any tree since the multi-agent environment (docs/performance.md).
"""

from __future__ import annotations

import sys
import time

import numpy as np

import multicrane


def main(steps: int) -> None:
    try:
        env = multicrane.parallel_env("hall-4c", n_cranes=4, obs_format="flat")
    except TypeError:  # a tree before obs_format
        env = multicrane.parallel_env("hall-4c", n_cranes=4)
    rng = np.random.default_rng(0)
    agents = env.possible_agents
    seed = 0
    env.reset(seed=seed)
    wall, cpu = time.perf_counter(), time.process_time()
    for _ in range(steps):
        masks = env.action_masks()
        rows = np.stack([masks[a] for a in agents])
        joint = (rng.random(rows.shape) * rows).argmax(axis=1).tolist()
        _, _, terminated, truncated, _ = env.step(dict(zip(agents, joint, strict=True)))
        if terminated[agents[0]] or truncated[agents[0]]:
            seed += 1
            env.reset(seed=seed)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    print(f"{steps / wall:.0f} joint steps/s (wall), {steps / cpu:.0f} per CPU second")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 20000)
