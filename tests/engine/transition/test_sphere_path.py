"""engine/transition/sphere_path.py: SpherePath's set-up, check-position moves, caches and slides.

The client's SPHEREPATH: InitSphere (at most two spheres, scaled), InitPath (a path with no begin
position is a placement), moving the check position and the global spheres with it, re-homing it
into another landblock, the walkable bookkeeping and the two slides that live on the path
(StepUpSlide, PrecipiceSlide). Numbers are float32-exact so most answers are exact.
"""

from __future__ import annotations

from engine.geometry import Frame, Plane, Position, Quat, Sphere, Vec3
from engine.geometry.polygon import Polygon
from engine.transition.sphere_path import SpherePath
from engine.transition.state import InsertType, TransitionState as TS
from engine.transition.transition import Transition

CELL = 0xA9B40001
EAST_CELL = 0xAAB40001  # the landblock east of CELL's, 192 m along x
UP = Vec3(0.0, 0.0, 1.0)
FOOT = Sphere(Vec3(0.0, 0.0, 0.5), 0.5)
HEAD = Sphere(Vec3(0.0, 0.0, 1.5), 0.5)


def _path(origin: Vec3, spheres: list[Sphere] | None = None, begin: Vec3 | None = None) -> SpherePath:
    path = SpherePath()
    path.init_sphere([FOOT, HEAD] if spheres is None else spheres, 1.0)
    end = Position(CELL, Frame(origin))
    path.init_path(None, Position(CELL, Frame(origin if begin is None else begin)), end)
    path.set_check_pos(end, None)
    return path


def test_init_sphere_keeps_two_spheres_scaled_and_the_foot_low_point() -> None:
    """SpherePath.InitSphere: of three spheres the first two, centres and radii times the scale 2;
    the local low point is the foot sphere's bottom, (0, 0, 1 - 1) = the origin."""
    path = SpherePath()
    path.init_sphere([FOOT, HEAD, Sphere(Vec3(0.0, 0.0, 3.0), 0.25)], 2.0)
    assert path.num_sphere == 2
    assert [(s.center, s.radius) for s in path.local_sphere] == [(Vec3(0.0, 0.0, 1.0), 1.0), (Vec3(0.0, 0.0, 3.0), 1.0)]
    assert path.local_low_point == Vec3(0.0, 0.0, 0.0)


def test_init_path_without_a_begin_position_is_a_placement() -> None:
    """SpherePath.InitPath: no begin position: a placement at the end position; with one, a
    transition from it. The current centres are placed at the current position."""
    path = SpherePath()
    path.init_sphere([FOOT], 1.0)
    end = Position(CELL, Frame(Vec3(10.0, 10.0, 50.0)))
    path.init_path(None, None, end)
    assert path.insert_type == InsertType.PLACEMENT and path.curr_pos is end
    begin = Position(CELL, Frame(Vec3(9.0, 10.0, 50.0)))
    path.init_path(None, begin, end)
    assert path.insert_type == InsertType.TRANSITION and path.curr_pos is begin
    assert path.global_curr_center[0].center == Vec3(9.0, 10.0, 50.5)


def test_the_global_spheres_follow_the_check_positions_frame() -> None:
    """SpherePath.CacheGlobalSphere: at heading 90 (an object's +y along the world's +x) a sphere
    0.5 m ahead of the origin and 1 m up is 0.5 m east of it."""
    path = _path(Vec3(10.0, 10.0, 50.0), [FOOT, Sphere(Vec3(0.0, 0.5, 1.0), 0.25)])
    path.set_check_pos(Position(CELL, Frame(Vec3(10.0, 10.0, 50.0), Quat.from_heading(90.0))), None)
    head = path.global_sphere[1].center
    assert abs(head.x - 10.5) < 1e-5 and abs(head.y - 10.0) < 1e-5 and head.z == 51.0
    assert path.global_sphere[1].radius == 0.25


def test_shifting_the_check_position_moves_its_spheres_and_low_point() -> None:
    """SpherePath.AddOffsetToCheckPos: origin, both global spheres and the low point move by the offset."""
    path = _path(Vec3(10.0, 10.0, 50.0))
    path.add_offset_to_check_pos(Vec3(0.25, -0.5, 0.125))
    assert path.check_pos.frame.origin == Vec3(10.25, 9.5, 50.125)
    assert [s.center for s in path.global_sphere] == [Vec3(10.25, 9.5, 50.625), Vec3(10.25, 9.5, 51.625)]
    assert path.global_low_point == Vec3(10.25, 9.5, 50.125)
    assert path.global_curr_center[0].center == Vec3(10.0, 10.0, 50.5)  # the current position's stay


def test_save_and_restore_put_the_check_position_back() -> None:
    """SpherePath.SaveCheckPos / RestoreCheckPos: the check position and its spheres as saved."""
    path = _path(Vec3(10.0, 10.0, 50.0))
    path.save_check_pos()
    path.add_offset_to_check_pos(Vec3(1.0, 1.0, 1.0))
    path.restore_check_pos()
    assert path.check_pos.frame.origin == Vec3(10.0, 10.0, 50.0)
    assert path.global_sphere[0].center == Vec3(10.0, 10.0, 50.5)


