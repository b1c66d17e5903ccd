"""``multicrane.core.kernel_cache``: numba's caches of a folder go when a kernel source there
is newer than the oldest cache index, and stay otherwise; and a real kernel that inlines one
from another file runs the edited callee after the folder's guard has run."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest

from multicrane.core.kernel_cache import drop_stale_caches


def _folder(tmp_path, kernel_age: float, other_age: float):
    """A package folder: a kernel source, a plain module and two cache files, with the sources'
    times ``kernel_age`` / ``other_age`` seconds after the caches'."""
    (tmp_path / "__init__.py").write_text("")
    kernel = tmp_path / "kernels.py"
    kernel.write_text("import numba\n")
    other = tmp_path / "plain.py"
    other.write_text("X = 1\n")
    cache = tmp_path / "__pycache__"
    cache.mkdir()
    files = [cache / "kernels.f-3.py311.nbi", cache / "kernels.f-3.py311.0.nbc"]
    for f in files:
        f.write_bytes(b"x")
        os.utime(f, (1_000_000, 1_000_000))
    os.utime(kernel, (1_000_000 + kernel_age,) * 2)
    os.utime(other, (1_000_000 + other_age,) * 2)
    os.utime(tmp_path / "__init__.py", (1_000_000 - 5,) * 2)
    return tmp_path / "__init__.py", files


@pytest.mark.parametrize(
    ("kernel_age", "other_age", "dropped"),
    [(-5, -5, False), (0, 0, False), (+5, -5, True), (-5, +5, False)],
    ids=["sources-older", "same-time", "kernel-edited", "plain-module-edited"],
)
def test_caches_go_only_when_a_kernel_source_is_newer(tmp_path, kernel_age, other_age, dropped):
    init, files = _folder(tmp_path, kernel_age, other_age)
    removed = drop_stale_caches(str(init))
    assert sorted(removed) == (sorted(files) if dropped else [])
    assert all(f.exists() != dropped for f in files)
    assert drop_stale_caches(str(init)) == []  # nothing left, or nothing stale: no change


@pytest.mark.parametrize("callee_age", [-5, +5], ids=["callee-older", "callee-edited"])
def test_caches_go_when_a_kernel_source_of_a_callee_folder_is_newer(tmp_path, callee_age):
    """A folder whose kernels call another folder's (the task vector kernels call the
    searches of ``multicrane.tasks``) names it: an edit there drops this folder's caches."""
    (tmp_path / "caller").mkdir()
    init, files = _folder(tmp_path / "caller", -5, -5)
    callee = tmp_path / "callee"
    callee.mkdir()
    (callee / "__init__.py").write_text("")
    (callee / "search.py").write_text("import numba\n")
    os.utime(callee / "search.py", (1_000_000 + callee_age,) * 2)
    os.utime(callee / "__init__.py", (1_000_000 - 5,) * 2)
    assert drop_stale_caches(str(init)) == []  # its own sources are older
    removed = drop_stale_caches(str(init), str(callee / "__init__.py"))
    assert sorted(removed) == (sorted(files) if callee_age > 0 else [])


def test_a_folder_without_caches_is_left_alone(tmp_path):
    (tmp_path / "k.py").write_text("import numba\n")
    assert drop_stale_caches(str(tmp_path / "__init__.py")) == []


_CALLEE = "import numba\n\n@numba.njit(cache=True, inline='always')\ndef value():\n    return {}\n"
_CALLER = textwrap.dedent("""\
    import numba
    from pkg.callee import value

    @numba.njit(cache=True)
    def read():
        return value()
""")
_INIT = textwrap.dedent("""\
    from multicrane.core.kernel_cache import drop_stale_caches

    drop_stale_caches(__file__)
""")


def test_an_edited_callee_is_not_run_from_its_caller_cache(tmp_path):
    """Two files, the caller inlining the callee, both cached; the callee's file is edited:
    without the guard numba would run the caller's cached machine code (the old value)."""
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text(_INIT)
    (pkg / "caller.py").write_text(_CALLER)
    run = [sys.executable, "-c", "from pkg.caller import read; print(read())"]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), *sys.path])}

    def value_after(source: str, when: int) -> str:
        (pkg / "callee.py").write_text(source)
        os.utime(pkg / "callee.py", (when, when))
        return subprocess.run(run, env=env, capture_output=True, text=True, check=True).stdout
    assert value_after(_CALLEE.format(1), 1_000_000_000).strip() == "1"  # compiled, cached
    assert list((pkg / "__pycache__").glob("caller.*.nbi"))
    assert value_after(_CALLEE.format(2), 2_000_000_000).strip() == "2"
