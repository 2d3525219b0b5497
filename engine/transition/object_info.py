"""ObjectInfo: the moving object's flags and step heights for one transition."""

from __future__ import annotations

from typing import Any

from ..constants import FLOOR_Z, LANDING_Z, STEP_DOWN_PROBE
from ..geometry import Vec3
from .state import OI
from .._compat import mypyc_attr

__all__ = ["ObjectInfo", "is_valid_walkable"]


def is_valid_walkable(normal: Vec3) -> bool:
    """A surface a grounded object may stand on (PhysicsObj.is_valid_walkable)."""
    return normal.z >= FLOOR_Z


@mypyc_attr(acyclic=True, free_list_len=1)
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
        "ignore_movers",
    )

    def __init__(self, state: int = 0, obj: Any = None) -> None:
        """A plain object: unscaled, no step heights, stepping down, falling.
        The object's own values are set by its maker (Mover.object_info)."""
        self.obj = obj
        self.state = state
        self.target_id = 0
        self.walkable_z = FLOOR_Z
        self.scale = 1.0
        self.step_up_height = 0.0
        self.step_down_height = 0.0
        self.ethereal = False
        self.step_down = True
        # standing in for the live Missile state when there is no mover behind us
        self.missile = False
        self.gravity = True
        # other movers are not obstacles (a navigation probe's default: engine.navigation)
        self.ignore_movers = False

    def get_walkable_z(self) -> float:
        """PhysicsObj.get_walkable_z: FloorZ for every object the client moves."""
        return self.walkable_z

    def step_search(self, walkable_step_height: float) -> tuple[float, float]:
        """The walkable z and the height of a step search (StepUp, and the
        step down of TransitionalInsert): on a walkable, the object's walkable
        z and `walkable_step_height` (its step-up or step-down height); else
        LandingZ and a probe just under 4 cm."""
        if self.state & OI.ON_WALKABLE:
            return self.get_walkable_z(), walkable_step_height
        return LANDING_Z, STEP_DOWN_PROBE

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
