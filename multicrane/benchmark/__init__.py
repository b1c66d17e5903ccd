"""The benchmark harness: algorithms x configurations x seeds of the paper's single-agent
mode, run, resumed, aggregated into Table I's metric and plotted (``multicrane benchmark``).

- ``profiles``: budget profiles (smoke, quick, paper) and the runs a sweep expands to.
- ``choices``: the command line's choices of configurations and seeds, parsed; ``SweepError``.
- ``runstate``: what a run directory holds (done, partial, ...), repairs before a resume.
- ``manifest``: the sweep directory's ``sweep.json`` (sessions) and its lock.
- ``estimate``: how long runs take; longest first.
- ``sweep``: running a sweep on a backend, resuming what was started.
- ``jobs``: one run as a unit of work (``Job`` -> ``execute_run`` -> ``Outcome``).
- ``backends``: a backend by name: ``local`` (processes), ``ray`` (``ray_backend``),
  ``serial`` (this process); ``interrupts`` routes Ctrl-C to them.
- ``aggregate``: Table I's metric over the result files.
- ``page``, ``report``: the markdown report and the files it is written to.
- ``plots``: learning curves like the paper's Fig. 7 (needs matplotlib).
- ``reference``: the paper's Table I.

Nothing here imports torch until a run starts: ``status`` and ``report`` read JSON only.

May import: every room below it (``core`` to ``training``).
"""

from multicrane.benchmark.choices import SweepError
from multicrane.benchmark.profiles import (
    PROFILES,
    Profile,
    RunSpec,
    Sweep,
    make_sweep,
)

__all__ = ["PROFILES", "Profile", "RunSpec", "Sweep", "SweepError", "make_sweep"]
