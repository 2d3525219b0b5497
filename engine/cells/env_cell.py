"""EnvCell: an indoor cell: a placed CellStruct, portals, and a stab list."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Final, TYPE_CHECKING

from ..constants import EPSILON
from ..bsp.node import BoundingType
from ..geometry import Position, Sphere, Vec3
from ..transition.state import OI, InsertType, TransitionState
from .cell_struct import CellStruct
from .land_cell import add_all_outside_cells
from .obj_cell import ObjCell

if TYPE_CHECKING:
    from ..transition.sphere_path import SpherePath
    from ..transition.transition import Transition
    from .cell_array import CellArray

__all__ = ["EnvCell", "CellPortal"]

OUTSIDE_CELL: Final = 0xFFFF


@dataclass(frozen=True, slots=True)
class CellPortal:
    """A doorway of an EnvCell: which polygon, and what lies behind it."""

    flags: int
    polygon_id: int
    other_cell_id: int  # 16-bit; 0xFFFF = outside
    other_portal_id: int

    @property
    def portal_side(self) -> bool:
        """True when the other cell lies in front of the portal polygon (flag 0x2 clear)."""
        return not self.flags & 0x2


class EnvCell(ObjCell):
    """The client's CEnvCell. `pos` places the cell in its landblock."""

    __slots__ = ("cell_struct", "portals", "visible_ids16", "visible_cells", "visible_cell_ids", "seen_outside", "environment_id")

    def __init__(
        self,
        cell_id: int,
        pos: Position,
        cell_struct: CellStruct,
        portals: list[CellPortal],
        visible_ids16: list[int],
        seen_outside: bool = False,
        environment_id: int = 0,
    ) -> None:
        super().__init__(cell_id, pos)
        self.cell_struct = cell_struct
        self.portals = portals
        self.visible_ids16 = visible_ids16
        self.seen_outside = seen_outside
        self.environment_id = environment_id
        #: stab list: 16-bit id -> EnvCell (None when not loaded)
        self.visible_cells: dict[int, EnvCell | None] = {}
        #: full ids of the loaded cells of the stab list
        self.visible_cell_ids: frozenset[int] = frozenset()

    def build_visible_cells(self, lookup: Any) -> None:
        """Resolve the stab list once every cell of the landblock exists."""
        block = self.id & 0xFFFF0000
        cells: dict[int, EnvCell | None] = {}
        for vid in self.visible_ids16:
            if vid in cells:
                continue
            cells[vid] = lookup(block | vid)
        self.visible_cells = cells
        self.visible_cell_ids = frozenset(c.id for c in cells.values() if c is not None)

    def get_visible(self, cell_id16: int) -> EnvCell | None:
        return self.visible_cells.get(cell_id16)

    # -- collisions -----------------------------------------------------------
    def find_collisions(self, transition: Transition) -> int:
        state = self.find_env_collisions(transition)
        if state == TransitionState.OK and self.shadow_objects:
            state = self.find_obj_collisions(transition)
        return state

    def find_env_collisions(self, transition: Transition) -> int:
        """Collide with the cell's physics BSP in cell space (EnvCell.FindEnvCollisions)."""
        if self.restriction is not None and (refused := self.check_entry_restrictions(transition)) != TransitionState.OK:
            return refused
        path = transition.sphere_path
        path.obstruction_ethereal = False
        bsp = self.cell_struct.physics_bsp
        if bsp is None:
            return TransitionState.OK
        path.cache_local_space_sphere(self.pos, 1.0)
        if path.insert_type == InsertType.INITIAL_PLACEMENT:
            state = bsp.placement_insert(transition)
        else:
            state = bsp.find_collisions(transition, 1.0)
        if state != TransitionState.OK and not transition.object_info.state & OI.CONTACT:
            transition.collision_info.collided_with_environment = True
        return state

    # -- membership ---------------------------------------------------------------
    def point_in_cell(self, point: Vec3) -> bool:
        return self.cell_struct.point_in_cell(self.pos.frame.global_to_local(point))

    def find_transit_cells(
        self, position: Position, num_sphere: int, spheres: list[Sphere], cell_array: CellArray, path: SpherePath | None
    ) -> None:
        """Neighbour cells the spheres reach through this cell's portals
        (EnvCell.find_transit_cells, sphere variant)."""
        check_outside = False
        frame = self.pos.frame
        polygons = self.cell_struct.polygons
        count = min(num_sphere, len(spheres))
        # the spheres' centres in this cell's frame, computed once (for the portals to
        # the outside and to cells that are not loaded)
        local_centers: list[Vec3] | None = None
        for portal in self.portals:
            plane = polygons[portal.polygon_id].plane
            if portal.other_cell_id == OUTSIDE_CELL:
                if local_centers is None:
                    local_centers = [frame.global_to_local(spheres[i].center) for i in range(count)]
                for i in range(count):
                    rad = spheres[i].radius + EPSILON
                    dist = plane.distance(local_centers[i])
                    if -rad < dist < rad:
                        check_outside = True
                        break
                continue
            other = self.visible_cells.get(portal.other_cell_id)
            if other is not None:
                other_frame = other.pos.frame
                other_struct = other.cell_struct
                for i in range(count):
                    sphere = spheres[i]
                    local = Sphere(other_frame.global_to_local(sphere.center), sphere.radius)
                    if other_struct.sphere_intersects_cell(local) != BoundingType.OUTSIDE:
                        cell_array.add_cell(other.id, other)
                        break
            else:
                if local_centers is None:
                    local_centers = [frame.global_to_local(spheres[i].center) for i in range(count)]
                portal_side = portal.portal_side
                for i in range(count):
                    rad = spheres[i].radius + EPSILON
                    dist = plane.distance(local_centers[i])
                    if (dist > -rad and portal_side) or (dist < rad and not portal_side):
                        # a neighbour that is not loaded: the client records the id with no cell
                        cell_array.add_cell((self.id & 0xFFFF0000) | portal.other_cell_id, None)
                        break
        if check_outside:
            add_all_outside_cells(cell_array.world, position, num_sphere, spheres, cell_array)

    def check_building_transit(
        self, portal_id: int, position: Position, num_sphere: int, spheres: list[Sphere], cell_array: CellArray, path: SpherePath | None
    ) -> None:
        """Add this cell when a sphere outside reaches into it through a building's
        door (EnvCell.check_building_transit)."""
        if portal_id == 0xFFFF:
            return
        frame = self.pos.frame
        for i in range(min(num_sphere, len(spheres))):
            sphere = spheres[i]
            local = Sphere(frame.global_to_local(sphere.center), sphere.radius)
            if self.cell_struct.sphere_intersects_cell(local) == BoundingType.OUTSIDE:
                continue
            if path is not None:
                path.hits_interior_cell = True
            cell_array.add_cell(self.id, self)
