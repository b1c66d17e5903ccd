#!/usr/bin/env bash
# The main job: sets up .venv (with the training and replay stacks), then trains parameter-
# sharing PPO for the cranes of a scenario, evaluates it against the prioritized planner,
# greedy and random cranes, and saves a replay. Arguments go to `multicrane demo`.
MULTICRANE_EXTRAS="train,replay"
source "$(dirname "$0")/_venv.sh"
"$PY" -m multicrane demo "$@"
