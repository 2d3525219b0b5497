"""Obstacles: the objects a mover collides with (the obstacle side of the
client's CPhysicsObj, ACE `PhysicsObj.FindObjCollisions`).

An `Obstacle` is a static object (a rock, a pillar, a house's props) or a
live one seen by other movers. A cell holds it in `cell.shadow_objects`;
`ObjCell.find_obj_collisions` calls `obstacle.find_obj_collisions(t)` on each
entry, newest first.

Its collision shape, as the reference chooses it: the parts' physics BSPs
if any part has one, else its cylspheres, else its spheres (scaled by
`scale`). `MoverObstacle` shows a live `engine.world.mover.Mover` to the
others through the same code.
"""

from __future__ import annotations

from typing import Any, Final, TYPE_CHECKING
from collections.abc import Sequence

from ..geometry import ZERO, Position, Sphere
from ..geometry.precision import fl, fl_add, fl_place
from ..geometry.landdefs import get_block_offset
from ..transition.state import OI, TransitionState
from .cylsphere_collision import CylSphere
from .gfx_obj import PhysicsPart
from .sphere_collision import intersects_sphere

if TYPE_CHECKING:
    from ..transition.object_info import ObjectInfo
    from ..transition.transition import Transition
    from ..world.mover import Mover  # (typed for mypyc: its fields are then read natively, every test)

__all__ = ["Obstacle", "MoverObstacle", "find_obj_collisions", "missile_ignore"]

_OK: Final = TransitionState.OK


class Obstacle:
    """A static or dynamic object others collide with.

    Shape: `spheres` and `cyl_spheres` in the object's frame (unscaled),
    `parts` (PhysicsParts, see `engine.objects.setup.Setup.make_parts`),
    `scale`. Placement: `position` (rebind it to move the object; the parts
    follow, placed again before the next test).

    Flags, as an obstacle: `static` (PhysicsState.Static: a landblock object);
    `ethereal`, `ignore_collisions` (ethereal and ignore-collisions together:
    nothing collides); `missile` (its live Missile state);
    `projectile_target_id` (the id a missile obstacle is aimed at, 0 none).
    Weenie properties, only read when `dat_object` is False (a dat object has
    no weenie: static landblock objects): `is_player`, `is_creature`,
    `is_pk`, `is_pk_lite`, `is_impenetrable`.

    `owner` is the physics object the collision records name (what goes into
    CollisionInfo.collide_object); None means the obstacle itself.
    """

    __slots__ = (
        "id",
        "position",
        "scale",
        "spheres",
        "cyl_spheres",
        "parts",
        "static",
        "ethereal",
        "ignore_collisions",
        "missile",
        "projectile_target_id",
        "dat_object",
        "is_player",
        "is_creature",
        "is_pk",
        "is_pk_lite",
        "is_impenetrable",
        "owner",
        "_has_physics_bsp",
        "_parts_placed_at",
        "_parts_placed_scale",
        "_sphere_cache_pos",
        "_sphere_cache_scale",
        "_sphere_cache_single",
        "_placed_spheres",
    )

    def __init__(
        self,
        obj_id: int,
        position: Position,
        *,
        spheres: Sequence[Sphere] = (),
        cyl_spheres: Sequence[CylSphere] = (),
        parts: Sequence[PhysicsPart] = (),
        scale: float = 1.0,
        static: bool = True,
        ethereal: bool = False,
        ignore_collisions: bool = False,
        missile: bool = False,
        projectile_target_id: int = 0,
        dat_object: bool | None = None,
        is_player: bool = False,
        is_creature: bool = False,
        is_pk: bool = False,
        is_pk_lite: bool = False,
        is_impenetrable: bool = False,
        owner: Any = None,
    ) -> None:
        self.id = obj_id
        self.position = position
        self.scale = scale
        self.spheres = list(spheres)
        self.cyl_spheres = list(cyl_spheres)
        self.parts = list(parts)
        self.static = static
        self.ethereal = ethereal
        self.ignore_collisions = ignore_collisions
        self.missile = missile
        self.projectile_target_id = projectile_target_id
        self.dat_object = static if dat_object is None else dat_object
        self.is_player = is_player
        self.is_creature = is_creature
        self.is_pk = is_pk
        self.is_pk_lite = is_pk_lite
        self.is_impenetrable = is_impenetrable
        self.owner = owner
        self._has_physics_bsp = any(p.gfx_obj.physics_bsp is not None for p in self.parts)
        self._parts_placed_at: Position | None = None
        self._parts_placed_scale = 0.0
        self._sphere_cache_pos: Position | None = None
        self._sphere_cache_scale = 0.0
        self._sphere_cache_single = False
        self._placed_spheres: list[Sphere] = []

    def __repr__(self) -> str:
        return f"Obstacle({self.id:#x}, {self.position!r})"

    @property
    def has_physics_bsp(self) -> bool:
        """PhysicsState.HasPhysicsBSP: some part has a physics BSP."""
        return self._has_physics_bsp

    def place_parts(self) -> None:
        """Place the parts at the obstacle's current position and scale
        (CPartArray::UpdateParts; kept while the same Position object and
        scale stand: Positions are immutable)."""
        if self._parts_placed_at is not self.position or self._parts_placed_scale != self.scale:
            for part in self.parts:
                part.place(self.position, self.scale)
            self._parts_placed_at = self.position
            self._parts_placed_scale = self.scale

    def placed_spheres(self, single: bool) -> list[Sphere]:
        """The spheres scaled and placed by `position`, in its landblock's
        frame (the part of Sphere.IntersectsSphere(Position, scale) that does
        not depend on the mover; kept until the obstacle moves), at the
        working precision (`single`: the client's single precision)."""
        if (
            self._sphere_cache_pos is not self.position
            or self._sphere_cache_scale != self.scale
            or self._sphere_cache_single != single
        ):
            pos = self.position
            scale = self.scale
            f = fl(scale, single)
            self._placed_spheres = [
                Sphere(fl_place(pos.cell_id, pos, s.center, f, single), fl(fl(s.radius, single) * f, single)) for s in self.spheres
            ]
            self._sphere_cache_pos = self.position
            self._sphere_cache_scale = self.scale
            self._sphere_cache_single = single
        return self._placed_spheres

    def find_obj_collisions(self, transition: Transition) -> int:
        """PhysicsObj.FindObjCollisions: see `find_obj_collisions`."""
        return find_obj_collisions(self, transition)


