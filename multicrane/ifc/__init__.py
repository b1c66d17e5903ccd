"""BIM in and out (the ``ifc`` extra): IFC building models read, snapped to the grid and
written as scenario files, and plans written back into the models as 4D work schedules.

May import: ``core``, ``sim`` and ``scenario`` (the import), and ``replay`` (the 4D export
reads episode records).
"""
