"""engine/transition/walkable.py: ObjectInfo.ValidateWalkable, the terrain contact rule, called directly.

A foot sphere of radius 0.5 whose check position (its low point) is placed by hand against a plane:
flat ground z = 50, a walkable 45 degree ramp z - 50 = x - 10 (normal (-1, 0, 1) / sqrt 2, n.z 0.7071
above FloorZ 0.6642) and an unwalkable one rising 1.25 m per metre (normal (-1.25, 0, 1) / 1.6008,
n.z 0.6247). The rule (the seed's pseudocode, ValidateWalkable):

- the low point's signed distance to the plane (lifted by any water depth) within EPSILON: resting,
  OK, the plane becomes the contact plane (for a grounded mover only if walkable);
- above: OK, nothing recorded; below: lifted straight up by distance / n.z (Adjusted), unless the
  plane is unwalkable under a grounded mover, or a CheckWalkable probe is running (Collided), or a
  step-down would go back up past its start (walk interpolation, Collided);
- a mover not in contact gets the plane's normal as its collision normal;
- a camera (IsViewer) is pulled back along its step until its sphere just touches the plane.

Coordinates are float32-exact where the answer is exact.
"""

from __future__ import annotations

import math

import pytest

from engine.constants import EPSILON
from engine.geometry import Frame, Plane, Position, Sphere, Vec3
from engine.transition.object_info import ObjectInfo
from engine.transition.state import OI, TransitionState as TS
from engine.transition.transition import Transition
from engine.transition.walkable import validate_walkable

CELL = 0xA9B40001
UP = Vec3(0.0, 0.0, 1.0)
R = 0.5
FLAT = Plane(UP, -50.0)
_S45 = math.sqrt(0.5)
#: z - 50 = x - 10, through (10, y, 50)
RAMP_45 = Plane(Vec3(-_S45, 0.0, _S45), (10.0 - 50.0) * _S45)
_L51 = math.hypot(1.25, 1.0)
#: z - 50 = 1.25 (x - 10)
RAMP_51 = Plane(Vec3(-1.25 / _L51, 0.0, 1.0 / _L51), (12.5 - 50.0) / _L51)
GROUNDED = OI.CONTACT | OI.ON_WALKABLE


def _transition(origin: Vec3, state: int = GROUNDED, *, begin: Vec3 | None = None, radius: float = R,
                begin_cell: int = CELL) -> Transition:
    """A bare transition (no cells: ValidateWalkable looks none up) whose check position is `origin`,
    having come from `begin` (default: the same place)."""
    t = Transition(None)  # type: ignore[arg-type]
    t.init_object(ObjectInfo(state))
    t.init_sphere([Sphere(Vec3(0.0, 0.0, radius), radius)], 1.0)
    end = Position(CELL, Frame(origin))
    t.init_path(None, Position(begin_cell, Frame(origin if begin is None else begin)), end)
    t.sphere_path.set_check_pos(end, None)
    return t


def _validate(t: Transition, plane: Plane, is_water: bool = False, water_depth: float = 0.0) -> int:
    return validate_walkable(t, t.sphere_path.global_sphere[0], plane, is_water, water_depth, CELL)


def _origin(t: Transition) -> Vec3:
    return t.sphere_path.check_pos.frame.origin


def test_a_sphere_above_the_ground_is_left_alone() -> None:
    """ObjectInfo.ValidateWalkable: the low point 1 m above: OK, no contact plane, no normal."""
    t = _transition(Vec3(10.0, 10.0, 51.0))
    assert _validate(t, FLAT) == TS.OK
    assert _origin(t) == Vec3(10.0, 10.0, 51.0)
    assert not t.collision_info.contact_plane_valid and not t.collision_info.collision_normal_valid


