"""Make the shipped IFC example: scenarios/ifc/example-frame.ifc and its imported scenario.

    python tools/make_example_ifc.py        (needs the ifc extra: pip install 'multicrane[ifc]')

The model is a two-storey steel frame, 2 x 1 bays 4 m apart, 3 m storeys, built with
``multicrane.ifc.build`` (fixed GlobalIds, so the import is the same every time), plus one
slanted brace that the import must report and leave out. The scenario is what
``multicrane import-ifc scenarios/ifc/example-frame.ifc --cranes 2`` writes.
"""

from __future__ import annotations

from pathlib import Path

from multicrane.ifc.build import frame
from multicrane.ifc.importer import import_ifc

HERE = Path(__file__).resolve().parent.parent / "scenarios" / "ifc"


def main() -> None:
    f = frame(2, 1, 2, span=4.0, height=3.0, fixed_ids=True, name="example-frame")
    level1 = f.model.by_type("IfcBuildingStorey")[0]
    f.linear(level1, (0.2, 0.0, 0.3), (3.8, 0.0, 2.6), 0.15, 0.15, name="Brace 1",
             ifc_class="IfcMember")  # fmt: skip
    HERE.mkdir(parents=True, exist_ok=True)
    model = f.write(HERE / "example-frame.ifc")
    result = import_ifc(model, cranes=2)
    (HERE / "example-frame.toml").write_text(result.text, encoding="utf-8")
    print(f"{model}: {len(result.scenario.components)} components, "
          f"{len(result.skipped)} skipped -> {HERE / 'example-frame.toml'}")  # fmt: skip


if __name__ == "__main__":
    main()
