"""Small IFC building models made with ifcopenshell.api: frames for the tests and the example.

Needs the ``ifc`` extra (``pip install 'multicrane[ifc]'``). ``FrameModel`` starts an IFC
file (project, units, a body context, site, building) and adds storeys and elements:
``column`` (a square section standing on a point), ``linear`` (any straight member between
two points of its axis: a beam, a member, a slanted brace), ``box`` (a slab, wall or plate
given by two opposite corners), ``bare`` (an element with no geometry) and ``assembly`` (an
``IfcElementAssembly``: elements made with it as their container are its parts). Every
element is an extruded rectangle placed with a 4 x 4 matrix, as authoring tools write them.
Coordinates are always given in metres, in the world; the model options say how they are
written:

- ``schema``: ``"IFC2X3"``, ``"IFC4"`` or ``"IFC4X3"``;
- ``units``: ``"m"`` or ``"mm"`` (lengths, placements and elevations in the file's unit);
- ``nested``: the site, building and storeys get placements of their own (the building
  moved by ``building_at``, each storey raised to its elevation) and every element's placement
  is relative to its storey's (or its assembly's), as authoring tools nest them;
- ``mapped``: every element's body is an ``IfcMappedItem`` of its type's representation map
  (one ``IfcBeamType``, ``IfcColumnType``, ... per class and size), as in type-based models.

``frame`` builds a whole column grid with a beam between every pair of neighbouring columns at
the top of each storey, and optionally secondary beams in every bay, infill walls on the first
column line, a roof slab on the top beams and each storey's beams in an assembly. The models
are deterministic except for their GlobalIds (drawn at random by ``ifcopenshell``) and the
header's time stamp; ``fixed_ids=True`` fixes both (the shipped examples). ``same_id``
gives an element another's GlobalId (a broken model, for the importer's tests).
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import ifcopenshell
import ifcopenshell.api.aggregate
import ifcopenshell.api.context
import ifcopenshell.api.geometry
import ifcopenshell.api.project
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.api.type
import ifcopenshell.api.unit
import ifcopenshell.guid
import numpy as np

Point = tuple[float, float, float]
UNITS = {"m": ("METERS", 1.0), "mm": ("MILLIMETERS", 0.001)}  # file unit, metres per unit


def _owner(m) -> None:
    """IFC2X3 needs an owner history on every rooted entity: ifcopenshell.api's defaults
    (``owner.settings``) take the file's first person and organisation and application."""
    import ifcopenshell.api.owner

    person = ifcopenshell.api.owner.add_person(m)
    org = ifcopenshell.api.owner.add_organisation(m)
    ifcopenshell.api.owner.add_person_and_organisation(m, person=person, organisation=org)
    ifcopenshell.api.owner.add_application(m)


def _matrix(origin, z_dir=(0.0, 0.0, 1.0), x_dir=(1.0, 0.0, 0.0)) -> np.ndarray:
    """The 4 x 4 placement with its origin at ``origin`` and its z axis along ``z_dir``."""
    z = np.asarray(z_dir, float) / np.linalg.norm(z_dir)
    x = np.asarray(x_dir, float)
    x = x - z * (x @ z)
    x /= np.linalg.norm(x)
    matrix = np.eye(4)
    matrix[:3, 0], matrix[:3, 1], matrix[:3, 2] = x, np.cross(z, x), z
    matrix[:3, 3] = origin
    return matrix


