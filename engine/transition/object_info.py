"""ObjectInfo: the moving object's flags and step heights for one transition."""

from __future__ import annotations

from typing import Any

from ..constants import FLOOR_Z
from ..geometry import Vec3
from .state import OI

__all__ = ["ObjectInfo", "is_valid_walkable"]


def is_valid_walkable(normal: Vec3) -> bool:
    """A surface a grounded object may stand on (PhysicsObj.is_valid_walkable)."""
    return normal.z >= FLOOR_Z


class ObjectInfo:
    """The client's OBJECTINFO.

    `obj` is the mover behind the transition (anything with a `velocity`
    attribute, a `state` physics-state bit set and the obstacle properties the
    object collision code asks for); it may be None for a bare transition built
    by hand, in which case StopVelocity does nothing.
    """

    __slots__ = (
        "obj",
        "state",
        "scale",
        "step_up_height",
        "step_down_height",
        "ethereal",
        "step_down",
        "target_id",
        "walkable_z",
        "missile",
        "gravity",
    )

    def __init__(
        self,
        state: int = 0,
        *,
        obj: Any = None,
        scale: float = 1.0,
        step_up_height: float = 0.0,
        step_down_height: float = 0.0,
        ethereal: bool = False,
        step_down: bool = True,
        gravity: bool = True,
        walkable_z: float = FLOOR_Z,
    ) -> None:
        self.obj = obj
        self.state = state
        self.scale = scale
        self.step_up_height = step_up_height
        self.step_down_height = step_down_height
        self.ethereal = ethereal
        self.step_down = step_down
        self.target_id = 0
        self.walkable_z = walkable_z
        # standing in for the live Missile state when there is no mover behind us
        self.missile = not step_down
        self.gravity = gravity

    def get_walkable_z(self) -> float:
        """PhysicsObj.get_walkable_z: FloorZ for every object the client moves."""
        return self.walkable_z

    def is_valid_walkable(self, normal: Vec3) -> bool:
        return normal.z >= FLOOR_Z

    def stop_velocity(self) -> None:
        """Zero the mover's velocity (ObjectInfo.StopVelocity)."""
        obj = self.obj
        if obj is not None:
            obj.stop_velocity()

    def is_missile(self) -> bool:
        """The mover's live Missile physics state (a collision may clear it)."""
        obj = self.obj
        if obj is not None:
            return bool(obj.missile)
        return self.missile

    def has(self, flag: int) -> bool:
        return bool(self.state & flag)

    @property
    def is_viewer(self) -> bool:
        return bool(self.state & OI.IS_VIEWER)
