"""BIM import (the ``ifc`` extra): IFC building models read, snapped to the grid and written
as scenario files.

May import: ``core``, ``sim`` and ``scenario``.
"""
