"""The component kinds as one table: per kind its file name, shape, supports, observation, colours.

Every room reads a kind's rules from its entry here (``kind_spec(code)``) instead of
branching on the kind, so a new kind is one ``KindSpec`` entry (``add_kind``) plus its tests.
An entry is data; the rooms above give each *shape* and each *supports rule* its meaning:

- ``shape`` (``multicrane.scenario.components_table`` checks it, ``multicrane.sim.geometry``
  lifts by it): a **vertical bar** (column: a straight run of cells along z; lifted, it is
  stood upright on node 1's (x, y), one cell up), a **horizontal bar** (beam: along x or y), a
  **horizontal panel** (slab: a rectangle one cell thick, at least 2 x 2 cells, z0 == z1) or a
  **vertical panel** (wall: upright, at least 2 cells along x or y and along z). Bars are given
  by their two end cells and a ``length`` in the file, may start at random and lie in the
  generator's lanes; panels by two opposite corners, lie flat in the yard (in a strip of their
  own in generated sites) and have fixed starts. Every shape but the vertical bar is lifted by
  turning it about its yard centre to its target's orientation: horizontal shapes to the lift
  height (``rules.beam_lift_z``; default: their target's height), a vertical panel stood up
  one cell above the yard.
- ``supports`` (``multicrane.scenario.supports`` checks or derives it) with ``rests_on``, the
  kinds it may rest on: **stacked** (on a foundation at the ground, else on a ``rests_on``
  target directly under its bottom cell; the support is implied, the file names none),
  **named** (the file names at least one support, each a ``rests_on`` target touching it),
  **under some** (it rests on the ``rests_on`` targets directly under its cells, at least one)
  or **under all** (every cell under its bottom row holds a ``rests_on`` target or, at the
  ground, a foundation); the two "under" rules derive the supports where the file names none.
- ``waits_for_target``: it may be claimed (or given out) only while some target it may fill
  is ready (free, supports assembled). ``beam_feature``: the value of the observations'
  ``beam`` column (``multicrane.envs.observation``, ``multicrane.envs.task_observation``);
  every kind shares the same planes. ``colors``: its RGBA colour per ``Status`` in 3D replays
  (every component is drawn as the box of its cells). ``ifc_types``: the IFC entity types an
  IFC import turns into this kind when they snap to its shape (``ifc_kind``).

``Kind`` (``multicrane.core.codes``) names the four built-in codes; a kind added later has a
plain integer code, which ``ComponentSpec.kind`` and the episode arrays hold the same way.
"""

from __future__ import annotations

from dataclasses import dataclass

from multicrane.core.codes import Kind, Status

VERTICAL_BAR = "vertical bar"
HORIZONTAL_BAR = "horizontal bar"
HORIZONTAL_PANEL = "horizontal panel"
VERTICAL_PANEL = "vertical panel"
SHAPES = (VERTICAL_BAR, HORIZONTAL_BAR, HORIZONTAL_PANEL, VERTICAL_PANEL)

STACKED = "stacked"
NAMED = "named"
UNDER_SOME = "under some"
UNDER_ALL = "under all"
SUPPORTS_RULES = (STACKED, NAMED, UNDER_SOME, UNDER_ALL)

RGBA = tuple[int, int, int, int]
# Colours by component state (initial, in transit, arrived, assembled), as in the paper's
# figures; panels get their own, so that they stand out from the frame.
FRAME_COLORS: tuple[RGBA, ...] = (
    (255, 153, 0, 255),  # initial: orange
    (40, 110, 255, 255),  # in transit: blue
    (50, 190, 70, 255),  # arrived: green
    (240, 110, 180, 255),  # assembled: pink
)
PANEL_COLORS: tuple[RGBA, ...] = (
    (190, 120, 60, 255),  # initial: brown
    (0, 175, 200, 255),  # in transit: cyan
    (150, 205, 50, 255),  # arrived: lime
    (160, 90, 210, 255),  # assembled: violet
)


