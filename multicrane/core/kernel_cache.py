"""numba's cached machine code dropped when a kernel source of its folder changed.

numba keeps each cached function's machine code in ``__pycache__`` (``.nbi`` index, ``.nbc``
code) and checks it against that function's own source file only. A kernel that calls or
inlines a kernel of another file keeps the old code of the callee after the callee's file is
edited: in a working tree, tests and benchmarks would then run stale machine code. A folder
whose kernels call one another calls ``drop_stale_caches`` from its ``__init__``, before any
kernel is compiled or loaded: when a kernel source (a ``.py`` file of the folder that
mentions numba or the vector kernels' decorators) is newer than the oldest cache index, every
cache file of the folder goes and numba compiles afresh. An install never edits its sources,
so there this costs a few file times; a cache that cannot be removed is left to numba.
"""

from __future__ import annotations

from pathlib import Path

_KERNEL_MARKS = ("numba", "compiled import")  # ``import numba``, ``...compiled import kernel``


def drop_stale_caches(package_file: str, *callees: str) -> list[Path]:
    """Remove the numba cache files of ``package_file``'s folder when a kernel source there,
    or in the folders of ``callees`` (files of packages whose kernels this folder's call), is
    newer than the oldest cache index; returns the files removed (none when fresh)."""
    folder = Path(package_file).parent
    cache = folder / "__pycache__"
    sources = [folder, *(Path(c).parent for c in callees)]
    try:
        indexes = list(cache.glob("*.nbi"))
        if not indexes:
            return []
        oldest = min(p.stat().st_mtime for p in indexes)
        newer = [p for f in sources for p in f.glob("*.py") if p.stat().st_mtime > oldest]
        if not any(_is_kernel_source(p) for p in newer):
            return []
        stale = indexes + list(cache.glob("*.nbc"))
    except OSError:
        return []
    removed = []
    for path in stale:
        try:
            path.unlink()
            removed.append(path)
        except OSError:
            pass  # another process removed it, or a read-only install: numba decides
    return removed


def _is_kernel_source(path: Path) -> bool:
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return False
    return any(mark in text for mark in _KERNEL_MARKS)
