"""Static objects of a landblock (LandblockInfo objects and EnvCell statics).

Each becomes an obstacle registered in the cells it occupies (ACE: a BSP or
sphere object in the cell holding its origin; a cylsphere object in every
cell a sphere of its radius at its low point touches). Cells test their
objects newest first.
"""

from __future__ import annotations

from typing import Any
from collections.abc import Mapping

from ..geometry import Position
from ..geometry.landdefs import outdoor_cell_id
from ..objects.setup import frame_from_dict
from ..objects.obstacle import Obstacle
from ..cells.cell_array import CellArray
from ..cells.find_cell_list import find_cell_list
from ..geometry import Sphere
from ..cells.obj_cell import ObjCell
from .landblock import Landblock
from .portal_cache import PortalCache

__all__ = ["attach_static_objects"]


def attach_static_objects(landblock: Landblock, lb_data: Mapping[str, Any], cache: PortalCache) -> None:
    """Create the landblock's static objects and register them in their cells."""
    for entry in lb_data.get("objects", []):
        model_id = int(entry["id"], 16)
        frame = frame_from_dict(entry.get("frame", {}))
        cell_id = outdoor_cell_id(landblock.id, frame.origin.x, frame.origin.y)
        _add_object(landblock, cache, model_id, Position(cell_id, frame))
    for ec in lb_data.get("env_cells", []):
        cell_id = int(ec["id"], 16)
        for entry in ec.get("static_objects", []):
            model_id = int(entry["id"], 16)
            frame = frame_from_dict(entry.get("frame", {}))
            _add_object(landblock, cache, model_id, Position(cell_id, frame))


def _add_object(landblock: Any, cache: PortalCache, model_id: int, position: Position) -> None:
    """A static dat object (PhysicsState.Static, no weenie) of the model at
    `position`, registered in its cells; a Setup without parts makes none."""
    obj = cache.obstacle(model_id, position, static=True)
    if obj is not None:
        _register(landblock, obj, position.cell_id)
        landblock.objects.append(obj)


class _ThisLandblock:
    """Cell lookup during loading: only the landblock being built exists yet."""

    def __init__(self, landblock: Landblock) -> None:
        self.landblock = landblock

    def get_landcell(self, cell_id: int) -> ObjCell | None:
        if (cell_id >> 16) & 0xFFFF != self.landblock.id:
            return None
        return self.landblock.get_cell(cell_id)


def _register(landblock: Landblock, obj: Obstacle, cell_id: int) -> None:
    """Put the object in the cells it occupies: a cylsphere object in every cell
    that a sphere of each cylsphere's radius at its low point touches
    (find_cell_list over the cylspheres), anything else in its own cell."""
    cells: list[ObjCell] = []
    if obj.cyl_spheres and not obj.has_physics_bsp:
        frame = obj.position.frame
        spheres = [Sphere(frame.local_to_global(c.low_point), c.radius) for c in obj.cyl_spheres[:10]]
        found = CellArray(_ThisLandblock(landblock))
        find_cell_list(obj.position, len(spheres), spheres, found, False, None)
        cells = [c for c in found.cells() if c is not None]
    if not cells:
        own = landblock.get_cell(cell_id)
        cells = [own] if own is not None else []
    for cell in cells:
        cell.shadow_objects.append(obj)