def test_adjust_check_pos_rehomes_an_origin_into_the_next_landblock() -> None:
    """SpherePath.AdjustCheckPos: x = 193 in A9B4 is x = 1 in AAB4 (192 m east), spheres too."""
    path = _path(Vec3(193.0, 10.0, 50.0))
    path.adjust_check_pos(EAST_CELL)
    assert path.check_pos.cell_id == EAST_CELL
    assert path.check_pos.frame.origin == Vec3(1.0, 10.0, 50.0)
    assert path.global_sphere[0].center == Vec3(1.0, 10.0, 50.5)


def test_walkable_bookkeeping() -> None:
    """SpherePath: IsWalkableAllowable is a strict z > allowance; SetCollide remembers the check
    position and the normal and starts a full walk interpolation; SetNegPolyHit keeps the head's
    normal reversed; CheckWalkables with no walkable is true."""
    path = _path(Vec3(10.0, 10.0, 50.0))
    path.walkable_allowance = 0.5
    assert path.is_walkable_allowable(0.6) and not path.is_walkable_allowable(0.5)
    normal = Vec3(-1.0, 0.0, 0.0)
    path.set_collide(normal)
    assert path.collide and path.backup_check_pos is path.check_pos and path.step_up_normal == normal
    assert path.walk_interp == 1.0
    path.set_neg_poly_hit(True, normal)
    assert path.neg_poly_hit and path.neg_step_up and path.neg_collision_normal == Vec3(1.0, 0.0, 0.0)
    assert path.walkable is None and path.check_walkables()


def _transition(step: Vec3) -> Transition:
    """A bare transition one step of `step` from (10, 10, 50), last standing on flat ground z = 50."""
    t = Transition(None)  # type: ignore[arg-type]  # no cells: none is looked up
    path = t.sphere_path
    path.init_sphere([FOOT], 1.0)
    begin = Position(CELL, Frame(Vec3(10.0, 10.0, 50.0)))
    end = Position(CELL, Frame(Vec3(10.0, 10.0, 50.0) + step))
    path.init_path(None, begin, end)
    path.set_check_pos(end, None)
    t.init_last_known_contact_plane(CELL, Plane(UP, -50.0), False)
    return t


def test_step_up_slide_slides_along_the_failed_step_ups_normal() -> None:
    """SpherePath.StepUpSlide: the contact plane dropped, the step (0.25, 0.125) slides along the
    crease of the wall (normal -x) and the last known ground: the 0.125 m along y is kept. Slid."""
    t = _transition(Vec3(0.25, 0.125, 0.0))
    t.init_contact_plane(CELL, Plane(UP, -50.0), False)
    t.sphere_path.step_up_normal = Vec3(-1.0, 0.0, 0.0)
    assert t.sphere_path.step_up_slide(t) == TS.SLID
    assert not t.collision_info.contact_plane_valid
    assert t.sphere_path.check_pos.frame.origin == Vec3(10.0, 10.125, 50.0)


def test_precipice_slide_keeps_the_mover_on_its_walkable() -> None:
    """SpherePath.PrecipiceSlide: on a walkable floor ending at x = 10.125 (its east edge), a step
    (0.25, 0.125) whose sphere centre leaves it over that edge slides along it. The crossed edge's
    normal points back into the floor (-x; CPolygon::find_crossed_edge), already against the step,
    so it stays; its crease with the ground runs along y: the step along y is kept, the step across
    the edge taken back. The walkable is forgotten."""
    t = _transition(Vec3(0.25, 0.125, 0.0))
    path = t.sphere_path
    # the floor polygon in its own frame, which is the landblock's (identity at the origin)
    floor = Polygon([Vec3(0.0, 0.0, 50.0), Vec3(10.125, 0.0, 50.0), Vec3(10.125, 20.0, 50.0), Vec3(0.0, 20.0, 50.0)])
    local = Position(CELL, Frame(Vec3(0.0, 0.0, 0.0)))
    path.set_walkable(path.global_sphere[0], floor, UP, local, 1.0)
    assert path.precipice_slide(t) == TS.SLID
    assert path.walkable is None
    assert path.check_pos.frame.origin == Vec3(10.0, 10.125, 50.0)
    assert t.collision_info.collision_normal == Vec3(-1.0, 0.0, 0.0)


def test_precipice_slide_with_no_edge_crossed_is_a_stop() -> None:
    """SpherePath.PrecipiceSlide: the sphere centre still over the floor (x = 10.0625 < 10.125): no
    crossed edge, Collided, the check position unmoved, the walkable forgotten."""
    t = _transition(Vec3(0.0625, 0.125, 0.0))
    path = t.sphere_path
    floor = Polygon([Vec3(0.0, 0.0, 50.0), Vec3(10.125, 0.0, 50.0), Vec3(10.125, 20.0, 50.0), Vec3(0.0, 20.0, 50.0)])
    path.set_walkable(path.global_sphere[0], floor, UP, Position(CELL, Frame(Vec3(0.0, 0.0, 0.0))), 1.0)
    assert path.precipice_slide(t) == TS.COLLIDED
    assert path.walkable is None
    assert path.check_pos.frame.origin == Vec3(10.0625, 10.125, 50.0)