@dataclass(frozen=True)
class KindSpec:
    """One component kind's rules, as data (the module docstring says what each field means)."""

    code: int  # ComponentSpec.kind, Site.kind
    name: str  # the scenario file's ``kind = "..."``, lower case
    shape: str  # one of SHAPES
    supports: str  # one of SUPPORTS_RULES
    rests_on: tuple[int, ...]  # codes of the kinds it may rest on (in the order messages name)
    waits_for_target: bool
    beam_feature: bool
    colors: tuple[RGBA, ...]  # per Status
    ifc_types: tuple[str, ...] = ()

    @property
    def panel(self) -> bool:
        """Given by two opposite corners, with no ``length`` key and no random start."""
        return self.shape in (HORIZONTAL_PANEL, VERTICAL_PANEL)

    @property
    def upright(self) -> bool:
        return self.shape in (VERTICAL_BAR, VERTICAL_PANEL)

    @property
    def lifted_about_centre(self) -> bool:
        """Its pick-up pose turns about its yard centre to its target's orientation (so it
        depends on the target); a vertical bar is stood up on node 1 instead."""
        return self.shape != VERTICAL_BAR


KINDS: dict[int, KindSpec] = {
    Kind.COLUMN: KindSpec(Kind.COLUMN, "column", VERTICAL_BAR, STACKED, (Kind.COLUMN,),
                          False, False, FRAME_COLORS, ("IfcColumn", "IfcMember")),
    Kind.BEAM: KindSpec(Kind.BEAM, "beam", HORIZONTAL_BAR, NAMED, (Kind.COLUMN, Kind.BEAM),
                        True, True, FRAME_COLORS, ("IfcBeam", "IfcMember")),
    Kind.SLAB: KindSpec(Kind.SLAB, "slab", HORIZONTAL_PANEL, UNDER_SOME, (Kind.BEAM, Kind.WALL),
                        True, False, PANEL_COLORS, ("IfcSlab", "IfcWall", "IfcPlate")),
    Kind.WALL: KindSpec(Kind.WALL, "wall", VERTICAL_PANEL, UNDER_ALL, (Kind.SLAB, Kind.BEAM),
                        True, False, PANEL_COLORS, ("IfcSlab", "IfcWall", "IfcPlate")),
}  # fmt: skip


def kind_spec(code: int) -> KindSpec:
    """The entry of the kind with this code."""
    return KINDS[code]


def kind_named(name: str) -> KindSpec | None:
    """The kind a scenario file names (any letter case), or None."""
    return next((k for k in KINDS.values() if k.name.upper() == name.upper()), None)


def kind_names() -> str:
    """The kinds' file names, quoted, as a message lists them: 'a', 'b' or 'c'."""
    names = [repr(k.name) for k in KINDS.values()]
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " or " + names[-1]


def rests_on_names(spec: KindSpec) -> str:
    """The kinds this one may rest on, as a message names them: ``beam or wall``."""
    return " or ".join(KINDS[k].name for k in spec.rests_on)


def waits_for_target(code: int) -> bool:
    """A component of this kind may be claimed (or given out) only while some target it may
    fill is ready (free, supports assembled): beams and panels wait, columns never do."""
    return KINDS[code].waits_for_target


def ifc_kind(ifc_type: str, shape: str) -> KindSpec:
    """The kind an IFC element of this entity type becomes when it snaps to ``shape``: the
    first in the table with that shape that lists the type."""
    found = next((k for k in KINDS.values() if k.shape == shape and ifc_type in k.ifc_types), None)
    if found is None:
        raise KeyError(f"no kind of shape {shape!r} takes the IFC type {ifc_type}")
    return found


def add_kind(spec: KindSpec) -> KindSpec:
    """Add a kind to the table (its code and name new, its fields valid) and return it."""
    checks = (
        (spec.code in KINDS, f"code {spec.code} is taken"),
        (kind_named(spec.name) is not None, f"name {spec.name!r} is taken"),
        (spec.name != spec.name.lower(), f"name {spec.name!r} must be lower case"),
        (spec.shape not in SHAPES, f"shape {spec.shape!r}: one of {SHAPES}"),
        (spec.supports not in SUPPORTS_RULES, f"supports {spec.supports!r}: one of "
         f"{SUPPORTS_RULES}"),
        (spec.supports == STACKED and spec.shape != VERTICAL_BAR,
         "only a vertical bar is stacked (on the one cell under its bottom)"),
        (not spec.rests_on or not all(k in KINDS or k == spec.code for k in spec.rests_on),
         f"rests_on {spec.rests_on}: codes of known kinds, at least one"),
        (len(spec.colors) != len(Status) or any(len(c) != 4 for c in spec.colors),
         f"colors: one RGBA per status ({len(Status)})"),
    )  # fmt: skip
    problem = next((message for bad, message in checks if bad), None)
    if problem is not None:
        raise ValueError(f"kind {spec.name!r}: {problem}")
    KINDS[spec.code] = spec
    return spec
