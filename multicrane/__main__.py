"""``python -m multicrane``: the ``multicrane`` command (see ``multicrane.cli``)."""

import sys

from multicrane.cli import main

sys.exit(main())