@pytest.mark.parametrize("gap", [0.0, EPSILON / 2, -EPSILON / 2])
def test_a_sphere_resting_on_the_ground_takes_it_as_contact_plane(gap: float) -> None:
    """ObjectInfo.ValidateWalkable: the low point within EPSILON of the plane, either side: OK,
    unmoved, and the plane is the contact plane of this cell."""
    t = _transition(Vec3(10.0, 10.0, 50.0 + gap))
    before = _origin(t)
    assert _validate(t, FLAT) == TS.OK
    ci = t.collision_info
    assert _origin(t) == before
    assert ci.contact_plane_valid and ci.contact_plane is FLAT and ci.contact_plane_cell_id == CELL
    assert not ci.collision_normal_valid  # already in contact: no collision to report


def test_a_falling_sphere_that_lands_reports_the_ground_as_collision_normal() -> None:
    """ObjectInfo.ValidateWalkable: not in Contact: resting on the ground is a collision with the
    environment, its normal the plane's."""
    t = _transition(Vec3(10.0, 10.0, 50.0), state=0)
    assert _validate(t, FLAT) == TS.OK
    ci = t.collision_info
    assert ci.contact_plane_valid and ci.collision_normal == UP and ci.collided_with_environment


def test_a_sphere_below_flat_ground_is_lifted_onto_it() -> None:
    """ObjectInfo.ValidateWalkable: the low point 0.125 m under: Adjusted, lifted by 0.125 m."""
    t = _transition(Vec3(10.0, 10.0, 49.875))
    assert _validate(t, FLAT) == TS.ADJUSTED
    assert _origin(t) == Vec3(10.0, 10.0, 50.0)
    assert t.sphere_path.global_sphere[0].center == Vec3(10.0, 10.0, 50.5)  # the sphere moves with it
    assert t.collision_info.contact_plane_valid


def test_a_sphere_below_a_45_degree_ramp_is_lifted_straight_up_onto_it() -> None:
    """ObjectInfo.ValidateWalkable: at x = 11 the ramp is at z = 51; a low point at 50.875 is
    0.125 / sqrt 2 from the plane, lifted by distance / n.z = 0.125 straight up (x unchanged)."""
    t = _transition(Vec3(11.0, 10.0, 50.875))
    assert _validate(t, RAMP_45) == TS.ADJUSTED
    o = _origin(t)
    assert o.x == 11.0 and o.y == 10.0 and o.z == pytest.approx(51.0, abs=1e-5)
    assert t.collision_info.contact_plane is RAMP_45


def test_an_unwalkable_ramp_does_not_lift_a_grounded_sphere() -> None:
    """ObjectInfo.ValidateWalkable: below a ramp of n.z 0.6247 < FloorZ, a mover on walkable ground
    is neither lifted nor given the ramp as contact plane (it will slide off it: Adjusted)."""
    t = _transition(Vec3(11.0, 10.0, 51.0))  # the ramp is at 51.25 here
    assert _validate(t, RAMP_51) == TS.ADJUSTED
    assert _origin(t) == Vec3(11.0, 10.0, 51.0)
    assert not t.collision_info.contact_plane_valid


def test_an_unwalkable_ramp_lifts_a_sphere_not_on_walkable_ground() -> None:
    """ObjectInfo.ValidateWalkable: a mover in Contact but not OnWalkable lands on any slope:
    lifted by (51.25 - 51) = 0.25 m, the ramp its contact plane."""
    t = _transition(Vec3(11.0, 10.0, 51.0), state=OI.CONTACT)
    assert _validate(t, RAMP_51) == TS.ADJUSTED
    assert _origin(t).z == pytest.approx(51.25, abs=1e-5)
    assert t.collision_info.contact_plane is RAMP_51


def test_a_check_walkable_probe_below_the_ground_collides() -> None:
    """ObjectInfo.ValidateWalkable during CheckWalkable: ground above the probe is Collided, unmoved."""
    t = _transition(Vec3(10.0, 10.0, 49.875))
    t.sphere_path.check_walkable = True
    assert _validate(t, FLAT) == TS.COLLIDED
    assert _origin(t) == Vec3(10.0, 10.0, 49.875)


