"""Summary statistics over seeds or episodes: the one standard-error convention of the project.

Every mean +- s.e. in the project's programs and pages uses these: the standard error is the
sample standard deviation (n - 1 in the denominator) divided by sqrt(n); it is undefined (None)
for fewer than two values, never silently 0.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Iterable

# Two-sided 95% quantiles of Student's t for n - 1 degrees of freedom (1..30); above 30 the
# normal quantile 1.96 is within 2% of t.
_T95 = (12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228,
        2.201, 2.179, 2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086,
        2.080, 2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045, 2.042)  # fmt: skip


def sem(values: Iterable[float]) -> float | None:
    """Standard error of the mean: sample sd (n - 1) / sqrt(n); None for fewer than 2 values."""
    xs = [float(v) for v in values]
    if len(xs) < 2:
        return None
    return statistics.stdev(xs) / math.sqrt(len(xs))


def mean_sem(values: Iterable[float]) -> tuple[float | None, float | None]:
    """(mean, standard error): (None, None) for no values, (x, None) for one."""
    xs = [float(v) for v in values]
    if not xs:
        return None, None
    return statistics.fmean(xs), sem(xs)


def ci95(values: Iterable[float]) -> tuple[float, float] | None:
    """The 95% confidence interval of the mean (Student's t); None for fewer than 2 values."""
    xs = [float(v) for v in values]
    if len(xs) < 2:
        return None
    m, s = statistics.fmean(xs), sem(xs)
    t = _T95[len(xs) - 2] if len(xs) - 1 <= len(_T95) else 1.96
    return m - t * s, m + t * s
