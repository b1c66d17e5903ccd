"""``multicrane generate``: write a generated scenario file (``multicrane.scenario.generator``)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from multicrane.cli.common import formatter

DESCRIPTION = """Generate a buildable, solvable scenario and write it as a scenario file.

    multicrane generate frame --seed 3 -o site.toml
    multicrane generate hall --seed 7 --bays-x 4 --storeys 1 --cranes 4 --yard two
    multicrane generate tower --seed 1 --storeys 6 --cranes 3 --reach --fixed-start
    multicrane generate --set test-small -o out/        # every site of a held-out set

FAMILY is frame (n x m bays, a few storeys), hall (long spans, one or two storeys), tower
(small footprint, many storeys) or precast (a frame one bay deep with floor slabs). Every
parameter left out is drawn from the family's range with the seed; the same arguments always
give the same bytes. The file loads with the strict loader (multicrane check FILE). Without -o
the file goes to standard output.
"""

_SHAPE = ("bays_x", "bays_y", "storeys", "column_height", "span", "cranes", "obstacles")


def register(sub) -> None:
    p = sub.add_parser("generate", help="generate a scenario file", description=DESCRIPTION,
                       **formatter())  # fmt: skip
    p.add_argument("family", nargs="?", help="frame, hall, tower or precast")
    p.add_argument("--seed", type=int, default=0)
    for key in _SHAPE:
        p.add_argument(f"--{key.replace('_', '-')}", type=int, default=None, dest=key)
    p.add_argument("--yard", choices=("one", "two", "around"), default=None)
    p.add_argument(
        "--reach",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="tower cranes of limited reach (needs --no-interchangeable)",
    )
    p.add_argument("--interchangeable", action=argparse.BooleanOptionalAction, default=None)
    p.add_argument(
        "--random-start", action=argparse.BooleanOptionalAction, default=None, dest="random_start"
    )
    p.add_argument(
        "--fixed-start", action="store_false", dest="random_start", help="same as --no-random-start"
    )
    p.add_argument("--set", default=None, help="write every site of a held-out set instead")
    p.add_argument("-o", "--output", type=Path, default=None, help="file (folder with --set)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from multicrane.core.schema import ScenarioError
    from multicrane.scenario.generator import generate
    from multicrane.scenario.named_sets import members
    from multicrane.scenario.writer import to_toml

    try:
        if args.set is not None:
            if args.output is None:
                print("multicrane generate: --set needs -o FOLDER", file=sys.stderr)
                return 2
            args.output.mkdir(parents=True, exist_ok=True)
            for m in members(args.set):
                path = args.output / f"{m.name.split('/')[-1]}.toml"
                path.write_text(to_toml(m.scenario()), encoding="utf-8")
                print(path)
            return 0
        if args.family is None:
            print("multicrane generate: give a FAMILY (frame, hall, tower) or --set",
                  file=sys.stderr)  # fmt: skip
            return 2
        keys = (*_SHAPE, "yard", "reach", "interchangeable", "random_start")
        params = {k: getattr(args, k) for k in keys if getattr(args, k) is not None}
        scenario = generate(args.family, args.seed, **params)
    except (ValueError, ScenarioError) as exc:
        print(f"multicrane generate: {exc}", file=sys.stderr)
        return 2
    text = to_toml(scenario)
    if args.output is None:
        sys.stdout.write(text)
    else:
        args.output.write_text(text, encoding="utf-8")
        print(f"{args.output}: {scenario.name}, {scenario.n_components} components, "
              f"{scenario.cranes} crane(s)")  # fmt: skip
    return 0
