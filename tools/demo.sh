#!/usr/bin/env bash
# The main job: sets up .venv, then runs policies on a scenario and prints the results.
# Arguments go to tools/run_policy.py (default: prioritized, greedy and random cranes on frame2-3c).
MULTICRANE_EXTRAS="test"
source "$(dirname "$0")/_venv.sh"
if [ "$#" -eq 0 ]; then
  set -- --scenario frame2-3c --cranes 3 --policy prioritized greedy random --episodes 5
fi
"$PY" tools/run_policy.py "$@"