class FrameModel:
    """An IFC model under construction (one building; the module docstring lists the options)."""

    def __init__(self, name: str = "frame", schema: str = "IFC4", fixed_ids: bool = False,
                 units: str = "m", nested: bool = False, mapped: bool = False,
                 building_at: Point = (0.0, 0.0, 0.0)):  # fmt: skip
        self.fixed_ids, self.nested, self.mapped = fixed_ids, nested, mapped
        self.unit = UNITS[units][1]
        self.same: list[tuple[object, object]] = []  # (element, the one whose GlobalId it takes)
        self._types: dict[tuple, object] = {}
        m = self.model = ifcopenshell.api.project.create_file(version=schema)
        if schema == "IFC2X3":
            _owner(m)
        project = self._entity("IfcProject", name)
        ifcopenshell.api.unit.assign_unit(m, length={"is_metric": True, "raw": UNITS[units][0]})
        model3d = ifcopenshell.api.context.add_context(m, context_type="Model")
        self.body = ifcopenshell.api.context.add_context(
            m, context_type="Model", context_identifier="Body", target_view="MODEL_VIEW",
            parent=model3d,
        )  # fmt: skip
        site = self._entity("IfcSite", "Site")
        self.building = self._entity("IfcBuilding", name)
        ifcopenshell.api.aggregate.assign_object(m, relating_object=project, products=[site])
        ifcopenshell.api.aggregate.assign_object(m, relating_object=site, products=[self.building])
        self.building_at = building_at
        if nested:
            self._place(site, _matrix((0.0, 0.0, 0.0)))
            self._place(self.building, _matrix(building_at))

    def _entity(self, ifc_class: str, name: str):
        return ifcopenshell.api.root.create_entity(self.model, ifc_class=ifc_class, name=name)

    def _place(self, product, matrix: np.ndarray) -> None:
        ifcopenshell.api.geometry.edit_object_placement(
            self.model, product=product, matrix=matrix, is_si=True
        )

    def storey(self, name: str, elevation: float):
        """A new building storey at ``elevation`` metres."""
        st = self._entity("IfcBuildingStorey", name)
        st.Elevation = float(elevation) / self.unit
        ifcopenshell.api.aggregate.assign_object(
            self.model, relating_object=self.building, products=[st]
        )
        if self.nested:
            bx, by, bz = self.building_at
            self._place(st, _matrix((bx, by, bz + float(elevation))))
        return st

    def assembly(self, storey, name: str = "assembly"):
        """An ``IfcElementAssembly`` in ``storey``; pass it as an element's storey to add parts."""
        element = self._entity("IfcElementAssembly", name)
        self._contain(element, storey)
        return element

    def bare(self, storey, ifc_class: str = "IfcBeam", name: str = "bare"):
        """An element with no geometry (no representation, no placement)."""
        element = self._entity(ifc_class, name)
        self._contain(element, storey)
        return element

    def same_id(self, element, other) -> None:
        """Give ``element`` the GlobalId of ``other`` when the model is written."""
        self.same.append((element, other))

    def _contain(self, element, container) -> None:
        """Put ``element`` in a storey (or any spatial element), an assembly, or nowhere."""
        if container is None:
            return
        if container.is_a("IfcElementAssembly"):
            ifcopenshell.api.aggregate.assign_object(
                self.model, relating_object=container, products=[element]
            )
        else:
            ifcopenshell.api.spatial.assign_container(
                self.model, relating_structure=container, products=[element]
            )

    def _body(self, element, width: float, depth: float, length: float) -> None:
        """The element's body: an extruded rectangle, or a mapped item of its type's one."""
        m, u = self.model, self.unit
        key = (element.is_a(), round(width, 6), round(depth, 6), round(length, 6))
        if self.mapped and key in self._types:
            ifcopenshell.api.type.assign_type(m, related_objects=[element],
                                              relating_type=self._types[key])  # fmt: skip
            return
        profile = m.create_entity("IfcRectangleProfileDef", ProfileType="AREA",
                                  XDim=float(width) / u, YDim=float(depth) / u)  # fmt: skip
        if m.schema == "IFC2X3":  # the profile's position is optional from IFC4 on only
            origin = m.create_entity("IfcCartesianPoint", Coordinates=(0.0, 0.0))
            profile.Position = m.create_entity("IfcAxis2Placement2D", Location=origin)
        rep = ifcopenshell.api.geometry.add_profile_representation(
            m, context=self.body, profile=profile, depth=float(length)  # metres: it converts
        )
        if not self.mapped:
            ifcopenshell.api.geometry.assign_representation(m, product=element, representation=rep)
            return
        kind = self._entity(f"{element.is_a()}Type", f"{element.is_a()[3:]} {width}x{depth}")
        ifcopenshell.api.geometry.assign_representation(m, product=kind, representation=rep)
        self._types[key] = kind
        ifcopenshell.api.type.assign_type(m, related_objects=[element], relating_type=kind)

    def _extrusion(self, ifc_class, name, storey, origin, z_dir, x_dir, width, depth, length):
        """An element of class ``ifc_class``: a ``width`` x ``depth`` rectangle centred on the
        local z axis through ``origin`` (along ``z_dir``), extruded ``length`` metres."""
        element = self._entity(ifc_class, name)
        self._body(element, width, depth, length)
        self._place(element, _matrix(origin, z_dir, x_dir))
        self._contain(element, storey)  # the placement is made relative to the container's
        return element

    def column(self, storey, x: float, y: float, z0: float, height: float, section: float = 0.3,
               name: str = "column", ifc_class: str = "IfcColumn"):  # fmt: skip
        """A column of square ``section`` standing at ``(x, y, z0)``, ``height`` metres tall."""
        return self._extrusion(ifc_class, name, storey, (x, y, z0), (0, 0, 1), (1, 0, 0),
                               section, section, height)  # fmt: skip

    def linear(self, storey, start: Point, end: Point, width: float = 0.3, depth: float = 0.3,
               name: str = "beam", ifc_class: str = "IfcBeam"):  # fmt: skip
        """A straight member whose axis (the section's centre line) runs from ``start`` to
        ``end``: a beam, a member or, when the two differ in height and plan, a brace (of no
        length, standing along z, when they are the same point)."""
        a, b = np.asarray(start, float), np.asarray(end, float)
        d = b - a if np.linalg.norm(b - a) > 0 else np.array([0.0, 0.0, 1.0])
        up = np.array([0.0, 0.0, 1.0])
        x_dir = up if abs(d @ up) < 0.9 * np.linalg.norm(d) else np.array([1.0, 0.0, 0.0])
        return self._extrusion(ifc_class, name, storey, a, d, x_dir, depth, width,
                               np.linalg.norm(b - a))  # fmt: skip

    def box(self, storey, lo: Point, hi: Point, name: str = "slab", ifc_class: str = "IfcSlab"):
        """A solid box from corner ``lo`` to corner ``hi`` (a slab, wall or plate)."""
        lo_, hi_ = np.asarray(lo, float), np.asarray(hi, float)
        centre = (lo_ + hi_) / 2
        size = hi_ - lo_
        return self._extrusion(ifc_class, name, storey, (centre[0], centre[1], lo_[2]),
                               (0, 0, 1), (1, 0, 0), size[0], size[1], size[2])  # fmt: skip

    def write(self, path: str | Path) -> Path:
        """Write the model; with ``fixed_ids`` every GlobalId is derived from the entity's
        number and the header's time stamp is fixed, so the same model gives the same bytes."""
        if self.fixed_ids:
            for e in self.model.by_type("IfcRoot"):
                digest = hashlib.sha256(f"{e.is_a()}#{e.id()}".encode()).hexdigest()
                e.GlobalId = ifcopenshell.guid.compress(digest[:32])
            self.model.header.file_name.time_stamp = "2026-01-01T00:00:00"
        for element, other in self.same:
            element.GlobalId = other.GlobalId
        self.model.write(str(path))
        return Path(path)