@pytest.mark.parametrize("depth", [0.125, 0.25, 0.5])
def test_a_step_down_landing_scales_its_walk_interpolation(depth: float) -> None:
    """ObjectInfo.ValidateWalkable in a StepDown of 0.5 m (walk interpolation 1): ground `depth`
    above the probed low point is landed on, leaving interp = 1 - depth / 0.5 (at 0.5 m the probe
    lands where it started: 0, still above the -0.1 floor)."""
    t = _transition(Vec3(10.0, 10.0, 50.0 - depth))
    path = t.sphere_path
    path.step_down, path.step_down_amt, path.walk_interp = True, 0.5, 1.0
    assert _validate(t, FLAT) == TS.ADJUSTED
    assert path.walk_interp == pytest.approx(1.0 - depth / 0.5)
    assert _origin(t).z == 50.0
    assert not t.collision_info.collision_normal_valid  # a step-down reports no collision


def test_a_step_down_that_would_rise_past_its_allowance_collides() -> None:
    """ObjectInfo.ValidateWalkable in a StepDown of 0.4 m: ground 0.5 m above the probe: interp
    1 - 0.5 / 0.4 = -0.25 < -0.1: Collided, the check position and walk interpolation unchanged."""
    t = _transition(Vec3(10.0, 10.0, 49.5))
    path = t.sphere_path
    path.step_down, path.step_down_amt, path.walk_interp = True, 0.4, 1.0
    assert _validate(t, FLAT) == TS.COLLIDED
    assert _origin(t) == Vec3(10.0, 10.0, 49.5) and path.walk_interp == 1.0


@pytest.mark.parametrize(("low_z", "state"), [(49.75, TS.OK), (49.5, TS.OK), (49.25, TS.ADJUSTED)])
def test_water_depth_lets_the_sphere_sink_that_far(low_z: float, state: int) -> None:
    """ObjectInfo.ValidateWalkable in 0.5 m of water: the plane counts 0.5 m lower. A low point
    0.25 m under the ground is above it (OK, no contact), 0.5 m under rests (contact, water), 0.75 m
    under is lifted by 0.25 m."""
    t = _transition(Vec3(10.0, 10.0, low_z))
    assert _validate(t, FLAT, is_water=True, water_depth=0.5) == state
    ci = t.collision_info
    assert ci.contact_plane_valid == (low_z <= 49.5)
    if ci.contact_plane_valid:
        assert ci.contact_plane_is_water
        assert _origin(t).z == 49.5


def test_a_camera_is_pulled_back_along_its_step_to_touch_the_ground() -> None:
    """ObjectInfo.ValidateWalkable, IsViewer: a camera sphere (r 0.25) stepping from centre z 51.25
    to 49.25 ends 1 m into flat ground z = 50 (its surface at 49.0): pulled back by
    dist / (step . n) = -1 / -2 of its step, 1 m up, its sphere touching the ground. Adjusted,
    with the ground's normal as collision normal."""
    t = _transition(Vec3(10.0, 10.0, 49.0), state=OI.IS_VIEWER, begin=Vec3(10.0, 10.0, 51.0), radius=0.25)
    assert _validate(t, FLAT) == TS.ADJUSTED
    assert _origin(t) == Vec3(10.0, 10.0, 50.0)
    assert t.sphere_path.global_sphere[0].center.z == 50.25  # resting on the ground
    ci = t.collision_info
    assert ci.collision_normal == UP and ci.collided_with_environment


def test_a_camera_clear_of_the_ground_is_left_alone() -> None:
    """ObjectInfo.ValidateWalkable, IsViewer (retail: outdoors too): a sphere above the plane is OK."""
    t = _transition(Vec3(10.0, 10.0, 50.5), state=OI.IS_VIEWER, begin=Vec3(10.0, 10.0, 51.0), radius=0.25)
    assert _validate(t, FLAT) == TS.OK
    assert _origin(t) == Vec3(10.0, 10.0, 50.5)
