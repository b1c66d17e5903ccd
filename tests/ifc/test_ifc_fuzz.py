"""Property-based fuzzing of the IFC import: models as people make them, and broken ones.

Hypothesis draws a model and builds it with ``ifcopenshell.api`` (``multicrane.ifc.build``):
a frame of random bays, storeys, spans and heights, in a random schema (IFC2X3, IFC4, IFC4X3)
and unit (m, mm), with nested placements or not, mapped geometry or not, beams in assemblies
or not, with secondary beams, infill walls and a roof slab or not, plus a few extras: a
slanted brace, an element with no geometry, a duplicate GlobalId, a zero-length member,
elements in no storey, a floor slab through the columns above it, a slab in the air, a random
plate, a random member and a tower column of 30 to 100 m (mostly too high for the scenario
format). It is imported at a random cell size, crane count and panels mode.
Every model must either import into a scenario that loads and that the prioritized planner
finishes, or be refused with an ``IfcImportError`` of one line; anything else (a traceback, a
site that does not load, an episode that does not finish) fails.

The default run draws 30 models; ``-m fuzz`` plays 150 fixed ones
(``MULTICRANE_IFC_FUZZ_EXAMPLES`` sets the number):

    python -m pytest -m fuzz tests/ifc/test_ifc_fuzz.py

and ``python tests/ifc/test_ifc_fuzz.py N`` draws N models and prints the outcome counts and
the time (the figures of docs/ifc.md).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest.importorskip("ifcopenshell")

import multicrane  # noqa: E402
from multicrane.episodes.rollout import run_episode  # noqa: E402
from multicrane.ifc.build import frame  # noqa: E402
from multicrane.ifc.importer import import_ifc  # noqa: E402
from multicrane.ifc.read import IfcImportError  # noqa: E402
from multicrane.scenario.loader import parse_scenario  # noqa: E402
from policies.prioritized import PrioritizedPlanner  # noqa: E402

# CI's fuzz step plays 150 derandomised models (about 2 minutes); the 1,000-model run:
# MULTICRANE_IFC_FUZZ_EXAMPLES=1000 python -m pytest -m fuzz tests/ifc/test_ifc_fuzz.py
LARGE = int(os.environ.get("MULTICRANE_IFC_FUZZ_EXAMPLES", "150"))
EXTRAS = ("brace", "bare", "duplicate", "zero", "loose", "floor", "floating", "plate", "member",
          "tower")
COMMON = dict(deadline=None, database=None, suppress_health_check=list(HealthCheck))


@st.composite
def models(draw) -> tuple[dict, list, dict]:
    """A model (``frame``'s arguments and extras with their numbers) and the import options."""
    shape = dict(
        bays_x=draw(st.integers(1, 3)), bays_y=draw(st.integers(0, 2)),
        storeys=draw(st.integers(1, 3)), span=draw(st.sampled_from([2.0, 3.0, 4.0, 5.5])),
        height=draw(st.sampled_from([2.5, 3.0, 4.0])),
        secondary=draw(st.integers(0, 2)), walls=draw(st.booleans()), roof=draw(st.booleans()),
        assemblies=draw(st.booleans()),
        schema=draw(st.sampled_from(["IFC2X3", "IFC4", "IFC4X3"])),
        units=draw(st.sampled_from(["m", "mm"])), nested=draw(st.booleans()),
        mapped=draw(st.booleans()),
        building_at=draw(st.sampled_from([(0.0, 0.0, 0.0), (120.0, -35.5, 2.0)])),
    )  # fmt: skip
    unit = st.floats(0, 1, allow_nan=False)
    extras = draw(st.lists(st.tuples(st.sampled_from(EXTRAS), st.tuples(unit, unit, unit, unit)),
                           max_size=4))  # fmt: skip
    options = dict(cell=draw(st.sampled_from([0.5, 1.0, 1.5])), cranes=draw(st.integers(1, 3)),
                   panels=draw(st.sampled_from(["components", "components", "obstacles",
                                                "skip"])))  # fmt: skip
    return shape, extras, options


def build(shape: dict, extras: list, path: Path) -> Path:
    """The drawn model, written to ``path``."""
    shape = dict(shape)
    nx, ny, storeys = shape.pop("bays_x"), shape.pop("bays_y"), shape.pop("storeys")
    f = frame(nx, ny, storeys, **shape)
    span, height = shape["span"], shape["height"]
    levels = f.model.by_type("IfcBuildingStorey")
    width, depth, top = nx * span, ny * span, storeys * height
    for what, (a, b, c, d) in extras:
        st_ = levels[int(a * (len(levels) - 1))]
        if what == "brace":
            f.linear(st_, (0.2, 0, 0.3), (span - 0.2, 0, height - 0.4), 0.15, 0.15,
                     name="brace", ifc_class="IfcMember")  # fmt: skip
        elif what == "bare":
            f.bare(st_, "IfcBeam" if b < 0.5 else "IfcSlab", name="no geometry")
        elif what == "duplicate":
            elements = f.model.by_type("IfcElement")
            f.same_id(elements[int(b * (len(elements) - 1))], elements[0])
        elif what == "zero":
            f.linear(st_, (b * width, 0, height), (b * width, 0, height), name="zero length")
        elif what == "loose":  # a column and a beam on it in no storey, beside the frame
            x = width + span
            f.column(None, x, 0, 0, height, name="loose column")
            f.linear(f.building if b < 0.5 else None, (width, 0, height - 0.15),
                     (x, 0, height - 0.15), name="loose beam")  # fmt: skip
        elif what == "floor":  # the first storey's floor: the columns above pass through it
            f.box(levels[0], (-0.15, -0.15, height), (width + 0.15, depth + 0.15, height + 0.2),
                  name="floor")  # fmt: skip
        elif what == "floating":
            z = top + 1 + 3 * c
            f.box(st_, (0, 0, z), (1 + b * width, 1 + d * depth, z + 0.2), name="floating")
        elif what == "plate":
            lo = (b * width - 1, c * depth - 1, d * top)
            size = (0.1 + 3 * a, 0.1 + 3 * b, 0.1 + 3 * c)
            hi = tuple(v + s for v, s in zip(lo, size, strict=True))
            f.box(st_, lo, hi, name="plate", ifc_class="IfcPlate")
        elif what == "tower":  # 30 to 100 m: mostly too high for the format
            f.column(None, width + 2 * span, depth + span, 0, 30 + 70 * b, name="tower")
        else:  # a random straight member, axis-parallel or not
            start = (a * width, b * depth, c * top)
            end = (d * width, a * depth, b * top) if d < 0.7 else (width * d, start[1], start[2])
            f.linear(st_, start, end, name="random member", ifc_class="IfcMember")
    return f.write(path)


def run_case(tmp_path: Path, case) -> str:
    """``"imported"`` (loaded and finished by the planner) or ``"refused"`` (one line)."""
    shape, extras, options = case
    path = build(shape, extras, tmp_path / "model.ifc")
    try:
        result = import_ifc(path, **options)
    except IfcImportError as exc:
        message = str(exc)
        assert message and "\n" not in message, message
        return "refused"
    s = result.scenario
    assert parse_scenario(result.text, source="again").components == s.components
    env = multicrane.parallel_env(s)
    metrics = run_episode(env, PrioritizedPlanner(env), seed=0)
    assert metrics["success"], (case, metrics)
    return "imported"


@settings(max_examples=30, derandomize=True, **COMMON)
@given(models())
def test_fuzz_ifc_models(tmp_path_factory, case):
    run_case(tmp_path_factory.mktemp("fuzz"), case)


@pytest.mark.fuzz
@settings(max_examples=LARGE, derandomize=True, **COMMON)
@given(models())
def test_fuzz_ifc_models_large(tmp_path_factory, case):
    run_case(tmp_path_factory.mktemp("fuzz"), case)


def _figures(n: int) -> None:
    """Outcome counts and the time of ``n`` random models."""
    import collections
    import tempfile
    import time

    counts: collections.Counter = collections.Counter()

    @settings(max_examples=n, derandomize=False, **COMMON)
    @given(models())
    def draw(case):
        with tempfile.TemporaryDirectory() as d:
            counts[run_case(Path(d), case)] += 1

    start = time.perf_counter()
    draw()
    print(f"{n} models: {dict(counts)} in {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    import sys

    _figures(int(sys.argv[1]) if len(sys.argv) > 1 else 100)
