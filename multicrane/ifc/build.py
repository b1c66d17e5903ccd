"""Small IFC building models made with ifcopenshell.api: frames for the tests and the example.

Needs the ``ifc`` extra (``pip install 'multicrane[ifc]'``). ``FrameModel`` starts an IFC
file (project, metre units, a body context, site, building) and adds storeys and elements:
``column`` (a square section standing on a point), ``linear`` (any straight member between
two points of its axis: a beam, a member, a slanted brace) and ``box`` (a slab, wall or plate
given by two opposite corners). Every element is an extruded rectangle placed with a
4 x 4 matrix, as authoring tools write them. ``frame`` builds a whole column grid with a
beam between every pair of neighbouring columns at the top of each storey. The models are
deterministic except for their GlobalIds (drawn at random by ``ifcopenshell``) and the
header's time stamp; ``fixed_ids=True`` fixes both (the shipped example).
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
import ifcopenshell.api.unit
import ifcopenshell.guid
import numpy as np

Point = tuple[float, float, float]


def _owner(m) -> None:
    """IFC2X3 needs an owner history on every rooted entity: ifcopenshell.api's defaults
    (``owner.settings``) take the file's first person and organisation and application."""
    import ifcopenshell.api.owner

    person = ifcopenshell.api.owner.add_person(m)
    org = ifcopenshell.api.owner.add_organisation(m)
    ifcopenshell.api.owner.add_person_and_organisation(m, person=person, organisation=org)
    ifcopenshell.api.owner.add_application(m)


class FrameModel:
    """An IFC model under construction (one building, metre units)."""

    def __init__(self, name: str = "frame", schema: str = "IFC4", fixed_ids: bool = False):
        self.fixed_ids = fixed_ids
        m = self.model = ifcopenshell.api.project.create_file(version=schema)
        if schema == "IFC2X3":
            _owner(m)
        project = self._entity("IfcProject", name)
        ifcopenshell.api.unit.assign_unit(m, length={"is_metric": True, "raw": "METERS"})
        model3d = ifcopenshell.api.context.add_context(m, context_type="Model")
        self.body = ifcopenshell.api.context.add_context(
            m, context_type="Model", context_identifier="Body", target_view="MODEL_VIEW",
            parent=model3d,
        )  # fmt: skip
        site = self._entity("IfcSite", "Site")
        self.building = self._entity("IfcBuilding", name)
        ifcopenshell.api.aggregate.assign_object(m, relating_object=project, products=[site])
        ifcopenshell.api.aggregate.assign_object(m, relating_object=site, products=[self.building])

    def _entity(self, ifc_class: str, name: str):
        return ifcopenshell.api.root.create_entity(self.model, ifc_class=ifc_class, name=name)

    def storey(self, name: str, elevation: float):
        """A new building storey at ``elevation`` metres."""
        st = self._entity("IfcBuildingStorey", name)
        st.Elevation = float(elevation)
        ifcopenshell.api.aggregate.assign_object(
            self.model, relating_object=self.building, products=[st]
        )
        return st

    def _extrusion(self, ifc_class, name, storey, origin, z_dir, x_dir, width, depth, length):
        """An element of class ``ifc_class``: a ``width`` x ``depth`` rectangle centred on the
        local z axis through ``origin`` (along ``z_dir``), extruded ``length`` metres."""
        m = self.model
        element = self._entity(ifc_class, name)
        profile = m.create_entity(
            "IfcRectangleProfileDef", ProfileType="AREA", XDim=float(width), YDim=float(depth)
        )
        rep = ifcopenshell.api.geometry.add_profile_representation(
            m, context=self.body, profile=profile, depth=float(length)
        )
        ifcopenshell.api.geometry.assign_representation(m, product=element, representation=rep)
        z = np.asarray(z_dir, float) / np.linalg.norm(z_dir)
        x = np.asarray(x_dir, float)
        x = x - z * (x @ z)
        x /= np.linalg.norm(x)
        matrix = np.eye(4)
        matrix[:3, 0], matrix[:3, 1], matrix[:3, 2] = x, np.cross(z, x), z
        matrix[:3, 3] = origin
        ifcopenshell.api.geometry.edit_object_placement(
            m, product=element, matrix=matrix, is_si=True
        )
        if storey is not None:
            ifcopenshell.api.spatial.assign_container(
                m, relating_structure=storey, products=[element]
            )
        return element

    def column(self, storey, x: float, y: float, z0: float, height: float, section: float = 0.3,
               name: str = "column", ifc_class: str = "IfcColumn"):  # fmt: skip
        """A column of square ``section`` standing at ``(x, y, z0)``, ``height`` metres tall."""
        return self._extrusion(ifc_class, name, storey, (x, y, z0), (0, 0, 1), (1, 0, 0),
                               section, section, height)  # fmt: skip

    def linear(self, storey, start: Point, end: Point, width: float = 0.3, depth: float = 0.3,
               name: str = "beam", ifc_class: str = "IfcBeam"):  # fmt: skip
        """A straight member whose axis (the section's centre line) runs from ``start`` to
        ``end``: a beam, a member or, when the two differ in height and plan, a brace."""
        a, b = np.asarray(start, float), np.asarray(end, float)
        d = b - a
        up = np.array([0.0, 0.0, 1.0])
        x_dir = up if abs(d @ up) < 0.9 * np.linalg.norm(d) else np.array([1.0, 0.0, 0.0])
        return self._extrusion(ifc_class, name, storey, a, d, x_dir, depth, width,
                               np.linalg.norm(d))  # fmt: skip

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
        self.model.write(str(path))
        return Path(path)


def frame(bays_x: int, bays_y: int, storeys: int, span: float = 4.0, height: float = 3.0,
          section: float = 0.3, schema: str = "IFC4", fixed_ids: bool = False,
          name: str = "frame", origin: Point = (0.0, 0.0, 0.0)) -> FrameModel:  # fmt: skip
    """A steel frame: ``(bays_x + 1) x (bays_y + 1)`` columns ``span`` metres apart (one row
    when ``bays_y`` is 0: a portal frame), one column per position and storey, and a beam
    (top flush with the column tops) between each pair of neighbouring columns per storey;
    the first column stands at ``origin``."""
    f = FrameModel(name=name, schema=schema, fixed_ids=fixed_ids)
    ox, oy, oz = origin
    grid = [(i, j) for j in range(bays_y + 1) for i in range(bays_x + 1)]

    def at(i: int, j: int) -> tuple[float, float]:
        return (ox + i * span, oy + j * span)

    for k in range(storeys):
        z0, top = oz + k * height, oz + (k + 1) * height
        st = f.storey(f"Level {k + 1}", z0)
        for n, (i, j) in enumerate(grid, 1):
            f.column(st, *at(i, j), z0, height, section, name=f"C{k + 1}.{n}")
        axis_z = top - section / 2
        pairs = [((i, j), (i + 1, j)) for i, j in grid if i < bays_x]
        pairs += [((i, j), (i, j + 1)) for i, j in grid if j < bays_y]
        for n, (a, b) in enumerate(pairs, 1):
            f.linear(st, (*at(*a), axis_z), (*at(*b), axis_z), section, section,
                     name=f"B{k + 1}.{n}")  # fmt: skip
    return f
