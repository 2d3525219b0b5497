"""Landblock: a loaded 192 m block of the world: terrain cells, indoor cells, objects."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from ..cells.land_cell import LandCell
from ..geometry import Vec3
from ..terrain.landblock import LandblockTerrain

if TYPE_CHECKING:
    from ..cells.building import BuildingObj
    from ..cells.env_cell import EnvCell
    from ..cells.obj_cell import ObjCell
    from ..objects.obstacle import Obstacle

__all__ = ["Landblock"]


class Landblock:
    """Terrain plus what stands on it. `cells[i]` is outdoor cell index i+1."""

    __slots__ = ("id", "terrain", "cells", "env_cells", "buildings", "objects", "water_type", "source")

    def __init__(self, terrain: LandblockTerrain, source: Mapping[str, Any] | None = None) -> None:
        self.id = terrain.landblock_id
        self.terrain = terrain
        self.water_type = terrain.water_type
        self.env_cells: dict[int, EnvCell] = {}
        self.buildings: list[BuildingObj] = []
        self.objects: list[Obstacle] = []
        self.source = source
        cells: list[LandCell] = []
        for cx in range(8):
            for cy in range(8):
                pos = terrain.cell_position(cx, cy)
                cell = LandCell(pos.cell_id, pos, terrain.cell_triangles(cx, cy))
                cell.water_type = int(terrain.cell_water[cx, cy])
                cell.landblock = self
                cells.append(cell)
        self.cells = cells

    def calc_water_depth(self, cell_id: int, point: Vec3) -> float:
        return self.terrain.calc_water_depth(cell_id, point)

    def get_cell(self, cell_id: int) -> ObjCell | None:
        index = cell_id & 0xFFFF
        if 1 <= index <= 64:
            return self.cells[index - 1]
        return self.env_cells.get(cell_id)

    @property
    def has_objects(self) -> bool:
        return bool(self.env_cells or self.buildings or self.objects)
