"""``multicrane gantt``: the Gantt chart of a recorded episode (PNG or self-contained HTML)."""

from __future__ import annotations

import argparse
from pathlib import Path

from multicrane.cli.common import error, formatter, needs_extra

DESCRIPTION = """Draw the Gantt chart of an episode record: cranes as lanes, each lift,
hold, assembly, wait and breakdown a bar (steps on the x axis).

    multicrane plan hall-4c --cranes 4 --record hall.json.gz
    multicrane gantt hall.json.gz -o hall.html        # a self-contained page (inline SVG)
    multicrane gantt hall.json.gz -o hall.png         # a picture (the 'bench' extra)
    multicrane plan hall-4c --cranes 4 --gantt hall.png   # straight from a run

The record is re-simulated (and checked) to read each crane's timeline
(multicrane.replay.timeline). .html writes one page with no script and nothing to
download; any other suffix (.png, .svg, .pdf) a matplotlib picture.
"""


def register(sub) -> None:
    p = sub.add_parser("gantt", help="draw the Gantt chart of an episode record",
                       description=DESCRIPTION, **formatter())  # fmt: skip
    p.add_argument("record", type=Path, help="the episode record (.json or .json.gz)")
    p.add_argument("-o", "--output", type=Path, required=True,
                   help="the chart: .html, or a picture (.png, .svg, .pdf)")
    p.add_argument("--title", default=None, help="default: scenario, policy, seed, cranes, steps")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from multicrane.replay.record import EpisodeRecord, RecordError
    from multicrane.replay.timeline import timeline_of
    from multicrane.reports.gantt import record_title, write_gantt

    if lacks_matplotlib(args.output):
        return needs_extra("gantt", "bench")
    try:
        record = EpisodeRecord.load(args.record)
        intervals = timeline_of(record)
        ids = record.load_scenario().ids
    except RecordError as exc:
        return error(exc)
    title = record_title(record) if args.title is None else args.title
    try:
        write_gantt(intervals, args.output, ids, title)
    except OSError as exc:
        return error(f"{args.output}: cannot write the chart ({exc.strerror or exc})")
    print(f"gantt chart: {args.output} ({len(intervals)} bars)")
    return 0


def lacks_matplotlib(path: Path) -> bool:
    """Whether the chart ``path`` is a picture (not ``.html``) and matplotlib is missing."""
    from multicrane.reports.gantt import HTML_SUFFIXES

    if path.suffix.lower() in HTML_SUFFIXES:
        return False
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return True
    return False
