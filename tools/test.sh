#!/usr/bin/env bash
# The test suite: sets up .venv with the test dependencies, then runs ruff and pytest, the test
# files spread over the cores (pytest-xdist; MULTICRANE_TEST_WORKERS=0 runs them in one process).
# Extra arguments go to pytest (e.g. tools/test.sh -k loader).
MULTICRANE_EXTRAS="train,test,replay,video,bench,ray,tianshou,torchrl,rllib,ifc"
source "$(dirname "$0")/_venv.sh"
"$PY" -m ruff check multicrane policies tools tests
"$PY" -m pytest -q --durations=15 -n "${MULTICRANE_TEST_WORKERS:-auto}" --dist loadfile "$@"
