"""How the IFC import's time grows with the model: frames of about 250 to 2,000 elements.

    python tools/ifc_costs.py                 (needs the ifc extra: pip install 'multicrane[ifc]')
    python tools/ifc_costs.py 250 1000 4000   (the element counts to aim at)

For each count, builds a four-storey square steel frame of about that many elements with
``multicrane.ifc.build`` (4.5 m bays, 3 m storeys; columns, beams and one secondary beam per
bay; IFC4, millimetres, nested placements, mapped geometry: a model as authoring tools write
it), then times, best of three, ``read_ifc`` (opening the file and triangulating
every element) and the whole ``import_ifc`` at 1.5 m cells with the yard all around (read,
snap, lay out, write, and load with the strict loader, solvability included), and prints one
markdown table row per model (the table of docs/ifc.md). Building the model with
``ifcopenshell.api`` is not timed. A model whose site would exceed the scenario format's
limits (262,144 cells: about 2,000 lying components fill that with their yard) gets the
import's one-line refusal instead.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

from multicrane.ifc.build import frame
from multicrane.ifc.importer import import_ifc
from multicrane.ifc.read import IfcImportError, read_ifc

STOREYS, SPAN, HEIGHT, CELL = 4, 4.5, 3.0, 1.5


def elements(bays: int) -> int:
    """Elements of the frame of ``bays`` x ``bays`` bays: columns, beams, secondary beams."""
    per_storey = (bays + 1) ** 2 + 2 * bays * (bays + 1) + bays * bays
    return STOREYS * per_storey


def best(run, repeats: int = 3) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return min(times)


def row(target: int, folder: Path) -> str:
    bays = min(range(1, 40), key=lambda b: abs(elements(b) - target))
    model = frame(bays, bays, STOREYS, SPAN, HEIGHT, secondary=1, units="mm",
                  nested=True, mapped=True, name=f"frame-{bays}")  # fmt: skip
    path = model.write(folder / f"frame-{bays}.ifc")
    n = len(model.model.by_type("IfcElement"))
    read = best(lambda: read_ifc(path, CELL))
    megabytes = path.stat().st_size / 1e6
    head = f"| {n} | {bays} x {bays} x {STOREYS} | {megabytes:.1f} MB | {read:.2f} s |"
    try:
        s = import_ifc(path, cell=CELL, yard="around").scenario
    except IfcImportError as exc:  # a site over the scenario format's limits
        return f"{head} refused: {str(exc).split(': ', 1)[1]} | | |"
    whole = best(lambda: import_ifc(path, cell=CELL, yard="around"))
    size = "x".join(map(str, s.size))
    return f"{head} {whole:.2f} s | {whole / n * 1e3:.2f} ms | {s.n_components} | {size} |"


def main(argv: list[str]) -> None:
    targets = [int(a) for a in argv] or [250, 500, 1000, 1500, 2000]
    print("| elements | bays x storeys | file | read | import | import per element | "
          "components | site |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as d:
        for target in targets:
            print(row(target, Path(d)), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
