# Sourced by tools/demo.sh and tools/test.sh: make .venv (once) and install the project into
# it with the extras named in $MULTICRANE_EXTRAS. Reinstalls only when pyproject.toml changes.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
py="${PYTHON:-python3}"
if [ ! -x .venv/bin/python ]; then
  "$py" -m venv .venv
fi
stamp=".venv/.installed-$(sha256sum pyproject.toml | cut -c1-16)-${MULTICRANE_EXTRAS}"
if [ ! -f "$stamp" ]; then
  # torch first, pinned, so that nothing pulls a CUDA build (see pyproject.toml).
  case "$MULTICRANE_EXTRAS" in *train*) .venv/bin/python -m pip install -q "torch==2.13.0" ;; esac
  .venv/bin/python -m pip install -q -e ".[${MULTICRANE_EXTRAS}]"
  rm -f .venv/.installed-*
  touch "$stamp"
fi
export OMP_NUM_THREADS="${OMP_NUM_THREADS:-1}"
PY="$root/.venv/bin/python"
