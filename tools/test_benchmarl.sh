#!/usr/bin/env bash
# The BenchMARL tests: sets up .venv-benchmarl (its own venv: BenchMARL 1.5 needs TorchRL 0.11,
# the main .venv has TorchRL 0.14), then runs the tests marked `benchmarl` and the recipe.
# Extra arguments go to pytest.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
py="${PYTHON:-python3}"
if [ ! -x .venv-benchmarl/bin/python ]; then
  "$py" -m venv .venv-benchmarl
fi
stamp=".venv-benchmarl/.installed-$(sha256sum pyproject.toml | cut -c1-16)"
if [ ! -f "$stamp" ]; then
  # torch first, pinned, so that BenchMARL's unpinned torchvision resolves to the release
  # built for it instead of pulling a newer torch with CUDA packages.
  .venv-benchmarl/bin/python -m pip install -q "torch==2.13.0"
  .venv-benchmarl/bin/python -m pip install -q -e ".[benchmarl,test]"
  rm -f .venv-benchmarl/.installed-*
  touch "$stamp"
fi
export OMP_NUM_THREADS="${OMP_NUM_THREADS:-1}"
.venv-benchmarl/bin/python -m pytest -q -p no:cacheprovider -m benchmarl \
  tests/integrations/test_benchmarl.py "$@"
