"""Progress bars for long commands: tqdm when it is installed and stderr is a terminal, else none.

    with progress.bar(total=40, desc="evaluate") as advance:
        for ...:
            advance(1)          # one unit of work done
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager


def enabled() -> bool:
    """Whether a bar would be shown: stderr is a terminal and tqdm can be imported."""
    try:
        if not sys.stderr.isatty():
            return False
    except (AttributeError, ValueError):
        return False
    try:
        import tqdm  # noqa: F401
    except ImportError:
        return False
    return True


def _silent(n: int = 1) -> None:
    """Advance nothing: the bar when none is shown."""


@contextmanager
def bar(total: int | None = None, desc: str = "") -> Iterator[Callable[[int], None]]:
    """A context giving ``advance(n=1)``; a tqdm bar on stderr or a silent no-op."""
    if not enabled():
        yield _silent
        return
    from tqdm import tqdm

    with tqdm(total=total, desc=desc, file=sys.stderr, leave=False, dynamic_ncols=True) as t:

        def advance(n: int = 1) -> None:
            t.update(n)

        yield advance