class MoverObstacle(Obstacle):
    """A live Mover as the others see it: its id, position, scale and flags
    are read from the mover at every test.

    Shape (formats README): its cylspheres if it has any, else its spheres,
    both scaled by its scale; never BSP parts. Weenie flags: IsPlayer, IsPK,
    IsPKLite, IsImpenetrable from its ObjectInfo flags, creature from
    `mover.creature`. It never collides with its own mover.
    """

    __slots__ = ("mover",)

    def __init__(self, mover: Mover) -> None:
        cyl = [c if isinstance(c, CylSphere) else CylSphere.from_spec(c) for c in (mover.cyl_spheres or ())]
        super().__init__(
            mover.id,
            mover.position,
            spheres=list(mover.spheres),
            cyl_spheres=cyl,
            scale=mover.scale,
            static=False,
            dat_object=False,
            owner=mover,
        )
        self.mover: Mover = mover
        self.refresh()

    def refresh(self) -> None:
        """Copy the mover's live position and flags (done before every test)."""
        m = self.mover
        self.id = m.id
        self.position = m.position
        self.scale = m.scale
        self.ethereal = bool(m.ethereal)
        self.missile = bool(m.missile)
        flags = m.oi_flags
        self.is_player = bool(flags & OI.IS_PLAYER)
        self.is_pk = bool(flags & OI.IS_PK)
        self.is_pk_lite = bool(flags & OI.IS_PK_LITE)
        self.is_impenetrable = bool(flags & OI.IS_IMPENETRABLE)
        self.is_creature = bool(m.creature)

    def find_obj_collisions(self, transition: Transition) -> int:
        oi = transition.object_info
        if oi.obj is self.mover or oi.ignore_movers:
            return _OK
        self.refresh()
        return find_obj_collisions(self, transition)


