"""Sweeps: a sphere carried along a segment by the client's transition.

`ray` is a missile's sweep (ObjectInfoState PathClipped, the flag
PhysicsObj.get_object_info gives an object in the Missile state): the
transition (Transition.FindTransitionalPosition) walks the segment in steps
of at most one sphere radius (CalcNumSteps) and stops at the first step that
reports a collision normal (the PathClipped break), the sphere left where the
step before put it, so up to one radius short of the contact (on terrain the
sphere is set onto the terrain plane, as the client's missile is). The client
has a finer answer, PerfectClip (ObjectInfoState 0x40, set on few objects):
BSPTREE::collide_with_pt then bisects the collision time against the polygon
(adjust_to_plane) and moves the sphere to the touch. As the reference has
it (engine.bsp.tree.adjust_to_plane, kept literally) that bisection always
gives up, so a PerfectClip collision ends Collided with no collision normal
recorded (the transition then reports +z), and only for BSP polygons at
that; so a query does not set PerfectClip but does the bisection itself over whole
transitions of the same sphere (`_to_contact`), which works alike for
terrain, cell polygons, buildings and objects. A ray's hit therefore reports
the centre of the sphere touching the surface (to CONTACT_TOLERANCE along the
segment) and the normal the colliding transition reports there: the polygon's
plane normal for a cell or building wall (collide_with_pt), the terrain
triangle's for land, centre to centre for an object's sphere.

`sight` is the same sweep of the sight object the server
builds for line of sight (ACE's WorldObject.IsDirectVisible: a throwaway
missile object swept eye to eye; PhysicsObj.IsSightObj lifts the step cap of
FindTransitionalPosition, so a long sight line is never refused for length).

Who blocks whom is the transition's own object rules
(engine.objects.obstacle.find_obj_collisions, PhysicsObj.FindObjCollisions
and ObjectInfo.MissileIgnore): ethereal objects never stop a missile;
creatures and players do, unless the sweep is aimed at a target
(ProjectileTarget), when every creature but the target is passed; static
objects, buildings, cell walls, closed doors (static objects) and terrain
always do. No gravity and no step-down: the sweep is a straight segment.

The sweep object is a Mover no cell knows about (no shadows are cast, its
result is never applied with SetPositionInternal), so a query changes no
mover. Unlike ACE there is no one-landblock limit: a sweep crosses as many
landblocks as the loaded world holds, and refuses (LandblockNotLoadedError)
one that would pass over land not loaded and not loadable.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING, Final

from .. import limits
from ..limits import MAX_RAY_RADIUS, MIN_SPHERE_RADIUS
from ..constants import BLOCK_LENGTH, EPSILON
from ..errors import LandblockNotLoadedError, OutOfRangeError
from ..geometry import ZERO, Position, Sphere
from ..geometry.landdefs import adjust_to_outside, get_block_offset
from ..transition.state import OI
from ..transition.transition import Transition
from ..world.mover import Mover
from .results import Blocker, RayHit, SightResult

if TYPE_CHECKING:
    from ..cells.obj_cell import ObjCell
    from ..world.world import World

__all__ = ["SIGHT_RADIUS", "CONTACT_TOLERANCE", "ray", "sight", "check_segment", "cell_for", "MAX_RAY_RADIUS"]

#: The sight object's radius, 0.1 m. What the server sweeps for line of sight
#: (ACE's WorldObject.IsDirectVisible) is PhysicsObj.makeObject(0x02000124, the
#: arrow's Setup, as a sight object) in the Missile state; PhysicsObj.transition
#: gives a transition that Setup's spheres, or, when it has none,
#: PhysicsGlobals.DummySphere: radius DummySphereRadius = 0.1, centred 0.1 above
#: the object's origin. The arrow Setup's own spheres are dat data that is not
#: in this project's material (the shared dats carry three scenes' Setups), so
#: the default is the dummy sphere's radius, swept with its centre on the eye
#: line; a caller who knows the arrow's sphere passes it as `radius`.
SIGHT_RADIUS: Final = 0.1
#: no step cap for a sight object (PhysicsObj.IsSightObj); for a ray the
#: settings' own cap (retail 30 steps) would refuse anything longer than
#: 30 radii, which a query has no reason to
_UNCAPPED_STEPS: Final = 1 << 30
#: the id of the sweep object (no mover has a negative id)
_SWEEP_ID: Final = -1
#: how far apart the landblock-coverage samples of a segment are
_COVERAGE_STEP: Final = 12.0
#: how close to the contact a hit's reported stop is found (metres along the segment)
CONTACT_TOLERANCE: Final = 1e-4
#: bisection steps at most (a radius of 10 m halved 17 times is under 1e-4 m)
_MAX_BISECTIONS: Final = 20


def _global_xy(position: Position) -> tuple[float, float]:
    cell = position.cell_id
    o = position.frame.origin
    return ((cell >> 24) & 0xFF) * BLOCK_LENGTH + o.x, ((cell >> 16) & 0xFF) * BLOCK_LENGTH + o.y


def check_point(world: World, position: Position, field: str) -> None:
    """A query point: finite, in range, a real cell of a loaded (or loadable) landblock."""
    limits.check_position(position, field)
    world.landscape.check_position(position)


def check_radius(radius: float, field: str = "radius") -> float:
    r = limits.check_number(radius, field)
    if not (MIN_SPHERE_RADIUS <= r <= MAX_RAY_RADIUS):
        raise OutOfRangeError(f"{field} must be from {MIN_SPHERE_RADIUS:g} to {MAX_RAY_RADIUS:g} m, got {radius!r}")
    return r


def check_segment(world: World, start: Position, end: Position, radius: float) -> None:
    """Every landblock the swept sphere passes over is loaded (or loaded now
    from the World's source); else LandblockNotLoadedError names the first
    one the sweep would reach."""
    landscape = world.landscape
    x0, y0 = _global_xy(start)
    x1, y1 = _global_xy(end)
    length = math.hypot(x1 - x0, y1 - y0)
    samples = max(1, math.ceil(length / _COVERAGE_STEP))
    seen: set[int] = set()
    for i in range(samples + 1):
        f = i / samples
        x = x0 + (x1 - x0) * f
        y = y0 + (y1 - y0) * f
        for dx in (-radius, radius):
            for dy in (-radius, radius):
                bx = math.floor((x + dx) / BLOCK_LENGTH)
                by = math.floor((y + dy) / BLOCK_LENGTH)
                if not (0 <= bx <= 0xFF and 0 <= by <= 0xFF):
                    raise LandblockNotLoadedError(f"the sweep leaves the world (landblock column {bx}, row {by}) at {f:.0%} of the way")
                lb_id = (bx << 8) | by
                if lb_id in seen:
                    continue
                seen.add(lb_id)
                try:
                    landscape.ensure_loaded(lb_id << 16 | 0xFFFF)
                except LandblockNotLoadedError:
                    raise LandblockNotLoadedError(
                        f"the sweep reaches landblock {lb_id:04X} at {f:.0%} of the way, and it is not loaded"
                    ) from None


def cell_for(world: World, position: Position, cache: dict[int, ObjCell | None] | None = None) -> tuple[ObjCell | None, Position]:
    """The cell a query point lies in, and the point re-homed there for an
    outdoor cell (LandDefs.AdjustToOutside, as a move's start is found).
    `cache` keeps indoor cells found earlier in a batch."""
    cell_id = position.cell_id
    if (cell_id & 0xFFFF) < 0x100:
        new_id, origin = adjust_to_outside(cell_id, position.frame.origin)
        if new_id != cell_id or origin != position.frame.origin:
            position = Position(new_id, position.frame.with_origin(origin))
        cell_id = new_id
    if cache is not None:
        cell = cache.get(cell_id)
        if cell is None:
            cell = world.get_landcell(cell_id)
            cache[cell_id] = cell
        return cell, position
    return world.get_landcell(cell_id), position


def _sweep(world: World, start: Position, end: Position, radius: float, target_id: int, cache: dict[int, ObjCell | None] | None,
           pass_creatures: bool = False) -> tuple[Transition, bool, Position]:
    """Run one missile sweep from `start` to `end` (PhysicsObj.transition on a
    throwaway object). Returns the transition, whether it found a position,
    and the start as re-homed. With `pass_creatures` the sweep object is also
    a viewer (ObjectInfoState IsViewer, the camera's flag), which creatures
    and players never stop (PhysicsObj.FindObjCollisions)."""
    cell, start = cell_for(world, start, cache)
    sweeper = Mover(_SWEEP_ID, [Sphere(ZERO, radius)], gravity=False, missile=True, step_down=False)
    sweeper.position = start
    sweeper.cell = cell
    settings = replace(world.settings, max_steps=_UNCAPPED_STEPS)
    t = sweeper.make_transition(world.landscape, settings)
    t.object_info.target_id = target_id
    if pass_creatures:
        t.object_info.state |= OI.IS_VIEWER
    t.init_path(cell, start, end)
    ok = cell is not None and t.find_valid_position()
    return t, ok, start


def _blocker(world: World, t: Transition, stop: Position, radius: float) -> Blocker:
    """What stopped the sweep. A mover is named by the transition itself
    (CollisionInfo.collide_object); otherwise the stop is told apart by where
    it is: an indoor cell's polygon, the terrain when the sphere rests on (or
    in) the terrain triangle under it with that triangle's normal, a building's shell
    when a building stands in the cells the sweep touched, else a static
    object (static objects are not recorded by the client's collision info)."""
    ci = t.collision_info
    if ci.collide_object:
        obj = ci.last_collided_object if ci.last_collided_object is not None else ci.collide_object[-1]
        return Blocker("object", int(getattr(obj, "id", 0)))
    if (stop.cell_id & 0xFFFF) >= 0x100:
        return Blocker("cell")
    normal = ci.collision_normal
    center = stop.frame.origin
    low = center - normal * radius
    for cell in t.cell_array.cells():
        if cell is None or (cell.id & 0xFFFF) >= 0x100:
            continue
        triangles = getattr(cell, "polygons", None)
        if not triangles:
            continue
        offset = get_block_offset(stop.cell_id, cell.id)
        for tri in triangles:
            # the terrain: a triangle under the sphere with the collision's normal, the sphere on or in it
            if (
                tri.plane.normal.dot(normal) > 0.999
                and tri.plane.distance(center - offset) <= radius + 0.05
                and (tri.point_in_poly_2d(center - offset) or tri.point_in_poly_2d(low - offset))
            ):
                return Blocker("terrain")
    for cell in t.cell_array.cells():
        if cell is not None and getattr(cell, "building", None) is not None:
            return Blocker("building")
    return Blocker("object", 0)


def ray(world: World, start: Position, end: Position, radius: float, *, target_id: int = 0, cache: dict[int, ObjCell | None] | None = None) -> RayHit:
    """The first contact of a sphere of `radius` swept from `start` to `end`
    (the missile sweep above). `target_id` is the mover the sweep is aimed at
    (ProjectileTarget), 0 for none."""
    check_point(world, start, "start")
    check_point(world, end, "end")
    radius = check_radius(radius)
    check_segment(world, start, end, radius)
    return _ray_checked(world, start, end, radius, target_id, cache)


def _to_contact(world: World, t: Transition, stop: Position, end: Position, radius: float, target_id: int,
                cache: dict[int, ObjCell | None] | None, pass_creatures: bool) -> tuple[Transition, Position]:
    """The sweep's stop carried on to the contact: the last position along the segment from which a
    short sweep of the same sphere still arrives, found by bisection to CONTACT_TOLERANCE.

    The missile's transition stops at the step before the one that collides (the PathClipped break),
    so up to one step (at most one radius) short of the surface. The client's finer answer is
    PerfectClip (BSPTREE::adjust_to_plane, a bisection of the collision time against the polygon);
    the reference port's version of it gives up and leaves no usable normal, so a query does the same
    bisection here over whole transitions instead (terrain, cells, buildings and objects alike).
    Returns the transition of the last colliding probe (its normal and what it hit) and the stop."""
    offset = stop.get_offset(end)
    remaining = offset.length()
    if remaining <= CONTACT_TOLERANCE:
        return t, stop
    direction = offset * (1.0 / remaining)
    lo, hi = 0.0, min(radius, remaining)
    collided = t
    free = stop
    # the probe one step ahead must collide, as the sweep's did; else keep the sweep's own answer
    for _ in range(_MAX_BISECTIONS):
        if hi - lo <= CONTACT_TOLERANCE:
            break
        mid = hi if collided is t else 0.5 * (lo + hi)
        probe_end = Position(stop.cell_id, stop.frame.with_origin(stop.frame.origin + direction * mid))
        probe, ok, _ = _sweep(world, free, probe_end, radius, target_id, cache, pass_creatures)
        reached = probe.sphere_path.curr_pos
        if ok and reached is not None and not probe.collision_info.collision_normal_valid:
            if collided is t:
                return t, stop  # the step ahead no longer collides: nothing to refine
            lo = mid
            free = reached
        elif not probe.collision_info.collision_normal_valid:
            break  # a probe too short for the transition to resolve (float32): as close as it gets
        else:
            hi = mid
            collided = probe
    if collided is t:
        return t, stop
    return collided, free


def _ray_checked(world: World, start: Position, end: Position, radius: float, target_id: int, cache: dict[int, ObjCell | None] | None,
                 pass_creatures: bool = False) -> RayHit:
    if start.get_offset(end).length() <= EPSILON:
        # a point, not a segment: swept as none (a first step of a few ulps can fail where none is taken)
        end = start
    t, ok, home = _sweep(world, start, end, radius, target_id, cache, pass_creatures)
    path = t.sphere_path
    ci = t.collision_info
    if not ok or path.curr_pos is None:
        # no position at all: the sphere cannot be where the segment begins
        normal = ci.collision_normal if ci.collision_normal_valid else None
        return RayHit(True, home, home.cell_id, normal, 0.0, _blocker(world, t, home, radius) if normal is not None else Blocker("object", 0))
    stop = path.curr_pos
    if not ci.collision_normal_valid:
        return RayHit(False, stop, stop.cell_id, None, home.get_offset(stop).length(), None)
    hit_t, stop = _to_contact(world, t, stop, end, radius, target_id, cache, pass_creatures)
    normal = hit_t.collision_info.collision_normal
    return RayHit(True, stop, stop.cell_id, normal, home.get_offset(stop).length(), _blocker(world, hit_t, stop, radius))


def viewer_radius(world: World, viewer_id: int) -> float:
    """How far the sight object starts from a viewer's eye: the viewer's physics radius, its first
    cylsphere's radius, else its first sphere's, times its scale (PhysicsObj.GetPhysicsRadius, as
    IsDirectVisible adds it to the sight object's own)."""
    mover = world.mover(viewer_id)
    if mover.cyl_spheres:
        return float(mover.cyl_spheres[0].radius) * mover.scale
    return mover.spheres[0].radius * mover.scale if mover.spheres else 0.0


def start_outside_viewer(world: World, a: Position, b: Position, radius: float, viewer_id: int) -> Position:
    """`a` moved toward `b` by the viewer's radius plus the sight object's,
    so the sweep begins outside the viewer (IsDirectVisible)."""
    offset = a.get_offset(b)
    length = offset.length()
    if length <= 0.0:
        return a
    step = min(viewer_radius(world, viewer_id) + radius, length)
    return Position(a.cell_id, a.frame.with_origin(a.frame.origin + offset * (step / length)))


def sight(
    world: World,
    a: Position,
    b: Position,
    radius: float = SIGHT_RADIUS,
    *,
    target_id: int = 0,
    viewer_id: int = 0,
    cache: dict[int, ObjCell | None] | None = None,
) -> SightResult:
    """Is the line from eye `a` to eye `b` clear for the sight object?

    Clear when the sweep arrives at `b` without a collision, or when what it
    touched is the target mover `target_id` (IsDirectVisible's test: the
    target among the objects collided with). With `viewer_id` (the mover
    whose eye `a` is) the sweep starts outside that mover, moved toward `b`
    by its radius plus the sight object's, as IsDirectVisible starts it."""
    check_point(world, a, "a")
    check_point(world, b, "b")
    radius = check_radius(radius)
    if viewer_id:
        a = start_outside_viewer(world, a, b, radius, viewer_id)
    check_segment(world, a, b, radius)
    return _sight_checked(world, a, b, radius, target_id, cache)


def _sight_checked(world: World, a: Position, b: Position, radius: float, target_id: int, cache: dict[int, ObjCell | None] | None) -> SightResult:
    hit = _ray_checked(world, a, b, radius, target_id, cache)
    if not hit.hit:
        return SightResult(True)
    if target_id and hit.blocker is not None and hit.blocker.kind == "object" and hit.blocker.object_id == target_id:
        return SightResult(True)
    return SightResult(False, hit.position, hit.normal, hit.cell, hit.blocker)
