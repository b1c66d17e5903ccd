"""The benchmark harness: algorithms x configurations x seeds of the paper's single-agent
mode, run, resumed, aggregated into Table I's metric and plotted (``tools/benchmark.py``).

- ``sweep``: budget profiles (smoke, quick, paper), the runs they expand to, their
  directories, what is done on disk, resume.
- ``backends``: where runs execute (local processes, Ray, this process).
- ``aggregate``: Table I's metric over the result files, and the markdown report.
- ``plots``: learning curves like the paper's Fig. 7 (needs matplotlib).
- ``reference``: the paper's Table I.

Nothing here imports torch until a run starts: ``status`` and ``report`` read JSON only.
"""

from multicrane.benchmark.sweep import PROFILES, Profile, RunSpec, Sweep, SweepError, make_sweep

__all__ = ["PROFILES", "Profile", "RunSpec", "Sweep", "SweepError", "make_sweep"]
