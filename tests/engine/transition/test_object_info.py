"""engine/transition/object_info.py: ObjectInfo's walkable test and step search.

FloorZ is 0.6642 (cos 48.4 degrees): a 45 degree slope (normal z cos 45 = 0.7071) is walkable, a
50 degree one (cos 50 = 0.6428) is not. A grounded object searches for a step with its own height
at FloorZ; anything else with the 4 cm probe at LandingZ (0.0872, cos 85 degrees).
"""

from __future__ import annotations

import math

import pytest

from engine.constants import FLOOR_Z, LANDING_Z, STEP_DOWN_PROBE
from engine.geometry import Vec3
from engine.transition.object_info import ObjectInfo, is_valid_walkable
from engine.transition.state import OI


def _slope(degrees: float) -> Vec3:
    a = math.radians(degrees)
    return Vec3(-math.sin(a), 0.0, math.cos(a))


@pytest.mark.parametrize(("degrees", "walkable"), [(0.0, True), (45.0, True), (48.0, True), (49.0, False), (50.0, False), (90.0, False)])
def test_is_valid_walkable_up_to_48_point_4_degrees(degrees: float, walkable: bool) -> None:
    """PhysicsObj.is_valid_walkable: normal z >= FloorZ, i.e. a slope of at most acos(0.6642) = 48.4 degrees."""
    assert math.degrees(math.acos(FLOOR_Z)) == pytest.approx(48.38, abs=0.01)
    assert is_valid_walkable(_slope(degrees)) == walkable
    assert ObjectInfo().is_valid_walkable(_slope(degrees)) == walkable


def test_step_search_on_walkable_ground_uses_the_objects_own_height() -> None:
    """ObjectInfo step search (StepUp, TransitionalInsert's step-down): on a walkable, FloorZ and the
    height asked for."""
    oi = ObjectInfo(OI.CONTACT | OI.ON_WALKABLE)
    assert oi.step_search(0.4) == (FLOOR_Z, 0.4)


@pytest.mark.parametrize("state", [0, OI.CONTACT])
def test_step_search_off_walkable_ground_probes_four_centimetres_at_landing_z(state: int) -> None:
    """ObjectInfo step search: not OnWalkable (falling, or on a steep slope): LandingZ and 0.04 m."""
    assert ObjectInfo(state).step_search(0.4) == (LANDING_Z, STEP_DOWN_PROBE)
    assert STEP_DOWN_PROBE == pytest.approx(0.04)
    assert math.degrees(math.acos(LANDING_Z)) == pytest.approx(85.0, abs=0.01)


def test_stop_velocity_and_missile_without_a_mover() -> None:
    """ObjectInfo.StopVelocity does nothing with no mover behind it; IsMissile reads the stand-in flag,
    and with a mover, the mover's own."""
    oi = ObjectInfo()
    oi.stop_velocity()
    oi.missile = True
    assert oi.is_missile()

    class Mover:
        missile = False
        stopped = False

        def stop_velocity(self) -> None:
            self.stopped = True

    mover = Mover()
    oi = ObjectInfo(obj=mover)
    oi.missile = True
    assert not oi.is_missile()
    oi.stop_velocity()
    assert mover.stopped