def frame(bays_x: int, bays_y: int, storeys: int, span: float = 4.0, height: float = 3.0,
          section: float = 0.3, *, name: str = "frame", origin: Point = (0.0, 0.0, 0.0),
          secondary: int = 0, walls: bool = False, roof: bool = False,
          assemblies: bool = False, **options) -> FrameModel:  # fmt: skip
    """A steel frame: ``(bays_x + 1) x (bays_y + 1)`` columns ``span`` metres apart (one row
    when ``bays_y`` is 0: a portal frame), one column per position and storey, and a beam
    (top flush with the column tops) between each pair of neighbouring columns per storey;
    the first column stands at ``origin``. Optionally ``secondary`` beams across each bay
    along y (axis to axis of the beams they rest on, tops flush), infill ``walls`` between
    the columns of the first line (``j = 0``) in every storey, under its beams, a ``roof``
    slab on the top beams covering the whole frame, and each storey's beams in an
    ``IfcElementAssembly`` (``assemblies``). ``options`` go to ``FrameModel``."""
    f = FrameModel(name=name, **options)
    ox, oy, oz = origin
    grid = [(i, j) for j in range(bays_y + 1) for i in range(bays_x + 1)]

    def at(i: float, j: float) -> tuple[float, float]:
        return (ox + i * span, oy + j * span)

    for k in range(storeys):
        z0, top = oz + k * height, oz + (k + 1) * height
        st = f.storey(f"Level {k + 1}", z0)
        for n, (i, j) in enumerate(grid, 1):
            f.column(st, *at(i, j), z0, height, section, name=f"C{k + 1}.{n}")
        beams_in = f.assembly(st, f"Beams {k + 1}") if assemblies else st
        axis_z = top - section / 2
        pairs = [((i, j), (i + 1, j)) for i, j in grid if i < bays_x]
        pairs += [((i, j), (i, j + 1)) for i, j in grid if j < bays_y]
        for n, (a, b) in enumerate(pairs, 1):
            f.linear(beams_in, (*at(*a), axis_z), (*at(*b), axis_z), section, section,
                     name=f"B{k + 1}.{n}")  # fmt: skip
        bays = [(i, j) for i, j in grid if i < bays_x and j < bays_y]
        for n, (i, j, s) in enumerate([(i, j, s) for i, j in bays for s in range(secondary)], 1):
            x = i + (s + 1) / (secondary + 1)
            depth = 0.8 * section
            f.linear(beams_in, (*at(x, j), top - depth / 2), (*at(x, j + 1), top - depth / 2),
                     0.7 * section, depth, name=f"SB{k + 1}.{n}")  # fmt: skip
        for i in range(bays_x if walls else 0):
            (x0, y0), (x1, _) = at(i, 0), at(i + 1, 0)
            f.box(st, (x0, y0 - 0.1, z0), (x1, y0 + 0.1, top), name=f"W{k + 1}.{i + 1}",
                  ifc_class="IfcWall")  # fmt: skip
            # centre line to centre line: the import cuts the columns and beam off its edges
    if roof and storeys:
        top, half = oz + storeys * height, section / 2
        st = f.model.by_type("IfcBuildingStorey")[-1]
        x1, y1 = at(bays_x, bays_y)
        f.box(st, (ox - half, oy - half, top), (x1 + half, y1 + half, top + 0.2), name="Roof")
    return f
