"""CollisionInfo: what a transition learned about contacts and collisions."""

from __future__ import annotations

from typing import Any, Final

from ..geometry import Plane, Vec3, ZERO
from .._compat import mypyc_attr

__all__ = ["CollisionInfo", "NO_PLANE"]

#: the plane of a CollisionInfo that has none yet (planes are values, never changed in place: one serves all)
NO_PLANE: Final = Plane(ZERO, 0.0)


@mypyc_attr(acyclic=True)
class CollisionInfo:
    """Accumulated results of one transition (the client's COLLISIONINFO).

    `ace_normals` reproduces the reference port's storage of collision and
    sliding normals: un-normalised, as given. The retail client stores unit
    vectors.
    """

    __slots__ = (
        "contact_plane_valid",
        "contact_plane",
        "contact_plane_cell_id",
        "contact_plane_is_water",
        "last_known_contact_plane_valid",
        "last_known_contact_plane",
        "last_known_contact_plane_cell_id",
        "last_known_contact_plane_is_water",
        "sliding_normal_valid",
        "sliding_normal",
        "collision_normal_valid",
        "collision_normal",
        "adjust_offset",
        "collide_object",
        "last_collided_object",
        "collided_with_environment",
        "frames_stationary_fall",
        "ace_normals",
    )

    def __init__(self, ace_normals: bool = False) -> None:
        self.collide_object: list[Any] = []
        self.reset(ace_normals)

    def reset(self, ace_normals: bool) -> None:
        """The state of a new transition's CollisionInfo (Transition.reset)."""
        self.contact_plane_valid = False
        self.contact_plane = NO_PLANE
        self.contact_plane_cell_id = 0
        self.contact_plane_is_water = False
        self.last_known_contact_plane_valid = False
        self.last_known_contact_plane = NO_PLANE
        self.last_known_contact_plane_cell_id = 0
        self.last_known_contact_plane_is_water = False
        self.sliding_normal_valid = False
        self.sliding_normal = ZERO
        self.collision_normal_valid = False
        self.collision_normal = ZERO
        self.adjust_offset = ZERO
        if self.collide_object:
            self.collide_object = []  # (a new list: the last move's result may still read the old one)
        self.last_collided_object: Any = None
        self.collided_with_environment = False
        self.frames_stationary_fall = 0
        self.ace_normals = ace_normals

    def reset_collide_objects(self) -> None:
        """The part of CollisionInfo.Init a failed placement step redoes."""
        self.collide_object = []

    def set_contact_plane(self, plane: Plane, is_water: bool) -> None:
        self.contact_plane_valid = True
        self.contact_plane = plane
        self.contact_plane_is_water = is_water

    def set_collision_normal(self, normal: Vec3) -> None:
        """Record a collision normal; a (near-)zero one is stored as zero.
        Decompiled client: FUN_004524a0 (the seed, transition_pseudocode.md)."""
        self.collision_normal_valid = True
        unit = normal.normalized_or_none()
        if unit is None:
            self.collision_normal = ZERO
        else:
            self.collision_normal = normal if self.ace_normals else unit

    def set_sliding_normal(self, normal: Vec3) -> None:
        """Record the horizontal part of a normal as the sliding normal.

        Retail keeps the unit horizontal direction. The reference port keeps
        (nx, ny, 0) as given and only zeroes it when the full normal is tiny.
        """
        self.sliding_normal_valid = True
        flat = Vec3(normal.x, normal.y, 0.0)
        if self.ace_normals:
            self.sliding_normal = ZERO if normal.normalized_or_none() is None else flat
        else:
            self.sliding_normal = flat.normalized_or_none() or ZERO

    def add_object(self, obj: Any, state: int) -> None:
        """Remember an object the mover touched (CollisionInfo.AddObject)."""
        if obj in self.collide_object:
            return
        self.collide_object.append(obj)
        if state != 1:  # anything but OK
            self.last_collided_object = obj
