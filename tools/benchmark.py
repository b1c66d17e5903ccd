"""Developer front end of ``multicrane benchmark`` (the same command, without the installed
script): ``python tools/benchmark.py run --profile smoke``."""

import sys

from multicrane.cli.benchmark import main

if __name__ == "__main__":
    sys.exit(main())
