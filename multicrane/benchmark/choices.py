"""The command line's choices of a sweep's runs, parsed (configurations, seeds), and the error
a sweep that cannot be set up or run raises.
"""

from __future__ import annotations

from collections.abc import Iterable

from multicrane.envs.paper_env import PAPER_CONFIGS


class SweepError(ValueError):
    """A sweep that cannot be set up or run; the message names the option, value or file."""


def parse_configs(items: Iterable[str]) -> tuple[str, ...]:
    """``E1S1`` .. ``E4S4``, ``E2`` (its four scenarios) or ``all``, in paper order."""
    chosen: set[str] = set()
    for item in items:
        token = item.strip().upper()
        if token == "ALL":
            chosen.update(PAPER_CONFIGS)
        elif token in PAPER_CONFIGS:
            chosen.add(token)
        elif token in ("E1", "E2", "E3", "E4"):
            chosen.update(c for c in PAPER_CONFIGS if c.startswith(token))
        else:
            raise SweepError(
                f"unknown configuration {item!r}: E1S1 .. E4S4, E1 .. E4 (an environment's "
                "four scenarios) or all"
            )
    return tuple(c for c in PAPER_CONFIGS if c in chosen)


def parse_seeds(items: Iterable[str]) -> tuple[int, ...]:
    """``0 1 2``, ``0-14`` or ``0,3,5``."""
    seeds: list[int] = []
    for item in items:
        for part in str(item).split(","):
            part = part.strip()
            if not part:
                continue
            first, dash, last = part.partition("-")
            try:
                if dash:
                    lo, hi = int(first), int(last)
                    if hi < lo:
                        raise ValueError
                    seeds.extend(range(lo, hi + 1))
                else:
                    seeds.append(int(part))
            except ValueError:
                raise SweepError(f"seeds {item!r}: expected integers or ranges like 0-14") from None
    return tuple(seeds)
