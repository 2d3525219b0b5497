"""Mover: the physics object a World moves (the part of PhysicsObj that moves).

It carries what the client's PhysicsObj carries from one transition to the
next: position and cell, contact plane and its cell, the transient flags
(Contact, OnWalkable, Sliding, WaterContact, Stationary*), the sliding normal
and the velocity collision responses act on.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Final

from ..constants import (
    DEFAULT_FRICTION,
    EPSILON,
    FLOOR_Z,
    GRAVITY,
    MAX_VELOCITY,
    MAX_VELOCITY_SQ,
    SLED_FAST_SPEED_SQ,
    SLED_SLOPE_FRICTION,
    SLED_SLOPE_NORMAL_Z,
    SLED_STOP_SPEED_SQ,
    ACE_SLED_FLAT_NORMAL_Z,
    SMALL_VELOCITY_SQ,
)
from ..geometry import UNIT_Z, ZERO, Frame, Plane, Position, Sphere, Vec3
from ..geometry.precision import fl, fl_dot, fl_plane, fl_rotate, fl_scale, fl_sub, fl_vec
from ..geometry.quaternion import Quat
from ..transition.object_info import ObjectInfo
from ..settings import RETAIL, EngineSettings
from ..transition.state import OI
from ..transition.sphere_path import ScaledSpheres
from ..transition.transition import Transition, take_transition
from .transient import TS
from .types import CylSphereSpec, MoveResult

if TYPE_CHECKING:
    from ..cells.broad_phase import ShapeBounds
    from ..cells.obj_cell import ObjCell
    from ..objects.obstacle import MoverObstacle
    from ..transition.interface import CellLookup


__all__ = ["Mover"]

DEFAULT_ELASTICITY: Final = 0.05

#: ObjectInfo flags that are properties of the object. Contact and OnWalkable
#: come from the transient state; PathClipped from the live Missile state.
_STATIC_OI: Final = ~(OI.CONTACT | OI.ON_WALKABLE | OI.PATH_CLIPPED)


class Mover:
    """A moving physics object."""

    __slots__ = (
        "id",
        "spheres",
        "cyl_spheres",
        "scale",
        "step_up_height",
        "step_down_height",
        "oi_flags",
        "gravity",
        "missile",
        "step_down",
        "ethereal",
        "creature",
        "sledding",
        "ignore_movers",
        "position",
        "cell",
        "transient",
        "contact_plane",
        "contact_plane_cell_id",
        "sliding_normal",
        "velocity",
        "acceleration",
        "elasticity",
        "friction",
        "shadow_cells",
        "obstacle",
        "broad_phase_bounds",
        "colliding_with_environment",
        "held_time",
        "held_motion",
        "scaled_spheres",
        "seq",
        "last",
        "__weakref__",
    )

    def __init__(
        self,
        mover_id: int,
        spheres: list[Sphere],
        *,
        oi_flags: int = 0,
        scale: float = 1.0,
        step_up_height: float = 0.4,
        step_down_height: float = 0.4,
        gravity: bool = True,
        missile: bool = False,
        step_down: bool = True,
        ethereal: bool = False,
        creature: bool = False,
        cyl_spheres: list[CylSphereSpec] | None = None,
        sledding: bool = False,
    ) -> None:
        if not spheres:
            spheres = [Sphere(Vec3(0.0, 0.0, 0.1), 0.1)]  # the client's dummy sphere
        self.id = mover_id
        self.spheres = spheres
        self.cyl_spheres = cyl_spheres or []
        self.scale = scale
        self.step_up_height = step_up_height
        self.step_down_height = step_down_height
        self.oi_flags = oi_flags & _STATIC_OI
        self.gravity = gravity
        self.missile = missile
        #: whether transitions probe for ground below (never for a missile)
        self.step_down = step_down
        self.ethereal = ethereal
        self.creature = creature
        #: PhysicsState.Sledding: the sledding friction rule, and (retail) gravity on the ground
        self.sledding = sledding
        #: other movers are not obstacles to this one (a navigation probe, engine.navigation)
        self.ignore_movers = False
        self.position: Position = Position(0, Frame(ZERO))
        self.cell: ObjCell | None = None
        self.transient = TS.ACTIVE
        self.contact_plane = Plane(ZERO, 0.0)
        self.contact_plane_cell_id = 0
        self.sliding_normal = ZERO
        self.velocity = ZERO
        self.acceleration = ZERO
        self.elasticity = DEFAULT_ELASTICITY
        self.friction = DEFAULT_FRICTION
        self.shadow_cells: list[ObjCell] = []
        #: this mover as an obstacle for others (engine.objects.obstacle.MoverObstacle)
        self.obstacle: MoverObstacle | None = None
        #: the box round its shapes the others' broad phase keeps (engine.cells.broad_phase)
        self.broad_phase_bounds: ShapeBounds | None = None
        self.colliding_with_environment = False
        #: elapsed time not yet run as a physics step (the client's lag of
        #: update_time behind the clock), and the share of the caller's
        #: motion that goes with it
        self.held_time = 0.0
        self.held_motion = ZERO
        #: `spheres` as its transitions move them (made by the first move, again when spheres, scale or
        #: precision change: the list is replaced, never edited in place)
        self.scaled_spheres: ScaledSpheres | None = None
        #: how many moves and steps have resolved for this mover (engine.world.moves counts them; a caller
        #: restoring a mover sets it), and the last one's result (None before the first): the per-mover
        #: bookkeeping a server keeps to order and resend a mover's results, kept where the move happens
        self.seq = 0
        self.last: MoveResult | None = None

    # -- velocity (PhysicsObj.set_velocity / calc_acceleration) -------------
    def set_velocity(self, velocity: Vec3) -> None:
        if velocity != self.velocity:
            length = velocity.length()
            if length > MAX_VELOCITY:
                velocity = velocity * (MAX_VELOCITY / length)
            self.velocity = velocity
        self.transient |= TS.ACTIVE

    def stop_velocity(self) -> None:
        self.set_velocity(ZERO)

    def calc_acceleration(self, sled_gravity: bool = True) -> None:
        """Gravity unless the object stands on walkable ground
        (PhysicsObj.calc_acceleration). With `sled_gravity` (the client's
        rule) a sledding object keeps gravity on the ground too; ACE drops
        the sledding test."""
        grounded = self.transient & TS.CONTACT and self.transient & TS.ON_WALKABLE
        if grounded and not (sled_gravity and self.sledding):
            self.acceleration = ZERO
        elif self.gravity:
            self.acceleration = Vec3(0.0, 0.0, GRAVITY)
        else:
            self.acceleration = ZERO

    def check_contact(self, contact: bool) -> bool:
        """Moving away from the contact plane breaks contact (PhysicsObj.check_contact)."""
        if self.transient & TS.CONTACT and self.velocity.dot(self.contact_plane.normal) > EPSILON:
            return False
        return contact

    # -- one transition (PhysicsObj.transition) --------------------------------
    def make_transition(self, world: CellLookup, settings: EngineSettings) -> Transition:
        """A Transition set up from this object's carried state (get_object_info)."""
        state = self.oi_flags
        in_contact = False
        if self.transient & TS.CONTACT:
            in_contact = self.check_contact(True)
            if in_contact:
                state |= OI.CONTACT
                if self.transient & TS.ON_WALKABLE:
                    state |= OI.ON_WALKABLE
        if self.missile:
            state |= OI.PATH_CLIPPED
        t = take_transition(world, settings, self.object_info(state))
        if self.transient & TS.CONTACT:
            is_water = bool(self.transient & TS.WATER_CONTACT)
            if in_contact:
                t.init_contact_plane(self.contact_plane_cell_id, self.contact_plane, is_water)
            else:
                t.init_last_known_contact_plane(self.contact_plane_cell_id, self.contact_plane, is_water)
        if self.transient & TS.SLIDING:
            t.init_sliding_normal(self.sliding_normal)
        scaled = self.scaled_spheres
        single = settings.single_precision
        if scaled is None or not scaled.made_from(self.spheres, self.scale, single):
            scaled = self.scaled_spheres = ScaledSpheres(self.spheres, self.scale, single)
        t.init_scaled_spheres(scaled)
        return t

    def object_info(self, state: int) -> ObjectInfo:
        """This object's ObjectInfo with the given state flags (ObjectInfo.Init).

        The step heights are taken as given, not multiplied by `scale`. The
        client reads them from the part array (setup height times the part
        array's own scale, PartArray.GetStepDownHeight), a scale apart from
        the object's; the spheres follow the object's scale. The reference
        traces show the part array's scale left at 1 for scaled movers:
        house-placement-073 (scale 1.25, 0.46 m above the floor) is not
        landed, as a 0.4 m step-down would not reach, a 0.5 m one would;
        steep-043 and cliff-036 agree only this way too.
        """
        oi = ObjectInfo(state, self)
        oi.scale = self.scale
        oi.step_up_height = self.step_up_height
        oi.step_down_height = self.step_down_height
        oi.ethereal = self.ethereal
        # a missile never probes for ground below
        oi.step_down = self.step_down and not self.missile
        oi.missile = not oi.step_down
        oi.gravity = self.gravity
        oi.ignore_movers = self.ignore_movers
        return oi

    def transition(self, world: CellLookup, old_pos: Position, new_pos: Position, settings: EngineSettings) -> Transition | None:
        t = self.make_transition(world, settings)
        t.init_path(self.cell, old_pos, new_pos)
        ci = t.collision_info
        if self.transient & TS.STATIONARY_STUCK:
            ci.frames_stationary_fall = 3
        elif self.transient & TS.STATIONARY_STOP:
            ci.frames_stationary_fall = 2
        elif self.transient & TS.STATIONARY_FALL:
            ci.frames_stationary_fall = 1
        if not t.find_valid_position():
            return None
        return t

    # -- applying a result (PhysicsObj.SetPositionInternal) ----------------------
    def set_position_internal(self, t: Transition) -> None:
        path = t.sphere_path
        ci = t.collision_info
        prev_on_walkable = bool(self.transient & TS.ON_WALKABLE)
        prev_contact = bool(self.transient & TS.CONTACT)
        assert path.curr_pos is not None
        # what the object keeps, it keeps at the working precision (the client's: single)
        cur = path.curr_pos
        single = t.single_precision
        origin = cur.frame.origin
        kept = fl_vec(origin, single)
        # (positions are immutable: when nothing rounds, the path's own is the copy)
        self.position = cur if kept is origin else Position(cur.cell_id, cur.frame.with_origin(kept))
        self.cell = path.curr_cell

        self.contact_plane_cell_id = ci.contact_plane_cell_id
        self.contact_plane = fl_plane(ci.contact_plane, single)
        if ci.contact_plane_valid:
            self.transient |= TS.CONTACT
        else:
            self.transient &= ~TS.CONTACT
        sled_gravity = t.settings.sled_gravity
        self.calc_acceleration(sled_gravity)
        if ci.contact_plane_is_water:
            self.transient |= TS.WATER_CONTACT
        else:
            self.transient &= ~TS.WATER_CONTACT
        if self.transient & TS.CONTACT:
            if self.contact_plane.normal.z < FLOOR_Z:
                self.transient &= ~TS.ON_WALKABLE
            else:
                self.transient |= TS.ON_WALKABLE
        else:
            self.transient &= ~TS.ON_WALKABLE
        self.calc_acceleration(sled_gravity)

        self.sliding_normal = fl_vec(ci.sliding_normal, single)
        if ci.sliding_normal_valid:
            self.transient |= TS.SLIDING
        else:
            self.transient &= ~TS.SLIDING
        self.handle_all_collisions(t, prev_contact, prev_on_walkable)

    def handle_all_collisions(self, t: Transition, prev_contact: bool, prev_on_walkable: bool) -> None:
        """Bounce off what we hit and track the stationary-fall flags."""
        ci = t.collision_info
        # a sled bounces off the ground it slides on; anything else on walkable ground does not
        apply_bounce = self.sledding or not (prev_on_walkable and self.transient & TS.ON_WALKABLE)
        for obj in ci.collide_object:
            # track_object_collision: hitting a live object ends a missile's flight
            if getattr(obj, "static", False):
                self.report_environment_collision()
            elif not getattr(obj, "ignore_collisions", False):
                self.missile = False
        if self.colliding_with_environment:
            self.colliding_with_environment = ci.collided_with_environment
        elif ci.collided_with_environment or (not prev_on_walkable and self.transient & TS.ON_WALKABLE):
            self.report_environment_collision()
        fsf = ci.frames_stationary_fall
        if fsf <= 1:
            if apply_bounce and ci.collision_normal_valid:
                self.velocity = self._bounce(ci.collision_normal, t.single_precision)
        else:
            self.velocity = ZERO
            if fsf == 3:
                self.transient &= ~TS.STATIONARY_COMPLETE
                return
        # The client sets these bits without clearing the lower ones.
        if fsf == 0:
            self.transient &= ~TS.STATIONARY_COMPLETE
        elif fsf == 1:
            self.transient |= TS.STATIONARY_FALL
        elif fsf == 2:
            self.transient |= TS.STATIONARY_STOP
        else:
            self.transient |= TS.STATIONARY_STUCK

    def _bounce(self, normal: Vec3, single: bool) -> Vec3:
        """The velocity after an elastic bounce off `normal` (the collision
        response of PhysicsObj.handle_all_collisions), at the working
        precision (`single`: the client's, the normal being the float32 it
        keeps)."""
        v = self.velocity
        n = fl_vec(normal, single)
        angle = fl_dot(v.x, v.y, v.z, n.x, n.y, n.z, single)
        if angle < 0.0:
            push = -fl(angle * fl(fl(self.elasticity, single) + 1.0, single), single)
            return Vec3(fl(v.x + fl(n.x * push, single), single), fl(v.y + fl(n.y * push, single), single), fl(v.z + fl(n.z * push, single), single))
        return v

    def report_environment_collision(self) -> None:
        """A missile's first hit on the world ends its flight (report_environment_collision)."""
        if self.colliding_with_environment:
            return
        self.colliding_with_environment = True
        self.missile = False

    # -- the physics step (UpdatePositionInternal / UpdatePhysicsInternal) -------
    def integrate(self, motion: Vec3, dt: float, settings: EngineSettings = RETAIL) -> Frame:
        """Where this object wants to be after `dt`: its own motion `motion`
        (metres in the object frame, already scaled to the object's size, as
        the client's animation offset is; applied only on walkable ground),
        plus velocity and gravity, with friction on the ground and the speed
        clamp (PhysicsObj.UpdatePositionInternal / UpdatePhysicsInternal).

        At the working precision (`settings.single_precision`); in single
        precision every step is done as the client does it, in the order its
        expressions evaluate: the motion rotated and added to the origin
        (AFrame.Combine), the movement `a * 0.5 * q * q + v * q` added to
        that, the velocity updated by `a * q`, with `q` the time step as a
        float32.

        `settings` also choose the sledding friction rule (the client's
        unless `sled_slope_friction` is off)."""
        s = settings.single_precision
        sled_slope = settings.sled_slope_friction
        frame = self.position.frame
        o = frame.origin
        if self.transient & TS.ON_WALKABLE:
            local = fl_rotate(frame.orientation, motion, s)
            x = fl(o.x + local.x, s)
            y = fl(o.y + local.y, s)
            z = fl(o.z + local.z, s)
        else:
            # the offset is scaled by zero: the origin plus a zero vector
            x = o.x
            y = o.y
            z = o.z
        q = fl(dt, s)
        a = self.acceleration
        v = self.velocity
        v2 = fl_dot(v.x, v.y, v.z, v.x, v.y, v.z, s)
        if v2 > 0.0:
            if v2 > MAX_VELOCITY_SQ:
                length = fl(math.sqrt(v2), s)
                v = fl_scale(Vec3(fl(v.x / length, s), fl(v.y / length, s), fl(v.z / length, s)), MAX_VELOCITY, s)
                v2 = MAX_VELOCITY_SQ
            v = self._friction(v, q, v2, sled_slope, s)
            if fl(v2 - SMALL_VELOCITY_SQ, s) < fl(EPSILON, s):
                v = ZERO
            # Acceleration * 0.5f * quantum * quantum + Velocity * quantum
            x = fl(x + fl(fl(fl(fl(a.x * 0.5, s) * q, s) * q, s) + fl(v.x * q, s), s), s)
            y = fl(y + fl(fl(fl(fl(a.y * 0.5, s) * q, s) * q, s) + fl(v.y * q, s), s), s)
            z = fl(z + fl(fl(fl(fl(a.z * 0.5, s) * q, s) * q, s) + fl(v.z * q, s), s), s)
        self.velocity = Vec3(fl(v.x + fl(a.x * q, s), s), fl(v.y + fl(a.y * q, s), s), fl(v.z + fl(a.z * q, s), s))
        return frame.with_origin(Vec3(x, y, z))

    def _friction(self, v: Vec3, q: float, speed_sq: float, sled_slope: bool, s: bool) -> Vec3:
        """Ground friction at the working precision (PhysicsObj.calc_friction)."""
        if not self.transient & TS.ON_WALKABLE:
            return v
        n = self.contact_plane.normal
        angle = fl_dot(v.x, v.y, v.z, n.x, n.y, n.z, s)
        if angle >= 0.25:
            return v
        v = fl_sub(v, fl_scale(n, angle, s), s)
        friction = self.ground_friction(speed_sq, sled_slope)
        scalar = fl(math.pow(fl(1.0 - fl(friction, s), s), q), s)
        return fl_scale(v, scalar, s)

    def ground_friction(self, speed_sq: float, sled_slope: bool) -> float:
        """The friction coefficient calc_friction applies on the ground, for a
        squared speed `speed_sq` (before the contact plane's normal part is
        taken off). A sled stops below 1.25 m/s; from 2.5 m/s it gets the low
        sledding friction on slopes steeper than 10 degrees (`sled_slope`, the
        client's test) or on nearly flat ground (ACE's test)."""
        if not self.sledding:
            return self.friction
        if speed_sq < SLED_STOP_SPEED_SQ:
            return 1.0
        if speed_sq >= SLED_FAST_SPEED_SQ:
            nz = self.contact_plane.normal.z
            if (nz < SLED_SLOPE_NORMAL_Z) if sled_slope else (nz > ACE_SLED_FLAT_NORMAL_Z):
                return SLED_SLOPE_FRICTION
        return self.friction

    def orientation(self) -> Quat:
        return self.position.frame.orientation

    def up(self) -> Vec3:
        return UNIT_Z

