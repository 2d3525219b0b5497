"""A landblock's terrain: 9x9 heights, 8x8 cells of two triangles, water."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..constants import BLOCK_LENGTH, CELL_LENGTH
from ..geometry import Frame, Position, Vec3
from ..geometry.landdefs import blockid_to_lcoord
from .split import split_sw_to_ne
from .triangle import TerrainTriangle
from .water import PARTIAL_WATER_DEPTH, SHORE_DEPTH, WaterType, is_water_terrain

__all__ = ["LandblockTerrain"]


class LandblockTerrain:
    """The terrain of one landblock (the client's CLandBlockStruct).

    Vertex (x, y) sits at (24x, 24y, height_table[heights[x*9+y]]) in
    landblock coordinates. `heights` and `terrain` use the client's index
    order x * 9 + y.
    """

    __slots__ = ("landblock_id", "heights", "terrain", "z", "water_vertex", "water_flags", "cell_water", "water_type", "triangles",
                 "split")

    def __init__(
        self,
        landblock_id: int,
        heights: Sequence[int],
        height_table: Sequence[float],
        terrain: Sequence[int] | None = None,
    ) -> None:
        if len(heights) != 81:
            raise ValueError(f"landblock {landblock_id:04X}: expected 81 height bytes, got {len(heights)}")
        if len(height_table) != 256:
            raise ValueError(f"height table must have 256 entries, got {len(height_table)}")
        if terrain is None:
            terrain = [0] * 81
        if len(terrain) != 81:
            raise ValueError(f"landblock {landblock_id:04X}: expected 81 terrain words, got {len(terrain)}")
        for h in heights:
            if not 0 <= int(h) <= 255:
                raise ValueError(f"landblock {landblock_id:04X}: height byte {h} out of 0..255")
        self.landblock_id = landblock_id
        self.heights = np.asarray(heights, dtype=np.uint8).reshape(9, 9)
        self.terrain = np.asarray(terrain, dtype=np.uint16).reshape(9, 9)
        table = np.asarray(height_table, dtype=np.float64)
        self.z = table[self.heights]  # (9, 9) absolute vertex heights
        self.water_vertex = np.array([[is_water_terrain(int(w)) for w in row] for row in self.terrain])
        #: water_vertex as plain flags in index order x * 9 + y: read per move (compiled, indexing a
        #: numpy array is a generic call that boxes the index)
        self.water_flags: list[bool] = [bool(w) for w in self.water_vertex.flatten()]
        self._build_water()
        self._build_triangles()

    def _build_water(self) -> None:
        """Per-cell and whole-block water (LandblockStruct.CalcWater)."""
        wv = self.water_vertex
        cell_water = np.zeros((8, 8), dtype=np.int8)
        any_water = False
        all_flooded = True
        for x in range(8):
            for y in range(8):
                corners = wv[x : x + 2, y : y + 2]
                if corners.any():
                    any_water = True
                    if corners.all():
                        cell_water[x, y] = WaterType.ENTIRELY_WATER
                    else:
                        cell_water[x, y] = WaterType.PARTIALLY_WATER
                        all_flooded = False
                else:
                    all_flooded = False
        self.cell_water = cell_water
        if not any_water:
            self.water_type = WaterType.NOT_WATER
        elif all_flooded:
            self.water_type = WaterType.ENTIRELY_WATER
        else:
            self.water_type = WaterType.PARTIALLY_WATER

    def _build_triangles(self) -> None:
        lx, ly = blockid_to_lcoord(self.landblock_id << 16)
        z = self.z
        tris: list[tuple[TerrainTriangle, TerrainTriangle]] = []
        split = np.zeros((8, 8), dtype=bool)
        for x in range(8):
            for y in range(8):
                v00 = Vec3(x * CELL_LENGTH, y * CELL_LENGTH, float(z[x, y]))
                v10 = Vec3((x + 1) * CELL_LENGTH, y * CELL_LENGTH, float(z[x + 1, y]))
                v01 = Vec3(x * CELL_LENGTH, (y + 1) * CELL_LENGTH, float(z[x, y + 1]))
                v11 = Vec3((x + 1) * CELL_LENGTH, (y + 1) * CELL_LENGTH, float(z[x + 1, y + 1]))
                if split_sw_to_ne(lx + x, ly + y):
                    split[x, y] = True
                    tris.append((TerrainTriangle(v00, v10, v11), TerrainTriangle(v00, v11, v01)))
                else:
                    tris.append((TerrainTriangle(v00, v10, v01), TerrainTriangle(v11, v01, v10)))
        self.triangles = tris
        self.split = split

    # -- queries ------------------------------------------------------------
    def cell_triangles(self, cx: int, cy: int) -> tuple[TerrainTriangle, TerrainTriangle]:
        return self.triangles[cx * 8 + cy]

    def find_terrain_poly(self, x: float, y: float) -> TerrainTriangle | None:
        """The triangle under landblock-local (x, y), or None off the block."""
        if not (0.0 <= x <= BLOCK_LENGTH and 0.0 <= y <= BLOCK_LENGTH):
            return None
        cx = min(int(x // CELL_LENGTH), 7)
        cy = min(int(y // CELL_LENGTH), 7)
        p = Vec3(x, y, 0.0)
        for tri in self.triangles[cx * 8 + cy]:
            if tri.point_in_poly_2d(p):
                return tri
        return None

    def height_at(self, x: float, y: float) -> float:
        """Terrain z under landblock-local (x, y)."""
        tri = self.find_terrain_poly(x, y)
        if tri is None:
            raise ValueError(f"point ({x}, {y}) is outside landblock {self.landblock_id:04X}")
        return tri.height_at(x, y)

    def normal_at(self, x: float, y: float) -> Vec3:
        tri = self.find_terrain_poly(x, y)
        if tri is None:
            raise ValueError(f"point ({x}, {y}) is outside landblock {self.landblock_id:04X}")
        return tri.plane.normal

    def calc_water_depth(self, cell_id: int, point: Vec3) -> float:
        """Depth in a partially flooded cell: deeper by a water corner
        (LandblockStruct.calc_water_depth: the corner of the cell's quadrant)."""
        index = (cell_id & 0xFFFF) - 1
        vx = index // 8
        vy = index % 8
        # fmod(c, CELL_LENGTH) >= 12: for c >= 0 Python's % is that same remainder (a native float
        # operation compiled, where math.fmod is a call by name); for c < 0 fmod's is negative
        x = point.x
        y = point.y
        if x >= 0.0 and x % CELL_LENGTH >= 12.0:
            vx += 1
        if y >= 0.0 and y % CELL_LENGTH >= 12.0:
            vy += 1
        return PARTIAL_WATER_DEPTH if self.water_flags[vx * 9 + vy] else SHORE_DEPTH

    def cell_position(self, cx: int, cy: int) -> Position:
        """Where the client places a LandCell: the centre of its 24 m square."""
        cell_id = (self.landblock_id << 16) | (cx * 8 + cy + 1)
        return Position(cell_id, Frame(Vec3(cx * CELL_LENGTH + 12.0, cy * CELL_LENGTH + 12.0, 0.0)))
