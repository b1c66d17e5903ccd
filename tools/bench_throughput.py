"""Developer front end of ``multicrane bench``: environment steps per second.

Kept so that ``python tools/bench_throughput.py --scenario hall-4c --cranes 4`` still measures
the hot path as before.
"""

import sys

from multicrane.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", *sys.argv[1:]]))
