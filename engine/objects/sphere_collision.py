"""A moving object's spheres against an obstacle's sphere (the client's CSphere
object routines, ACE `Sphere.cs`).

Every function answers a `TransitionState` int and works on the global
spheres the path has cached at the check position (`path.global_sphere`)
and at the current position (`path.global_curr_center`). The obstacle's
sphere is given by its centre in the check position's landblock frame and
its (scaled) radius.

Overlap tests use `radsum = mover radius + obstacle radius - EPSILON`, and
"touching" counts as a collision (`|d|^2 <= radsum^2`), as the client's.

Some routines carry the reference's oddities on purpose, since the traces
pin them down:
- the contact planes an obstacle sphere gives (standing on it while stepping
  down, landing on it in collide mode) are recorded as water planes;
- in collide mode a single-sphere mover that does not overlap still runs the
  landing solve; when that solve has no real root the reference's NaN
  arithmetic ends in OK with nothing changed, which is what is done here;
- PerfectClip adds the sphere's offset from the obstacle (not the way back)
  to the check position, after a time of collision whose sign convention
  makes most approaches COLLIDED.
"""

from __future__ import annotations

import math
from typing import Final, TYPE_CHECKING

from ..constants import EPSILON, LANDING_Z
from ..geometry import Plane, Position, Sphere, Vec3
from ..geometry.precision import fl, fl_place
from ..geometry.landdefs import get_block_offset
from ..transition.slide import slide_sphere, slide_sphere_object
from ..transition.state import OI, InsertType, TransitionState

if TYPE_CHECKING:
    from ..transition.transition import Transition

__all__ = [
    "intersects_sphere",
    "intersects_sphere_at",
    "collides_with_sphere",
    "step_sphere_up",
    "step_sphere_down",
    "land_on_sphere",
    "collide_with_point",
    "slide_sphere_toward",
    "slide_sphere_env",
    "find_time_of_collision",
]

_OK: Final = TransitionState.OK
_COLLIDED: Final = TransitionState.COLLIDED
_ADJUSTED: Final = TransitionState.ADJUSTED
_SLID: Final = TransitionState.SLID
_PLACEMENT: Final = InsertType.PLACEMENT
_CONTACT_OR_WALKABLE: Final = OI.CONTACT | OI.ON_WALKABLE


def collides_with_sphere(disp: Vec3, radsum: float) -> bool:
    """Does a sphere `disp` away overlap (or touch) at distance `radsum`?
    (Sphere.CollidesWithSphere)"""
    return disp.x * disp.x + disp.y * disp.y + disp.z * disp.z <= radsum * radsum


def intersects_sphere_at(
    local_sphere: Sphere, position: Position, scale: float, transition: Transition, is_creature: bool
) -> int:
    """Collide the path with one of an obstacle's spheres given in the
    obstacle's frame (Sphere.IntersectsSphere(Position, scale, ...)).

    The sphere's centre is scaled, placed by `position` and expressed in the
    check position's landblock; its radius is scaled.
    """
    s = transition.single_precision
    center = fl_place(transition.sphere_path.check_pos.cell_id, position, local_sphere.center, scale, s)
    radius = fl(fl(local_sphere.radius, s) * fl(scale, s), s)
    return intersects_sphere(Sphere(center, radius), transition, is_creature)


