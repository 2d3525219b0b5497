"""LandCell: a 24 m outdoor cell of terrain (two triangles), maybe with a building."""

from __future__ import annotations

import math
from typing import Final, TYPE_CHECKING

from ..constants import BLOCK_LENGTH, CELL_LENGTH, EPSILON, LAND_LENGTH
from ..geometry import ZERO, Position, Sphere, Vec3
from ..geometry.landdefs import adjust_to_outside, cell_in_range, get_block_offset
from ..terrain.triangle import TerrainTriangle
from ..terrain.water import WaterType
from ..transition.state import OI, TransitionState
from .landscape import Landscape
from .obj_cell import ObjCell

if TYPE_CHECKING:
    from ..transition.sphere_path import SpherePath
    from ..transition.transition import Transition
    from ..transition.interface import CellLookup
    from .building import BuildingObj
    from .cell_array import CellArray

__all__ = ["LandCell", "add_all_outside_cells", "outdoor_cell_id_at_lcoord"]

#: slack of the quick square test; far above rounding, far below anything real
_MARGIN: Final = 1e-3


def outdoor_cell_id_at_lcoord(x: int, y: int) -> int:
    """Cell id of the outdoor cell at world cell coordinates (x, y)."""
    return ((((x >> 3) << 8) | (y >> 3)) << 16) | ((x & 7) * 8 + (y & 7) + 1)


class LandCell(ObjCell):
    """The client's CLandCell (a SortCell: it may carry one building)."""

    __slots__ = ("polygons", "building", "x0", "y0")

    def __init__(self, cell_id: int, pos: Position, polygons: tuple[TerrainTriangle, TerrainTriangle]) -> None:
        super().__init__(cell_id, pos)
        self.polygons = polygons
        self.building: BuildingObj | None = None
        # the south-west corner of the cell's square, landblock-local
        self.x0 = pos.frame.origin.x - CELL_LENGTH * 0.5
        self.y0 = pos.frame.origin.y - CELL_LENGTH * 0.5

    def find_collisions(self, transition: Transition) -> int:
        """Terrain first, then the building, then objects (LandCell.FindCollisions)."""
        state = self.find_env_collisions(transition)
        if state == TransitionState.OK:
            building = self.building
            if building is not None:
                state = building.find_building_collisions(transition)
            if state == TransitionState.OK and self.shadow_objects:
                state = self.find_obj_collisions(transition)
        return state

    def find_terrain_poly(self, point: Vec3, quick: bool = True) -> TerrainTriangle | None:
        """The triangle under a landblock-local point, if it is over this cell.

        With `quick`, a point clearly outside the cell's square is refused
        before the triangle tests (which would refuse it too)."""
        x0 = self.x0
        y0 = self.y0
        if quick and (
            point.x < x0 - _MARGIN or point.x > x0 + CELL_LENGTH + _MARGIN or point.y < y0 - _MARGIN or point.y > y0 + CELL_LENGTH + _MARGIN
        ):
            return None
        # the two triangles unpacked, not looped over: compiled, a loop over the native pair boxes it
        # into a new tuple every call
        first, second = self.polygons
        if first.point_in_poly_2d(point):
            return first
        if second.point_in_poly_2d(point):
            return second
        return None

    def find_env_collisions(self, transition: Transition) -> int:
        """Collide the path's foot sphere with the terrain (LandCell.FindEnvCollisions)."""
        if self.restriction is not None and (refused := self.check_entry_restrictions(transition)) != TransitionState.OK:
            return refused
        path = transition.sphere_path
        block_offset = get_block_offset(path.check_pos.cell_id, self.id)
        same_block = block_offset is ZERO  # nothing to take off (most cells)
        local_point = path.global_low_point if same_block else path.global_low_point - block_offset
        walkable = self.find_terrain_poly(local_point, transition.settings.skip_far_cells)
        if walkable is None:
            return TransitionState.OK

        obj_info = transition.object_info
        if (
            self.landblock is not None
            and self.landblock.water_type == WaterType.ENTIRELY_WATER
            and not obj_info.state & OI.IS_VIEWER
            and not obj_info.is_missile()
        ):
            return TransitionState.COLLIDED

        water_depth = self.get_water_depth(local_point)
        g = path.global_sphere[0]
        # validate_walkable only reads the sphere (before it moves the check position): the path's own
        # foot sphere serves when it is already in this cell's landblock
        check_sphere = g if same_block else Sphere(g.center - block_offset, g.radius)
        return transition.validate_walkable(
            check_sphere, walkable.plane_at(transition.single_precision), self.water_type != WaterType.NOT_WATER, water_depth, self.id
        )

    def point_in_cell(self, point: Vec3) -> bool:
        return self.find_terrain_poly(point) is not None

    def find_transit_cells(
        self, position: Position, num_sphere: int, spheres: list[Sphere], cell_array: CellArray, path: SpherePath | None
    ) -> None:
        """Outdoor neighbours, then whatever the building lets the spheres reach."""
        add_all_outside_cells(cell_array.world, position, num_sphere, spheres, cell_array)
        if self.building is not None:
            self.building.find_building_transit_cells(position, num_sphere, spheres, cell_array, path)


