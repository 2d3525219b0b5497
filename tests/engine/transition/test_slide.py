"""Sphere.SlideSphere, branch by branch, on hand geometry.

The environment variant (engine.transition.slide.slide_sphere; the client's
CSphere::slide_sphere, FUN_00538180 in the seed) and the object variant
(slide_sphere_object, double and single precision). Each test sets up one
step of a mover whose foot sphere (radius 0.5) goes from `curr` to `check`
and one obstacle normal, and checks the returned state, where the check
position ends and the collision normal recorded, all worked out by hand:

- a zero normal: the step is halved (Adjusted);
- a wall and the ground meet in a crease: the step is projected onto the
  crease (Slid), or stops when that leaves less than sqrt(EPSILON) = 1.4 cm
  (Collided);
- wall and ground parallel (within sqrt(EPSILON) of it): pushed straight out
  of the wall (Slid); facing each other: the step is given up, the normal
  turned against the step (OK);
- the ground is the contact plane if valid, else the last known one;
- a step that crosses into the next landblock is measured across the edge.

Numbers are chosen exactly representable in float32 where the engine keeps
the check position in single precision, so most answers are exact.
"""

from __future__ import annotations

import dataclasses
import math

import pytest

from engine.constants import EPSILON
from engine.geometry import Frame, Plane, Position, Sphere, Vec3
from engine.transition.slide import slide_sphere, slide_sphere_object
from engine.transition.state import TransitionState as TS
from engine.settings import RETAIL
from engine.transition.transition import Transition

DOUBLE = dataclasses.replace(RETAIL, single_precision=False)
CELL = 0xA9B40001  # landblock A9B4, outdoor cell (0, 0)
EAST_CELL = 0xAAB40001  # the landblock east of it, 192 m further along x
R = 0.5
UP = Vec3(0.0, 0.0, 1.0)
GROUND = Plane(UP, -50.0)  # flat ground at z = 50
CURR = Vec3(10.0, 10.0, 50.0)  # the mover's origin before the step; its foot sphere's centre is 0.5 higher


def _transition(step: Vec3, *, single: bool = True, head: bool = False, curr: Vec3 = CURR,
                curr_cell: int = CELL, check_cell: int = CELL, check: Vec3 | None = None) -> Transition:
    """A transition part-way through one step from `curr` by `step`, standing on GROUND."""
    t = Transition(None, RETAIL if single else DOUBLE)  # type: ignore[arg-type]  # no cells: none is looked up
    path = t.sphere_path
    spheres = [Sphere(Vec3(0.0, 0.0, R), R)]
    if head:
        spheres.append(Sphere(Vec3(0.0, 0.0, R + 1.0), R))
    path.init_sphere(spheres, 1.0)
    begin = Position(curr_cell, Frame(curr))
    end = Position(check_cell, Frame(curr + step if check is None else check))
    path.init_path(None, begin, end)
    path.set_check_pos(end, None)
    t.init_contact_plane(CELL, GROUND, False)
    return t


def _slide(t: Transition, normal: Vec3, sphere_index: int = 0) -> int:
    path = t.sphere_path
    return slide_sphere(t, normal, path.global_curr_center[sphere_index].center,
                        None if sphere_index == 0 else path.global_sphere[sphere_index])


def _check_origin(t: Transition) -> Vec3:
    return t.sphere_path.check_pos.frame.origin


def _near(v: Vec3, x: float, y: float, z: float, tol: float) -> bool:
    return abs(v.x - x) <= tol and abs(v.y - y) <= tol and abs(v.z - z) <= tol


# -- the environment variant (FUN_00538180) -------------------------------------------


def test_a_zero_normal_takes_back_half_the_step() -> None:
    t = _transition(Vec3(0.25, 0.125, -0.5))
    assert _slide(t, Vec3(0.0, 0.0, 0.0)) == TS.ADJUSTED
    assert _check_origin(t) == Vec3(10.125, 10.0625, 49.75)
    assert not t.collision_info.collision_normal_valid  # no wall, no normal


def test_a_wall_on_flat_ground_keeps_the_step_along_the_wall() -> None:
    # a wall facing -x across the step (0.25, 0.125): the crease with the ground runs along y,
    # so the 0.125 m along y is kept and the 0.25 m into the wall is taken back
    t = _transition(Vec3(0.25, 0.125, 0.0))
    assert _slide(t, Vec3(-1.0, 0.0, 0.0)) == TS.SLID
    assert _check_origin(t) == Vec3(10.0, 10.125, 50.0)
    assert t.collision_info.collision_normal_valid and t.collision_info.collision_normal == Vec3(-1.0, 0.0, 0.0)


