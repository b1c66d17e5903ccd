"""Reading an IFC model: its columns, beams, members and panels as world boxes, and what it skips.

Needs the ``ifc`` extra (``pip install 'multicrane[ifc]'``). ``read_ifc(path, cell)`` opens
the file with IfcOpenShell, triangulates every element's body in world coordinates
(``ifcopenshell.geom``, metres whatever the file's units) and returns the elements it can
use: ``IfcColumn``, ``IfcBeam`` and ``IfcMember`` as straight axis-parallel members (a member
standing upright is read as a column, a lying one as a beam) and ``IfcSlab``, ``IfcWall`` and
``IfcPlate`` as panels, each with its storey (``IfcBuildingStorey``) and its bounding box.
Every other element is skipped with a reason (``Skipped``): an unsupported type, no body
geometry, a slanted or curved member, a column lying down, a beam standing up.

Straightness is judged from the geometry alone (``classify``), so it works for extrusions,
breps and meshes alike: the member's axis is the longest side of its bounding box; the
vertices near either end give the end sections; the member is *slanted* when the centres of
its two end sections lie more than a quarter cell apart across the axis, and *curved* when its
box is wider across the axis than its end sections by more than a quarter cell.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

LINEAR = ("IfcColumn", "IfcBeam", "IfcMember")
PANELS = ("IfcSlab", "IfcWall", "IfcPlate")
AXES = "xyz"


class IfcImportError(ValueError):
    """An IFC file that cannot be imported; the message names the file and the problem."""


@dataclass(frozen=True)
class Element:
    """One usable IFC element: its identity, storey and world bounding box (metres)."""

    ifc_type: str
    global_id: str
    name: str
    storey: str  # the IfcBuildingStorey's name ("" when the element is in none)
    storey_elevation: float | None
    role: str  # "column", "beam" or "panel"
    lo: tuple[float, float, float]
    hi: tuple[float, float, float]


@dataclass(frozen=True)
class Skipped:
    """One element left out of the import, and why."""

    ifc_type: str
    global_id: str
    name: str
    reason: str

    def line(self) -> str:
        return f"{self.ifc_type} {self.global_id} {self.name!r}: {self.reason}"


def classify(verts: np.ndarray, cell: float) -> tuple[int | None, str | None]:
    """The axis (0 x, 1 y, 2 z) of a straight axis-parallel member with these world vertices
    (n x 3, metres), or ``(None, reason)``: slanted or curved (module docstring)."""
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    extent = hi - lo
    axis = int(np.argmax(extent))
    length = extent[axis]
    across = [a for a in range(3) if a != axis]
    tol = cell / 4
    band = max(0.05 * length, 1e-6)
    ends = [verts[verts[:, axis] <= lo[axis] + band], verts[verts[:, axis] >= hi[axis] - band]]
    centres = [(e[:, across].min(axis=0) + e[:, across].max(axis=0)) / 2 for e in ends]
    shift = float(np.abs(centres[1] - centres[0]).max())
    if shift > tol:
        angle = float(np.degrees(np.arctan2(np.hypot(*(centres[1] - centres[0])), length)))
        return None, f"slanted member ({angle:.0f} degrees off the {AXES[axis]} axis)"
    widths = [e[:, across].max(axis=0) - e[:, across].min(axis=0) for e in ends]
    bulge = float((extent[across] - np.maximum(widths[0], widths[1])).max())
    if bulge > tol:
        return None, f"curved member (bows {bulge:.2f} m off a straight {AXES[axis]} axis)"
    return axis, None


def open_model(path: str | Path):
    """The IFC file at ``path``, opened; every problem an ``IfcImportError`` naming it."""
    import ifcopenshell

    p = Path(path)
    if not p.is_file():
        raise IfcImportError(f"{p}: no such file")
    head = p.read_bytes()[:64]
    if not head.strip():
        raise IfcImportError(f"{p}: the file is empty")
    if not head.lstrip().startswith(b"ISO-10303-21"):
        raise IfcImportError(f"{p}: not an IFC file (an IFC-SPF file starts with ISO-10303-21;)")
    try:
        return ifcopenshell.open(str(p))
    except Exception as exc:  # IfcOpenShell raises its own Error, OSError or RuntimeError
        raise IfcImportError(f"{p}: not a readable IFC file ({exc})") from None


def _storey(element) -> tuple[str, float | None]:
    import ifcopenshell.util.element

    container = ifcopenshell.util.element.get_container(element, ifc_class="IfcBuildingStorey")
    if container is None:
        return "", None
    elevation = getattr(container, "Elevation", None)
    return container.Name or "", None if elevation is None else float(elevation)


def read_ifc(path: str | Path, cell: float) -> tuple[str, list[Element], list[Skipped]]:
    """The file's schema, its usable elements and its skipped ones (file order)."""
    import ifcopenshell.geom

    model = open_model(path)
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    elements: list[Element] = []
    skipped: list[Skipped] = []
    for e in sorted(model.by_type("IfcElement"), key=lambda e: e.id()):
        if e.is_a("IfcFeatureElement") or e.is_a("IfcVirtualElement"):
            continue  # openings and projections shape other elements; they are no parts
        ifc_type, gid, name = e.is_a(), e.GlobalId, e.Name or ""

        def skip(reason: str, ifc_type=ifc_type, gid=gid, name=name) -> None:
            skipped.append(Skipped(ifc_type, gid, name, reason))

        kind = next((k for k in (*LINEAR, *PANELS) if e.is_a(k)), None)
        if kind is None:
            skip("unsupported type")
            continue
        if e.Representation is None:
            skip("no body geometry")
            continue
        try:
            shape = ifcopenshell.geom.create_shape(settings, e)
        except Exception as exc:  # a representation IfcOpenShell cannot triangulate
            skip(f"no body geometry ({exc})")
            continue
        verts = np.asarray(shape.geometry.verts, float).reshape(-1, 3)
        if len(verts) == 0:
            skip("no body geometry")
            continue
        role = "panel"
        if kind in LINEAR:
            axis, reason = classify(verts, cell)
            if reason is not None:
                skip(reason)
                continue
            role = "column" if axis == 2 else "beam"
            if kind == "IfcColumn" and role != "column":
                skip(f"a column lying along {AXES[axis]} (not upright)")
                continue
            if kind == "IfcBeam" and role != "beam":
                skip("a beam standing upright (along z)")
                continue
        storey, elevation = _storey(e)
        lo, hi = verts.min(axis=0), verts.max(axis=0)
        elements.append(Element(kind, gid, name, storey, elevation, role,
                                tuple(map(float, lo)), tuple(map(float, hi))))  # fmt: skip
    return model.schema, elements, skipped
