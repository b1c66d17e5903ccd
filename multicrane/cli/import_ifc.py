"""``multicrane import-ifc``: IFC building model to scenario file (``multicrane.ifc.importer``)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from multicrane.cli.common import formatter

DESCRIPTION = """Import an IFC building model as a scenario (needs the ifc extra:
pip install 'multicrane[ifc]'). IFC2X3, IFC4 and IFC4X3 files are read, in any length
unit.

    multicrane import-ifc frame.ifc -o site.toml
    multicrane import-ifc frame.ifc -o site.toml --cell 0.5 --yard two --cranes 3
    multicrane plan site.toml --policy prioritized --rrd site.rrd

Columns (IfcColumn) and beams (IfcBeam, and straight IfcMember) become components, snapped
to cells of --cell metres: columns stand on foundations at their bases (or on the column
below), beams rest on the columns they touch, and secondary beams on the beams they frame
into. By default (--panels components) slabs, walls and plates (IfcSlab, IfcWall, IfcPlate)
become panel components resting on exactly the beams and walls (a slab) or the slabs and
beams (a wall) directly under them; a wall on the ground gets a foundation strip. With
--panels obstacles their cells become obstacles instead, with --panels skip they are left
out. Every element left out (a slanted brace, a panel with nothing under it, ...) is
reported with its type, GlobalId, name and reason, on the terminal and as comments in the
file. The file is loaded with the strict loader (solvability included) before it is
written. Without -o the file goes to standard output. A model that cannot be imported gets
one line on standard error and exit status 2.
"""


def register(sub) -> None:
    p = sub.add_parser("import-ifc", help="import an IFC building model as a scenario",
                       description=DESCRIPTION, **formatter())  # fmt: skip
    p.add_argument("model", type=Path, help="the IFC file (IFC2X3, IFC4, IFC4X3)")
    p.add_argument("-o", "--output", type=Path, default=None, help="the scenario file to write")
    p.add_argument("--cell", type=float, default=1.0, help="cell size in metres (default 1.0)")
    p.add_argument("--yard", choices=("one", "two", "around"), default="one",
                   help="yard strips on the low-y side, both y sides, or all around")
    p.add_argument("--cranes", type=int, default=1, help="cranes (default 1)")
    p.add_argument("--panels", choices=("components", "obstacles", "skip"), default="components",
                   help="what slabs, walls and plates become: panel components (the default), "
                   "obstacles, or nothing")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from multicrane.ifc.importer import IfcImportError, import_ifc

    try:
        result = import_ifc(args.model, cell=args.cell, yard=args.yard, cranes=args.cranes,
                            panels=args.panels)  # fmt: skip
    except IfcImportError as exc:
        print(f"multicrane import-ifc: error: {exc}", file=sys.stderr)
        return 2
    s = result.scenario
    assert s is not None
    report = sys.stderr if args.output is None else sys.stdout
    if args.output is None:
        sys.stdout.write(result.text)
    else:
        args.output.write_text(result.text, encoding="utf-8")
    kinds = [c.kind.name.lower() for c in s.components]
    counts = ", ".join(f"{kinds.count(k)} {k}s" for k in dict.fromkeys(kinds))
    print(f"{args.output or '<stdout>'}: {s.n_components} components ({counts}), "
          f"{len(s.obstacles)} obstacle boxes, site {s.size[0]}x{s.size[1]}x{s.size[2]}, "
          f"{s.cranes} crane(s); {len(result.skipped)} element(s) skipped",
          file=report)  # fmt: skip
    for k in result.skipped:
        print(f"  skipped {k.line()}", file=report)
    return 0