def intersects_sphere(obstacle_sphere: Sphere, transition: Transition, is_creature: bool) -> int:
    """Collide the path's spheres with an obstacle sphere (global, check-pos
    landblock frame) and respond (Sphere.IntersectsSphere, static form).

    Branches, in the reference's order:
    - ethereal obstruction or placement: overlap only, COLLIDED or OK;
    - step-down: a creature is never stood on (OK); else StepSphereDown;
    - walkable probe: overlap only;
    - not yet in collide mode: in contact, the foot sphere steps up onto
      (or slides round) it and the head sphere slides off it; a path-clipped
      mover (missile) collides with the point; airborne, the foot lands on it
      and the head collides with the point;
    - collide mode: a creature is ignored; otherwise solve for where along
      the step the foot sphere first rests on the obstacle and, if the
      surface there is walkable enough, make it the contact plane.
    Decompiled client: FUN_005387c0 (the seed, transition_pseudocode.md).
    """
    path = transition.sphere_path
    center = obstacle_sphere.center
    glob_sphere = path.global_sphere[0]
    gc = glob_sphere.center
    # the foot sphere's offset from the obstacle (the reference's disp), made a
    # vector only on the branches that pass it on
    dx = gc.x - center.x
    dy = gc.y - center.y
    dz = gc.z - center.z
    radsum = glob_sphere.radius + obstacle_sphere.radius - EPSILON
    rs2 = radsum * radsum
    hit0 = dx * dx + dy * dy + dz * dz <= rs2
    # the head sphere's overlap (collides_with_sphere(head - center, radsum)), on floats
    two = path.num_sphere > 1
    glob_sphere_1 = None
    hit1 = False
    if two:
        glob_sphere_1 = path.global_sphere[1]
        hc = glob_sphere_1.center
        hx = hc.x - center.x
        hy = hc.y - center.y
        hz = hc.z - center.z
        hit1 = hx * hx + hy * hy + hz * hz <= rs2

    if path.obstruction_ethereal or path.insert_type == _PLACEMENT:
        if hit0:
            return _COLLIDED
        if hit1:
            return _COLLIDED
        return _OK

    if path.step_down:
        if is_creature:
            return _OK
        return step_sphere_down(center, obstacle_sphere.radius, transition, glob_sphere, Vec3(dx, dy, dz), radsum)

    if path.check_walkable:
        if hit0:
            return _COLLIDED
        if hit1:
            return _COLLIDED
        return _OK

    if not path.collide:
        state = transition.object_info.state
        if state & _CONTACT_OR_WALKABLE:
            if hit0:
                return step_sphere_up(center, transition, Vec3(dx, dy, dz), radsum)
            if hit1:
                return slide_sphere_toward(center, transition, glob_sphere_1, 1)  # type: ignore[arg-type]
            return _OK
        if state & OI.PATH_CLIPPED:
            if hit0:
                return collide_with_point(center, transition, glob_sphere, radsum, 0)
        else:
            if hit0:
                return land_on_sphere(center, transition)
            if hit1:
                return collide_with_point(center, transition, glob_sphere_1, radsum, 1)  # type: ignore[arg-type]
        return _OK

    if is_creature:
        return _OK
    # (with one sphere the reference goes on to the solve even without overlap)
    if not hit0 and two and not hit1:
        return _OK

    # Where along the step (from the current centre back toward it) does the
    # foot sphere first touch the obstacle?
    disp = Vec3(dx, dy, dz)
    block_offset = path.get_curr_pos_check_pos_block_offset()
    movement = path.global_curr_center[0].center - gc - block_offset
    radsum += EPSILON
    len_sq = movement.length_sq()
    diff = -movement.dot(disp)
    if abs(len_sq) < EPSILON:
        return _COLLIDED
    disc = diff * diff - (disp.length_sq() - radsum * radsum) * len_sq
    if disc < 0.0:
        # the reference takes the square root of a negative number here; the
        # NaN fails every later test and the walkable check returns OK
        return _OK
    t = math.sqrt(disc) + diff
    if t > 1.0:  # (the reference compares the unscaled root with 1)
        t = diff * 2.0 - t
    time = t / len_sq
    walk_interp = path.walk_interp
    timecheck = (1.0 - time) * walk_interp
    if timecheck >= walk_interp or timecheck < -0.1:
        return _COLLIDED
    movement = movement * time
    normal = (disp + movement) * (1.0 / radsum)
    if not path.is_walkable_allowable(normal.z):
        return _OK

    touch = gc - normal * glob_sphere.radius
    ci = transition.collision_info
    ci.set_contact_plane(Plane(normal, -normal.dot(touch)), True)
    ci.contact_plane_cell_id = path.check_pos.cell_id
    path.walk_interp = timecheck
    path.add_offset_to_check_pos(movement)
    return _ADJUSTED


def step_sphere_down(
    center: Vec3, radius: float, transition: Transition, check_sphere: Sphere, disp: Vec3, radsum: float
) -> int:
    """Stand the lowered foot sphere on top of the obstacle sphere
    (Sphere.StepSphereDown).

    Lifts the check position until the spheres just touch; refuses
    (COLLIDED) a lift beyond the step-down budget or none at all; a resting
    point too steep for the path's walkable allowance is no floor (OK).
    The rest plane is tangent to the obstacle at its surface point under the
    mover.
    """
    path = transition.sphere_path
    if not collides_with_sphere(disp, radsum):
        if path.num_sphere <= 1:
            return _OK
        if not collides_with_sphere(path.global_sphere[1].center - center, radsum):
            return _OK

    step_down = path.step_down_amt * path.walk_interp
    if abs(step_down) < EPSILON:
        return _COLLIDED

    radsum += EPSILON
    horizontal = radsum * radsum - (disp.x * disp.x + disp.y * disp.y)
    if horizontal < 0.0:
        # only reachable when the head sphere overlaps while the foot sphere
        # is horizontally clear of the obstacle; the reference's square root
        # of a negative number would poison the check position with NaN
        return _COLLIDED
    scaled_step = (math.sqrt(horizontal) - disp.z) / step_down
    timecheck = (1.0 - scaled_step) * path.walk_interp
    if timecheck >= path.walk_interp or timecheck < -0.1:
        return _COLLIDED

    interp = step_down * scaled_step
    inv = 1.0 / radsum
    normal = Vec3(disp.x * inv, disp.y * inv, (disp.z + interp) * inv)
    if normal.z <= path.walkable_allowance:
        return _OK

    surface = normal * radius + center
    ci = transition.collision_info
    ci.set_contact_plane(Plane(normal, -normal.dot(surface)), True)
    ci.contact_plane_cell_id = path.check_pos.cell_id
    path.walk_interp = timecheck
    path.add_offset_to_check_pos(Vec3(0.0, 0.0, interp))
    return _ADJUSTED