def test_the_slide_follows_the_crease_with_a_slope() -> None:
    # on ground rising to the north (normal (0, 0.6, 0.8)) the crease with a wall facing -x is
    # (0, 0.8, -0.6): of the step (0.25, 0.125, 0) what remains is 0.1 m along it
    t = _transition(Vec3(0.25, 0.125, 0.0))
    t.init_contact_plane(CELL, Plane(Vec3(0.0, 0.6, 0.8), -40.0), False)
    assert _slide(t, Vec3(-1.0, 0.0, 0.0)) == TS.SLID
    assert _near(_check_origin(t), 10.0, 10.08, 49.94, 1e-5)  # float32 positions near 50 m


def test_the_last_known_plane_is_the_ground_when_there_is_no_contact_plane() -> None:
    # the contact plane (flat) is not valid; the last known one is the slope of the test above
    t = _transition(Vec3(0.25, 0.125, 0.0))
    ci = t.collision_info
    ci.last_known_contact_plane = Plane(Vec3(0.0, 0.6, 0.8), -40.0)
    ci.last_known_contact_plane_valid = True
    ci.contact_plane_valid = False
    assert ci.contact_plane == GROUND
    assert _slide(t, Vec3(-1.0, 0.0, 0.0)) == TS.SLID
    assert _near(_check_origin(t), 10.0, 10.08, 49.94, 1e-5)


def test_straight_into_a_wall_is_a_stop() -> None:
    t = _transition(Vec3(0.25, 0.0, 0.0))
    before = _check_origin(t)
    assert _slide(t, Vec3(-1.0, 0.0, 0.0)) == TS.COLLIDED
    assert _check_origin(t) == before
    assert t.collision_info.collision_normal == Vec3(-1.0, 0.0, 0.0)


@pytest.mark.parametrize(("along", "state"), [(0.0140, TS.COLLIDED), (0.0145, TS.SLID)])
def test_a_slide_shorter_than_the_root_of_epsilon_is_a_stop(along: float, state: int) -> None:
    assert along**2 < EPSILON if state == TS.COLLIDED else along**2 > EPSILON  # 1.96e-4 and 2.10e-4
    t = _transition(Vec3(0.25, along, 0.0))
    before = _check_origin(t)
    assert _slide(t, Vec3(-1.0, 0.0, 0.0)) == state
    if state == TS.SLID:
        assert _near(_check_origin(t), 10.0, 10.0 + along, 50.0, 1e-6)
    else:
        assert _check_origin(t) == before


def test_a_wall_parallel_to_the_ground_pushes_straight_out() -> None:
    # a "wall" facing up, like the ground: no crease; the step's 0.125 m down into it is taken back
    t = _transition(Vec3(0.25, 0.0, -0.125))
    assert _slide(t, UP) == TS.SLID
    assert _check_origin(t) == Vec3(10.25, 10.0, 50.0)
    assert t.collision_info.collision_normal == UP


@pytest.mark.parametrize(("tilt_degrees", "parallel"), [(0.5, True), (1.0, False)])
def test_a_wall_within_the_root_of_epsilon_of_the_ground_counts_as_parallel(tilt_degrees: float, parallel: bool) -> None:
    # the crease of unit normals is sin(angle) long: sin^2 is 7.6e-5 at 0.5 degrees, 3.05e-4 at 1 degree
    a = math.radians(tilt_degrees)
    assert (math.sin(a) ** 2 < EPSILON) == parallel
    normal = Vec3(-math.sin(a), 0.0, math.cos(a))
    t = _transition(Vec3(0.0, 0.25, -0.125))
    assert _slide(t, normal) == TS.SLID
    origin = _check_origin(t)
    if parallel:
        # pushed out along the normal by the step's depth into it; the step along y is kept
        assert _near(origin, 10.0 - 0.125 * math.sin(a) * math.cos(a), 10.25, 50.0 - 0.125 + 0.125 * math.cos(a) ** 2, 1e-5)
    else:
        # the crease with flat ground runs along y: only the y part of the step is kept
        assert _near(origin, 10.0, 10.25, 50.0, 1e-5)


def test_a_ceiling_facing_the_ground_gives_the_step_up() -> None:
    # a ceiling (normal down) over flat ground: the step is left as it is, and the collision
    # normal turned against the step, (-0.25, 0, -0.25) normalized
    t = _transition(Vec3(0.25, 0.0, 0.25))
    before = _check_origin(t)
    assert _slide(t, Vec3(0.0, 0.0, -1.0)) == TS.OK
    assert _check_origin(t) == before
    s = math.sqrt(0.5)
    assert _near(t.collision_info.collision_normal, -s, 0.0, -s, 1e-12)


def test_a_ceiling_with_no_step_keeps_its_own_normal() -> None:
    t = _transition(Vec3(0.0, 0.0, 0.0))
    assert _slide(t, Vec3(0.0, 0.0, -1.0)) == TS.OK
    assert t.collision_info.collision_normal == Vec3(0.0, 0.0, -1.0)


