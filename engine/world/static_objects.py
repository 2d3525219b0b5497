"""Static objects of a landblock (LandblockInfo objects and EnvCell statics).

Each becomes an obstacle registered in the cells it occupies (ACE: a BSP or
sphere object in the cell holding its origin; a cylsphere object in every
cell a sphere of its radius at its low point touches). Cells test their
objects newest first.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Mapping

from ..geometry import Position
from ..geometry.landdefs import outdoor_cell_id
from ..transition.state import OI, TransitionState

if TYPE_CHECKING:
    from ..objects.gfx_obj import PhysicsPart
    from ..transition.transition import Transition
    from .indoor_loader import PortalCache

__all__ = ["StaticBSPObject", "attach_static_objects"]


class StaticBSPObject:
    """A static object whose shape is its parts' physics BSPs (a dat object:
    Static, HasPhysicsBSP, no weenie). PhysicsObj.FindObjCollisions, BSP branch."""

    __slots__ = ("id", "parts", "position", "ethereal")

    def __init__(self, model_id: int, parts: list[PhysicsPart], position: Position) -> None:
        self.id = 0  # dat objects carry no instance id
        self.parts = parts
        self.position = position
        self.ethereal = False

    def find_obj_collisions(self, transition: Transition) -> int:
        path = transition.sphere_path
        path.obstruction_ethereal = False
        for part in self.parts:
            state = part.find_obj_collisions(transition)
            if state != TransitionState.OK:
                if not path.step_down and not transition.object_info.state & OI.CONTACT:
                    transition.collision_info.collided_with_environment = True
                path.obstruction_ethereal = False
                return state
        path.obstruction_ethereal = False
        return TransitionState.OK


def _setup_has_bsp(cache: PortalCache, model_id: int) -> bool:
    if model_id >> 24 == 0x01:
        return cache.gfx_obj(model_id).physics_bsp is not None
    setup = cache.setup(model_id)
    return any(cache.gfx_obj(int(p, 16)).physics_bsp is not None for p in setup.get("parts", []))


def _make_object(cache: PortalCache, model_id: int, position: Position) -> Any:
    if _setup_has_bsp(cache, model_id):
        return StaticBSPObject(model_id, cache.parts_of(model_id, position.frame, position.cell_id), position)
    from ..objects.obstacle import Obstacle  # sphere and cylsphere shapes

    return Obstacle.static_from_setup(model_id, cache.setup(model_id), position)


def attach_static_objects(landblock: Any, lb_data: Mapping[str, Any], cache: PortalCache) -> None:
    """Create the landblock's static objects and register them in their cells."""
    from .indoor_loader import frame_from_dict

    for entry in lb_data.get("objects", []):
        model_id = int(entry["id"], 16)
        frame = frame_from_dict(entry.get("frame", {}))
        cell_id = outdoor_cell_id(landblock.id, frame.origin.x, frame.origin.y)
        obj = _make_object(cache, model_id, Position(cell_id, frame))
        _register(landblock, obj, cell_id)
        landblock.objects.append(obj)
    for ec in lb_data.get("env_cells", []):
        cell_id = int(ec["id"], 16)
        for entry in ec.get("static_objects", []):
            model_id = int(entry["id"], 16)
            frame = frame_from_dict(entry.get("frame", {}))
            obj = _make_object(cache, model_id, Position(cell_id, frame))
            _register(landblock, obj, cell_id)
            landblock.objects.append(obj)


def _register(landblock: Any, obj: Any, cell_id: int) -> None:
    cell = landblock.get_cell(cell_id)
    if cell is not None:
        cell.shadow_objects.append(obj)
