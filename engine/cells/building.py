"""A building: an outer shell (physics BSP part) on a LandCell, with doors into EnvCells."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..geometry import Position, Sphere
from ..transition.state import OI, TransitionState
from .env_cell import EnvCell

if TYPE_CHECKING:
    from ..objects.gfx_obj import PhysicsPart
    from .land_cell import LandCell
    from ..transition.sphere_path import SpherePath
    from ..transition.transition import Transition
    from .cell_array import CellArray

__all__ = ["BuildingObj", "BldPortal"]


@dataclass(frozen=True, slots=True)
class BldPortal:
    """A door of a building into one of its EnvCells."""

    flags: int
    other_cell_id: int  # 16-bit EnvCell id behind the door
    other_portal_id: int
    stab_list: tuple[int, ...] = ()


class BuildingObj:
    """The client's CBuildingObj: attached to the LandCell holding its origin."""

    __slots__ = ("id", "parts", "portals", "cell", "num_leaves")

    def __init__(self, model_id: int, parts: list[PhysicsPart], portals: list[BldPortal], num_leaves: int = 0) -> None:
        self.id = model_id
        self.parts = parts
        self.portals = portals
        self.cell: LandCell | None = None
        self.num_leaves = num_leaves

    def find_building_collisions(self, transition: Transition) -> int:
        """Collide with the shell, part 0 only, with the building check on."""
        if not self.parts:
            return TransitionState.OK
        path = transition.sphere_path
        path.building_check = True
        state = self.parts[0].find_obj_collisions(transition)
        path.building_check = False
        if state != TransitionState.OK and not transition.object_info.state & OI.CONTACT:
            transition.collision_info.collided_with_environment = True
        return state

    def find_building_transit_cells(
        self, position: Position, num_sphere: int, spheres: list[Sphere], cell_array: CellArray, path: SpherePath | None
    ) -> None:
        """EnvCells behind the doors that the spheres reach into."""
        cell = self.cell
        assert cell is not None  # set when the loader attaches the building to its cell
        block = cell.id & 0xFFFF0000
        world = cell_array.world
        for portal in self.portals:
            other = world.get_landcell(block | portal.other_cell_id)
            if isinstance(other, EnvCell):  # a building's portals lead into EnvCells
                other.check_building_transit(portal.other_portal_id, position, num_sphere, spheres, cell_array, path)