def step_sphere_up(center: Vec3, transition: Transition, disp: Vec3, radsum: float) -> int:
    """Walked into an obstacle sphere: step onto it if its top is within the
    step-up height, else slide round it (Sphere.StepSphereUp).

    `radsum - disp.z` is how far the obstacle's top is above the foot
    sphere's bottom. A failed step-up slides along the step-up normal
    (StepUpSlide).
    """
    radsum += EPSILON
    if transition.object_info.step_up_height < radsum - disp.z:
        return slide_sphere_object(transition, center, disp, 0)
    path = transition.sphere_path
    collision_normal = path.global_curr_center[0].center - center
    if transition.step_up(collision_normal):
        return _OK
    return path.step_up_slide(transition)


def land_on_sphere(center: Vec3, transition: Transition) -> int:
    """A falling foot sphere meets an obstacle sphere: enter collide mode
    along the line of centres, ready to land on anything not steeper than
    LandingZ (Sphere.LandOnSphere).
    Decompiled client: FUN_00538f50 (the seed, transition_pseudocode.md)."""
    path = transition.sphere_path
    normal = (path.global_curr_center[0].center - center).normalized_or_none()
    if normal is None:
        return _COLLIDED
    path.set_collide(normal)
    path.walkable_allowance = LANDING_Z
    return _ADJUSTED


def collide_with_point(center: Vec3, transition: Transition, check_sphere: Sphere, radsum: float, sphere_num: int) -> int:
    """A path-clipped mover or an airborne head sphere hits an obstacle
    sphere (Sphere.CollideWithPoint).

    Without PerfectClip: the collision normal points from the obstacle to the
    sphere's current centre; COLLIDED. With PerfectClip: the time of
    collision along the step decides; outside (EPSILON, 1] COLLIDED, else
    the check position takes the offset and the normal the reference
    computes, ADJUSTED.
    """
    path = transition.sphere_path
    ci = transition.collision_info
    g_center = path.global_curr_center[sphere_num].center
    global_offset = g_center - center

    if transition.object_info.state & OI.PERFECT_CLIP:
        assert path.curr_pos is not None
        block_offset = get_block_offset(path.curr_pos.cell_id, path.check_pos.cell_id)
        check_offset = check_sphere.center - g_center + block_offset
        time = find_time_of_collision(check_offset, global_offset, radsum + EPSILON)
        if time < EPSILON or time > 1.0:
            return _COLLIDED
        collision_offset = check_offset * time - check_offset
        old_disp = collision_offset + check_sphere.center - center
        ci.set_collision_normal(old_disp * (1.0 / radsum))
        path.add_offset_to_check_pos(old_disp)
        return _ADJUSTED

    normal = global_offset.normalized_or_none()
    if normal is not None:
        ci.set_collision_normal(normal)
    return _COLLIDED


def find_time_of_collision(movement: Vec3, sphere_pos: Vec3, radsum: float) -> float:
    """Fraction of `movement` at which a sphere at `sphere_pos` (relative to
    the obstacle) reaches distance `radsum`, or -1 when it never does or
    already overlaps (Sphere.FindTimeOfCollision, sign conventions kept).
    Decompiled client: FUN_00539ba0 (the seed, transition_pseudocode.md)."""
    dist_sq = movement.length_sq()
    if dist_sq < EPSILON:
        return -1.0
    non_collide = sphere_pos.length_sq() - radsum * radsum
    if non_collide < EPSILON:
        return -1.0
    similar = -sphere_pos.dot(movement)
    disc = similar * similar - non_collide * dist_sq
    if disc < 0.0:
        return -1.0
    c_dist = math.sqrt(disc)
    if similar - c_dist < 0.0:
        return -(c_dist + similar) / dist_sq
    return -(similar - c_dist) / dist_sq


def slide_sphere_toward(center: Vec3, transition: Transition, check_sphere: Sphere, sphere_num: int) -> int:
    """Slide path sphere `sphere_num` (`check_sphere`, its global sphere) off
    an obstacle at `center`: the wall normal is the line from the obstacle
    to the sphere's current centre (Sphere.SlideSphere(center, transition,
    Sphere checkPos, sphereNum))."""
    curr = transition.sphere_path.global_curr_center[sphere_num].center
    normal = (curr - center).normalized_or_none()
    if normal is None:
        return _COLLIDED
    return slide_sphere_env(transition, check_sphere, normal, curr)


def slide_sphere_env(transition: Transition, sphere: Sphere, collision_normal: Vec3, curr_pos: Vec3) -> int:
    """The wall slide of any path sphere (Sphere.SlideSphere(transition, ref
    collisionNormal, currPos) called on `sphere`): `slide.slide_sphere` with
    the sphere named."""
    return slide_sphere(transition, collision_normal, curr_pos, sphere)
