"""Reading an IFC model: its columns, beams, members and panels as world boxes, and what it skips.

Needs the ``ifc`` extra (``pip install 'multicrane[ifc]'``). ``read_ifc(path, cell)`` opens
the file with IfcOpenShell (IFC2X3, IFC4, IFC4X3), triangulates every element's body in world
coordinates (``ifcopenshell.geom``'s iterator: metres whatever the file's units, through every
nested placement and mapped item) and returns the elements it can use: ``IfcColumn``,
``IfcBeam`` and ``IfcMember`` as straight axis-parallel members (a member standing upright is
read as a column, a lying one as a beam) and ``IfcSlab``, ``IfcWall`` and ``IfcPlate`` as
panels, each with its storey (``IfcBuildingStorey``, through any assembly it is part of; the
elevation in metres) and its bounding box. Openings and other feature elements shape other
elements and are ignored; an assembly (``IfcElementAssembly``, ``IfcRoof``, ... with parts)
is read as its parts. Every other element is skipped with a reason (``Skipped``): an
unsupported type, no body geometry (none, none that can be triangulated, or of zero size), a
slanted or curved member, a column lying down, a beam standing up, a GlobalId that an earlier
element has (the first keeps it), a part of an element that is read as a whole.

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
# The geometry kernel: CGAL for plain extrusions and meshes, OpenCASCADE where booleans need it
# (about 0.2 ms an element against 5 ms for OpenCASCADE alone; docs/ifc.md).
KERNEL = "hybrid-cgal-simple-opencascade"


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
        raise IfcImportError(f"{p}: not a readable IFC file ({one_line(exc)})") from None


class _Storeys:
    """Each element's ``IfcBuildingStorey``: its name and elevation in metres (cached)."""

    def __init__(self, model):
        import ifcopenshell.util.unit

        self.scale = ifcopenshell.util.unit.calculate_unit_scale(model)  # metres per unit
        self.known: dict[int, tuple[str, float | None]] = {}

    def of(self, element) -> tuple[str, float | None]:
        import ifcopenshell.util.element

        st = ifcopenshell.util.element.get_container(element, ifc_class="IfcBuildingStorey")
        if st is None:
            return "", None
        if st.id() not in self.known:
            self.known[st.id()] = (st.Name or "", self._elevation(st))
        return self.known[st.id()]

    def _elevation(self, st) -> float | None:
        """The storey's ``Elevation``, else the height of its placement (metres)."""
        import ifcopenshell.util.placement

        if getattr(st, "Elevation", None) is not None:
            return float(st.Elevation) * self.scale
        if st.ObjectPlacement is None:
            return None
        matrix = ifcopenshell.util.placement.get_local_placement(st.ObjectPlacement)
        return float(matrix[2][3]) * self.scale


def _label(e) -> str:
    return f"{e.is_a()} {e.GlobalId} {e.Name or ''!r}"


def _select(model) -> tuple[list, list[Skipped]]:
    """The elements to triangulate (file order) and those left out before (module docstring):
    feature and virtual elements and assemblies with parts pass silently."""
    import ifcopenshell.util.element

    chosen, skipped, first = [], [], {}
    for e in sorted(model.by_type("IfcElement"), key=lambda e: e.id()):
        if e.is_a("IfcFeatureElement") or e.is_a("IfcVirtualElement"):
            continue  # openings and projections shape other elements; they are no parts
        ifc_type, gid, name = e.is_a(), e.GlobalId, e.Name or ""
        kind = next((k for k in (*LINEAR, *PANELS) if e.is_a(k)), None)
        whole = ifcopenshell.util.element.get_aggregate(e)
        reason = None
        if gid in first:
            reason = f"its GlobalId is also that of {_label(first[gid])} (GlobalIds are unique)"
        elif whole is not None and any(whole.is_a(k) for k in (*LINEAR, *PANELS)):
            reason = f"a part of {_label(whole)}, which is read as a whole"
        elif kind is None:
            if ifcopenshell.util.element.get_parts(e):
                continue  # an assembly (IfcElementAssembly, IfcRoof, ...): its parts are read
            reason = "unsupported type"
        elif e.Representation is None:
            reason = "no body geometry"
        first.setdefault(gid, e)
        if reason is None:
            chosen.append(e)
        else:
            skipped.append(Skipped(ifc_type, gid, name, reason))
    return chosen, skipped


def _bodies(model, elements: list) -> dict[int, np.ndarray]:
    """Each element's body vertices in world coordinates (metres), by entity id; an element
    the geometry kernel cannot triangulate is missing."""
    import ifcopenshell.geom

    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    settings.set("disable-opening-subtractions", True)  # openings never change the box
    out: dict[int, np.ndarray] = {}
    if not elements:
        return out
    it = ifcopenshell.geom.iterator(settings, model, 1, include=elements, geometry_library=KERNEL)
    if it.initialize():
        while True:
            shape = it.get()
            out[shape.id] = np.asarray(shape.geometry.verts, float).reshape(-1, 3)
            if not it.next():
                break
    return out


def read_ifc(path: str | Path, cell: float) -> tuple[str, list[Element], list[Skipped]]:
    """The file's schema, its usable elements and its skipped ones (file order)."""
    model = open_model(path)
    try:
        chosen, skipped = _select(model)
        bodies = _bodies(model, chosen)
    except RuntimeError as exc:  # the geometry kernel refusing the whole file
        raise IfcImportError(f"{path}: the geometry cannot be read ({one_line(exc)})") from None
    storeys = _Storeys(model)
    elements: list[Element] = []
    for e in chosen:
        kind = next(k for k in (*LINEAR, *PANELS) if e.is_a(k))
        verts = bodies.get(e.id())
        role, reason = _role(kind, verts, cell)
        if reason is not None:
            skipped.append(Skipped(e.is_a(), e.GlobalId, e.Name or "", reason))
            continue
        storey, elevation = storeys.of(e)
        lo, hi = verts.min(axis=0), verts.max(axis=0)
        elements.append(Element(kind, e.GlobalId, e.Name or "", storey, elevation, role,
                                tuple(map(float, lo)), tuple(map(float, hi))))  # fmt: skip
    return model.schema, elements, skipped


def _role(kind: str, verts: np.ndarray | None, cell: float) -> tuple[str, str | None]:
    """What an element of class ``kind`` with this body is ("column", "beam", "panel"), or why
    it is left out."""
    if verts is None or len(verts) == 0 or not np.isfinite(verts).all():
        return "", "no body geometry (none that can be triangulated)"
    if float((verts.max(axis=0) - verts.min(axis=0)).max()) < 1e-6:
        return "", "no body geometry (of zero size)"
    if kind not in LINEAR:
        return "panel", None
    axis, reason = classify(verts, cell)
    if reason is not None:
        return "", reason
    role = "column" if axis == 2 else "beam"
    if kind == "IfcColumn" and role != "column":
        return "", f"a column lying along {AXES[axis]} (not upright)"
    if kind == "IfcBeam" and role != "beam":
        return "", "a beam standing upright (along z)"
    return role, None


def one_line(exc: BaseException) -> str:
    """An exception's message on one line."""
    return " ".join(str(exc).split()) or type(exc).__name__
