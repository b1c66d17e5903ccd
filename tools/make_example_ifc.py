"""Make the shipped IFC examples: the models in scenarios/ifc/ and their imported scenarios.

    python tools/make_example_ifc.py        (needs the ifc extra: pip install 'multicrane[ifc]')

Both models are built with ``multicrane.ifc.build`` (fixed GlobalIds, so the import is the
same every time) and imported with two cranes:

- ``example-frame``: a two-storey steel frame, 2 x 1 bays 4 m apart, 3 m storeys, plus one
  slanted brace that the import must report and leave out;
- ``example-roof``: a two-storey 3 x 2-bay steel frame with a secondary beam across each bay
  and a roof slab on the top beams, written as authoring tools write it (millimetres, nested
  placements, mapped geometry); it imports with the default options into columns, beams
  (the secondary ones resting on the primary ones) and a slab resting on the beams under it.

Each scenario is what ``multicrane import-ifc scenarios/ifc/NAME.ifc --cranes 2`` writes.
"""

from __future__ import annotations

from pathlib import Path

from multicrane.ifc.build import FrameModel, frame
from multicrane.ifc.importer import import_ifc

HERE = Path(__file__).resolve().parent.parent / "scenarios" / "ifc"


def example_frame() -> FrameModel:
    f = frame(2, 1, 2, span=4.0, height=3.0, fixed_ids=True, name="example-frame")
    level1 = f.model.by_type("IfcBuildingStorey")[0]
    f.linear(level1, (0.2, 0.0, 0.3), (3.8, 0.0, 2.6), 0.15, 0.15, name="Brace 1",
             ifc_class="IfcMember")  # fmt: skip
    return f


def example_roof() -> FrameModel:
    return frame(3, 2, 2, span=4.0, height=3.0, secondary=1, roof=True, fixed_ids=True,
                 name="example-roof", units="mm", nested=True, mapped=True)  # fmt: skip


def main() -> None:
    HERE.mkdir(parents=True, exist_ok=True)
    for name, make in (("example-frame", example_frame), ("example-roof", example_roof)):
        model = make().write(HERE / f"{name}.ifc")
        result = import_ifc(model, cranes=2)
        (HERE / f"{name}.toml").write_text(result.text, encoding="utf-8")
        print(f"{model}: {len(result.scenario.components)} components, "
              f"{len(result.skipped)} skipped -> {HERE / f'{name}.toml'}")  # fmt: skip


if __name__ == "__main__":
    main()