def test_a_step_into_the_next_landblock_slides_by_the_step_across_the_edge() -> None:
    # from x = 191.875 in A9B4 to x = 0.125 in the landblock east (192 m on): the step is (0.25, 0.125)
    t = _transition(Vec3(0.0, 0.0, 0.0), curr=Vec3(191.875, 10.0, 50.0), curr_cell=0xA9B40039,
                    check_cell=EAST_CELL, check=Vec3(0.125, 10.125, 50.0))
    assert _slide(t, Vec3(-1.0, 0.0, 0.0)) == TS.SLID
    # back to x = 191.875 (-0.125 in the east landblock's frame), the 0.125 m along y kept
    assert t.sphere_path.check_pos.cell_id == EAST_CELL
    assert _check_origin(t) == Vec3(-0.125, 10.125, 50.0)


def test_the_head_sphere_slides_by_its_own_step() -> None:
    # the head sphere (given, with its own current centre) slides exactly as the foot would
    t = _transition(Vec3(0.25, 0.125, 0.0), head=True)
    assert _slide(t, Vec3(-1.0, 0.0, 0.0), sphere_index=1) == TS.SLID
    assert _check_origin(t) == Vec3(10.0, 10.125, 50.0)
    assert t.sphere_path.global_sphere[1].center == Vec3(10.0, 10.125, 51.5)


# -- the object variant -----------------------------------------------------------------

PRECISIONS = pytest.mark.parametrize("single", [True, False], ids=["float32", "float64"])


def _slide_off(t: Transition, obstacle: Vec3, disp: Vec3) -> int:
    return slide_sphere_object(t, obstacle, disp, 0)


@PRECISIONS
def test_sliding_past_an_object_keeps_the_step_around_it(single: bool) -> None:
    # an obstacle sphere due east of the foot sphere: the normal is -x, the crease with the ground y
    t = _transition(Vec3(0.25, 0.125, 0.0), single=single)
    assert _slide_off(t, Vec3(11.0, 10.0, 50.5), Vec3(0.25, 0.125, 0.0)) == TS.SLID
    assert _check_origin(t) == Vec3(10.0, 10.125, 50.0)
    assert t.collision_info.collision_normal == Vec3(-1.0, 0.0, 0.0)


@PRECISIONS
def test_straight_at_an_object_is_a_stop(single: bool) -> None:
    t = _transition(Vec3(0.25, 0.0, 0.0), single=single)
    before = _check_origin(t)
    assert _slide_off(t, Vec3(11.0, 10.0, 50.5), Vec3(0.25, 0.0, 0.0)) == TS.COLLIDED
    assert _check_origin(t) == before
    assert t.collision_info.collision_normal == Vec3(-1.0, 0.0, 0.0)


@PRECISIONS
def test_an_object_at_the_spheres_own_centre_is_a_stop_with_no_normal(single: bool) -> None:
    t = _transition(Vec3(0.25, 0.125, 0.0), single=single)
    assert _slide_off(t, Vec3(10.0, 10.0, 50.5), Vec3(0.25, 0.125, 0.0)) == TS.COLLIDED
    assert not t.collision_info.collision_normal_valid


@PRECISIONS
def test_standing_on_an_object_pushes_out_of_it_unless_moving_down_into_it(single: bool) -> None:
    # the obstacle straight below: its normal is the ground's, no crease
    t = _transition(Vec3(0.25, 0.0, -0.125), single=single)
    assert _slide_off(t, Vec3(10.0, 10.0, 49.5), Vec3(0.25, 0.0, 0.0)) == TS.SLID
    assert _check_origin(t) == Vec3(10.25, 10.0, 50.0)  # the 0.125 m down into it taken back
    t = _transition(Vec3(0.25, 0.0, -0.125), single=single)
    before = _check_origin(t)
    assert _slide_off(t, Vec3(10.0, 10.0, 49.5), Vec3(0.25, 0.0, -0.125)) == TS.COLLIDED
    assert _check_origin(t) == before


@PRECISIONS
def test_an_object_slide_into_the_next_landblock_is_measured_across_the_edge(single: bool) -> None:
    t = _transition(Vec3(0.0, 0.0, 0.0), single=single, curr=Vec3(191.875, 10.0, 50.0), curr_cell=0xA9B40039,
                    check_cell=EAST_CELL, check=Vec3(0.125, 10.125, 50.0))
    assert _slide_off(t, Vec3(192.875, 10.0, 50.5), Vec3(0.25, 0.125, 0.0)) == TS.SLID
    assert _check_origin(t) == Vec3(-0.125, 10.125, 50.0)
