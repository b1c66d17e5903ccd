#!/usr/bin/env bash
# The PufferLib tests: sets up .venv-pufferlib (its own venv: PufferLib 3.0.0 declares numpy<2,
# gymnasium<=0.29.1 and pettingzoo<=1.24.1, which the main .venv's ranges exclude), installs
# PufferLib 3.0.0 from PyPI alone, then runs tests/integrations/test_pufferlib.py.
# Extra arguments go to pytest.
#
# PyPI has no 3.x wheel; its sdist's setup.py downloads raylib and box2d from GitHub unless
# NO_OCEAN=1 (no C environments), and with NO_OCEAN=1 it fails on an undefined name
# (`c_extension_paths`); `pip download` cannot fetch it (it builds metadata first). So: the
# sdist from PyPI's simple index, JSON form (sha256 checked), the one-line fix, NO_OCEAN=1, and
# `pip install --no-deps --no-build-isolation` (its torch extension, the advantage kernel
# PufferLib's trainer needs, is compiled against the venv's torch; about 1-2 minutes on 2
# cores, 3.5 under load). nvcc is hidden from the build when torch has no CUDA.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
py="${PYTHON:-python3}"
venv=.venv-pufferlib
if [ ! -x "$venv/bin/python" ]; then
  "$py" -m venv "$venv"
fi
stamp="$venv/.installed-$(sha256sum pyproject.toml | cut -c1-16)"
if [ ! -f "$stamp" ]; then
  # torch first, pinned, so that nothing pulls a CUDA build (see pyproject.toml).
  "$venv/bin/python" -m pip install -q "torch==2.13.0" setuptools wheel cython
  "$venv/bin/python" -m pip install -q -e ".[pufferlib,test]"
  work="$(mktemp -d)"
  trap 'rm -rf "$work"' EXIT
  "$venv/bin/python" - "$work" <<'PY'
import hashlib, json, sys, tarfile, urllib.request
work = sys.argv[1]
index = urllib.request.Request(  # PyPI's simple index, JSON form (PEP 691)
    "https://pypi.org/simple/pufferlib/",
    headers={"Accept": "application/vnd.pypi.simple.v1+json"},
)
with urllib.request.urlopen(index) as answer:
    (sdist,) = [f for f in json.load(answer)["files"] if f["filename"] == "pufferlib-3.0.0.tar.gz"]
data = urllib.request.urlopen(sdist["url"]).read()
assert hashlib.sha256(data).hexdigest() == sdist["hashes"]["sha256"], "sha256 mismatch"
path = f"{work}/{sdist['filename']}"
open(path, "wb").write(data)
tarfile.open(path).extractall(work, filter="data")
PY
  src="$work/pufferlib-3.0.0"
  sed -i 's/^c_extensions = \[\]$/c_extensions = []\nc_extension_paths = []/' "$src/setup.py"
  grep -q '^c_extension_paths = \[\]$' "$src/setup.py"
  build_path="$PATH"
  if ! "$venv/bin/python" -c "import sys, torch; sys.exit(torch.version.cuda is None)"; then
    build_path="$(tr ':' '\n' <<<"$PATH" | while read -r d; do
      [ -x "$d/nvcc" ] || printf '%s:' "$d"; done)"
    build_path="${build_path%:}"
  fi
  (cd "$src" && PATH="$build_path" NO_OCEAN=1 "$root/$venv/bin/python" -m pip install -q \
    --no-deps --no-build-isolation .)
  rm -f "$venv"/.installed-*
  touch "$stamp"
fi
export OMP_NUM_THREADS="${OMP_NUM_THREADS:-1}"
"$venv/bin/python" -m pytest -q -p no:cacheprovider tests/integrations/test_pufferlib.py "$@"
