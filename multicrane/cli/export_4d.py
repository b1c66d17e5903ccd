"""``multicrane export-4d``: an episode record's plan into its IFC model as a 4D schedule."""

from __future__ import annotations

import argparse
import sys
from datetime import datetime
from pathlib import Path

from multicrane.cli.common import formatter

DESCRIPTION = """Write the plan of an episode record into the IFC model its scenario was
imported from, as a 4D work schedule (needs the ifc extra: pip install 'multicrane[ifc]').

    multicrane import-ifc frame.ifc -o frame.toml --cranes 2
    multicrane plan frame.toml --policy prioritized --record frame.json.gz
    multicrane export-4d frame.json.gz --ifc frame.ifc -o frame-4d.ifc \\
        --step-seconds 30 --start 2027-03-01T07:00

The copy of the model gets an IfcWorkSchedule with one IfcTask per assembled component, in
the order the record assembles them, each with a lift and an assembly task and their
schedule start and finish (step t is --start + t x --step-seconds), its element as the
task's output, the crane that lifts it as an IfcConstructionEquipmentResource, and a
FINISH_START sequence from each support's assembly. Open it in Bonsai (Blender), Navisworks
or Synchro to play the 4D model. The record may come from any policy; its scenario must be
an import of this model (the GlobalIds in the scenario file's comments).
"""


def register(sub) -> None:
    p = sub.add_parser("export-4d", help="write a record's plan into its IFC model (4D schedule)",
                       description=DESCRIPTION, **formatter())  # fmt: skip
    p.add_argument("record", type=Path, help="the episode record (.json or .json.gz)")
    p.add_argument("--ifc", type=Path, required=True, metavar="MODEL",
                   help="the IFC model the record's scenario was imported from")
    p.add_argument("-o", "--output", type=Path, required=True, help="the IFC file to write")
    p.add_argument("--step-seconds", type=float, default=60.0,
                   help="seconds one step takes on site (default 60)")
    p.add_argument("--start", type=_moment, default=None, metavar="YYYY-MM-DDTHH:MM",
                   help="when step 0 begins (default: today at 07:00)")
    p.set_defaults(func=run)


def _moment(text: str) -> datetime:
    try:
        return datetime.fromisoformat(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a date and time like "
                                         "2027-03-01T07:00") from None  # fmt: skip


def run(args: argparse.Namespace) -> int:
    from multicrane.ifc.schedule_4d import ScheduleExportError, export_4d
    from multicrane.replay.record import EpisodeRecord, RecordError

    try:
        record = EpisodeRecord.load(args.record)
        done = export_4d(record, args.ifc, args.output, args.step_seconds, args.start)
    except (ScheduleExportError, RecordError) as exc:
        print(f"multicrane export-4d: error: {exc}", file=sys.stderr)
        return 2
    first, last = done.clock.at(0), done.clock.at(done.steps)
    print(f"{done.path}: work schedule of {len(done.tasks)} tasks ({len(done.tasks)} of "
          f"{done.n_components} components assembled), {done.n_cranes} crane resource(s), "
          f"{done.sequences} sequence relations; {first:%Y-%m-%d %H:%M} to {last:%Y-%m-%d %H:%M} "
          f"({done.steps} steps of {done.clock.step_seconds:g} s)")  # fmt: skip
    return 0