def _add_outside_cell(cell_array: CellArray, x: int, y: int) -> None:
    if 0 <= x < LAND_LENGTH and 0 <= y < LAND_LENGTH:
        cell_id = outdoor_cell_id_at_lcoord(x, y)
        if cell_id in cell_array:
            return  # (add_cell would keep the one there: no lookup needed)
        cell = cell_array.landcell(cell_id)
        if cell is not None:
            cell_array.add_cell(cell_id, cell)


def add_all_outside_cells(
    world: CellLookup, position: Position, num_sphere: int, spheres: list[Sphere], cell_array: CellArray
) -> None:
    """Add the outdoor cells under each sphere and those its radius reaches into
    (LandCell.add_all_outside_cells with check_add_cell_boundary).

    The sphere centres are in the frame of `position`'s landblock; a centre
    past the landblock's edge lands in the neighbouring landblock's cells.
    """
    if cell_array.added_outside or cell_array.outside_searched:
        return
    landscape = world if isinstance(world, Landscape) else None
    cell_id = position.cell_id
    if num_sphere == 0:
        cell_id, _ = adjust_to_outside(cell_id, position.frame.origin)
        if cell_id:
            x, y = _lcoord(cell_id)
            _add_outside_cell(cell_array, x, y)
        return
    if not cell_in_range(cell_id & 0xFFFF):
        return
    block_x = ((cell_id >> 24) & 0xFF) << 3
    block_y = ((cell_id >> 16) & 0xFF) << 3
    settings = landscape.settings if landscape is not None else getattr(world, "settings", None)
    dedupe = settings is None or settings.skip_repeat_spheres
    # the same spheres add the same cells again later in this search
    cell_array.outside_searched = settings is None or settings.skip_repeat_outside
    last_x = last_y = last_r = math.nan
    # by index, as spheres[:num_sphere] would give them (no new list)
    for i in range(num_sphere if num_sphere < len(spheres) else len(spheres)):
        sphere = spheres[i]
        c = sphere.center
        cx = c.x
        cy = c.y
        if dedupe and cx == last_x and cy == last_y and sphere.radius == last_r:
            continue  # an upright mover's head sphere: the same cells again
        last_x = cx
        last_y = cy
        last_r = sphere.radius
        if -EPSILON < cx < EPSILON:
            cx = 0.0
        if -EPSILON < cy < EPSILON:
            cy = 0.0
        fx = math.floor(cx / CELL_LENGTH)
        fy = math.floor(cy / CELL_LENGTH)
        x = block_x + fx
        y = block_y + fy
        if x < 0 or y < 0 or x >= LAND_LENGTH or y >= LAND_LENGTH:
            break
        if 0.0 <= cx < BLOCK_LENGTH and 0.0 <= cy < BLOCK_LENGTH:
            px = cx - fx * CELL_LENGTH
            py = cy - fy * CELL_LENGTH
        else:  # re-homed into the neighbouring landblock first, as the client does
            cx -= math.floor(cx / BLOCK_LENGTH) * BLOCK_LENGTH
            cy -= math.floor(cy / BLOCK_LENGTH) * BLOCK_LENGTH
            px = cx - math.floor(cx / CELL_LENGTH) * CELL_LENGTH
            py = cy - math.floor(cy / CELL_LENGTH) * CELL_LENGTH
        min_rad = sphere.radius
        max_rad = CELL_LENGTH - min_rad
        _add_outside_cell(cell_array, x, y)
        if px > max_rad:
            _add_outside_cell(cell_array, x + 1, y)
            if py > max_rad:
                _add_outside_cell(cell_array, x + 1, y + 1)
            if py < min_rad:
                _add_outside_cell(cell_array, x + 1, y - 1)
        if px < min_rad:
            _add_outside_cell(cell_array, x - 1, y)
            if py > max_rad:
                _add_outside_cell(cell_array, x - 1, y + 1)
            if py < min_rad:
                _add_outside_cell(cell_array, x - 1, y - 1)
        if py > max_rad:
            _add_outside_cell(cell_array, x, y + 1)
        if py < min_rad:
            _add_outside_cell(cell_array, x, y - 1)


def _lcoord(cell_id: int) -> tuple[int, int]:
    """World cell coordinates of an outdoor cell id (LandDefs.gid_to_lcoord)."""
    index = (cell_id & 0xFFFF) - 1
    return ((cell_id >> 24) & 0xFF) * 8 + (index >> 3), ((cell_id >> 16) & 0xFF) * 8 + (index & 7)