def missile_ignore(oi: ObjectInfo, obstacle: Obstacle) -> bool:
    """Does the mover pass through this obstacle because one of them is a
    missile? (ObjectInfo.MissileIgnore, the reference's two-way form)

    A missile obstacle is ignored by every non-player, and by a player unless
    the missile has no target or targets that player. A missile mover
    ignores an obstacle with a weenie that is not its target when the
    obstacle is ethereal, or is a creature while the missile has a target.
    """
    if obstacle.missile:
        if not oi.state & OI.IS_PLAYER:
            return True
        target = obstacle.projectile_target_id
        mover = oi.obj
        if target == 0 or (mover is not None and target == getattr(mover, "id", None)):
            return False
        return True
    if oi.is_missile():
        if not obstacle.dat_object and obstacle.id != oi.target_id:
            if obstacle.ethereal or (oi.target_id != 0 and obstacle.is_creature):
                return True
    return False


def find_obj_collisions(obstacle: Obstacle, transition: Transition) -> int:
    """Collide the path with one obstacle (PhysicsObj.FindObjCollisions).

    - ethereal + ignore-collisions obstacles, and creatures seen by a viewer
      (camera), are never touched;
    - an ethereal obstacle, or any non-static one when the mover is ethereal,
      is an overlap test only (ethereal obstruction) and is skipped while
      stepping down;
    - players walk through players unless either is impenetrable or both are
      PK or both PK-lite ("exemption"); missiles pass what MissileIgnore
      says;
    - the shape tested is the BSP parts, else the cylspheres, else the
      spheres; the first one answering anything but OK decides.
    """
    path = transition.sphere_path
    oi = transition.object_info
    if obstacle.ethereal and obstacle.ignore_collisions:
        return _OK
    state = oi.state
    dat_object = obstacle.dat_object
    if not dat_object and state & OI.IS_VIEWER and obstacle.is_creature:
        return _OK

    ethereal = False
    if obstacle.ethereal or (not obstacle.static and oi.ethereal):
        if path.step_down:
            return _OK
        ethereal = True
    path.obstruction_ethereal = ethereal

    exemption = not (
        dat_object
        or not obstacle.is_player
        or not state & OI.IS_PLAYER
        or state & OI.IS_IMPENETRABLE
        or obstacle.is_impenetrable
        or (state & OI.IS_PK and obstacle.is_pk)
        or (state & OI.IS_PK_LITE and obstacle.is_pk_lite)
    )
    ignore = missile_ignore(oi, obstacle)
    is_creature = bool(obstacle.missile or (not dat_object and obstacle.is_creature))

    if not (ignore or exemption):
        if obstacle.has_physics_bsp:
            obstacle.place_parts()
            for part in obstacle.parts:
                result = part.find_obj_collisions(transition)
                if result != _OK:
                    return _respond(obstacle, transition, result, ethereal, is_creature)
        elif obstacle.cyl_spheres:
            pos = obstacle.position
            scale = obstacle.scale
            for cyl in obstacle.cyl_spheres:
                result = cyl.intersects_sphere_at(pos, scale, transition)
                if result != _OK:
                    return _respond(obstacle, transition, result, ethereal, is_creature)
        elif obstacle.spheres:
            # the obstacle's spheres placed in the check position's landblock
            offset = get_block_offset(path.check_pos.cell_id, obstacle.position.cell_id)
            single = transition.single_precision
            for placed in obstacle.placed_spheres(single):
                if offset is not ZERO:
                    placed = Sphere(fl_add(offset, placed.center, single), placed.radius)
                result = intersects_sphere(placed, transition, is_creature)
                if result != _OK:
                    return _respond(obstacle, transition, result, ethereal, is_creature)

    path.obstruction_ethereal = False
    return _OK


def _respond(obstacle: Obstacle, transition: Transition, result: int, ethereal: bool, is_creature: bool) -> int:
    """Record the collision (PhysicsObj.FindObjCollisions_Inner).

    Outside step-down: a static obstacle only marks an environment collision
    for a mover not in contact; an ethereal obstacle, or a creature when the
    mover ignores creatures, is recorded as touched and the result becomes
    OK with the collision normal invalidated; anything else is recorded with
    the result.
    """
    path = transition.sphere_path
    if not path.step_down:
        ci = transition.collision_info
        oi = transition.object_info
        if obstacle.static:
            if not oi.state & OI.CONTACT:
                ci.collided_with_environment = True
        else:
            owner = obstacle.owner if obstacle.owner is not None else obstacle
            if ethereal or (is_creature and oi.state & OI.IGNORE_CREATURES):
                result = _OK
                ci.collision_normal_valid = False
                ci.add_object(owner, _OK)
            else:
                ci.add_object(owner, result)
    path.obstruction_ethereal = False
    return result
