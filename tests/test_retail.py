"""RETAIL's corrections of ACE (docs/divergences.md, "Retail against ACE: survey").

Expected values come from the client's own rules worked by hand here:
the physics step ladder of PhysicsObj.update_object, calc_friction's
sledding branch and calc_acceleration. The engine computes in single
precision, these in double, hence the small tolerances.
"""

from __future__ import annotations

import dataclasses
import math

import pytest

import engine
from engine import MoverSpec, Position, SphereSpec, Vec3
from engine.constants import HUGE_QUANTUM
from engine.world.quantum import split_elapsed
from benchmarks.scenes import PLAYER, world_from_heights
from test_scenarios import cell_at, standing

G = 9.8
#: one float32 step at the speeds and distances below, with room for a few dozen roundings
TOL = 2e-5


# -- the physics step ladder ---------------------------------------------------------


@pytest.mark.parametrize(
    ("elapsed", "quanta", "held"),
    [
        (0.01, [], 0.01),  # below 1/30 s: waits
        (1.0 / 30.0, [1.0 / 30.0], 0.0),  # the minimum itself runs
        (0.19, [0.19], 0.0),  # up to the maximum quantum: one step
        (0.2, [0.2], 0.0),
        (0.23, [0.2], 0.03),  # 0.03 left is not above 1/30: kept for later
        (0.24, [0.2, 0.04], 0.0),  # 0.04 left is: it runs
        (0.45, [0.2, 0.2, 0.05], 0.0),
        (2.0, [0.2] * 10, 0.0),
    ],
)
def test_the_ladder_splits_elapsed_time_as_update_object_does(elapsed: float, quanta: list[float], held: float) -> None:
    split = split_elapsed(elapsed, 0.2)
    assert not split.dropped
    assert list(split.quanta) == pytest.approx(quanta, abs=1e-12)
    assert split.held == pytest.approx(held, abs=1e-12)
    assert sum(split.quanta) + split.held == pytest.approx(elapsed, abs=1e-12)


def test_time_beyond_the_huge_quantum_is_dropped_whole() -> None:
    split = split_elapsed(HUGE_QUANTUM + 0.01, 0.2)
    assert split.dropped and split.quanta == () and split.held == 0.0


def test_the_ace_ladder_steps_a_tenth_of_a_second() -> None:
    assert list(split_elapsed(0.45, 0.1).quanta) == pytest.approx([0.1, 0.1, 0.1, 0.1, 0.05], abs=1e-12)
    assert list(split_elapsed(0.43, 0.1).quanta) == pytest.approx([0.1, 0.1, 0.1, 0.1], abs=1e-12)
    assert split_elapsed(0.43, 0.1).held == pytest.approx(0.03, abs=1e-12)


def test_the_retail_and_ace_quanta() -> None:
    assert engine.RETAIL.quantum_ladder and engine.RETAIL.max_quantum == 0.2
    assert not engine.ACE_COMPAT.quantum_ladder and engine.ACE_COMPAT.max_quantum == 0.1
    with pytest.raises(ValueError, match="max_quantum"):
        dataclasses.replace(engine.RETAIL, max_quantum=0.01)


def _floating(settings: engine.EngineSettings) -> tuple[engine.World, int]:
    """A mover at rest 60 m above flat ground, not in contact: it falls."""
    world = world_from_heights(lambda bx, by, x, y: 100, settings=settings)
    spec = dataclasses.replace(PLAYER, state=["IsPlayer"])
    mid = world.add_mover(spec, Position.at(cell_at(50.0, 50.0), Vec3(50.0, 50.0, 110.0)))
    return world, mid


def _fall(quanta: list[float]) -> tuple[float, float]:
    """Drop and velocity after falling from rest in these physics steps, by
    UpdatePhysicsInternal: the origin moves by a q^2 / 2 + v q only once the
    velocity is non-zero; then v += a q."""
    z = v = 0.0
    for q in quanta:
        if v != 0.0:
            z += -G * 0.5 * q * q + v * q
        v += -G * q
    return z, v


def test_a_long_frame_falls_in_quanta_of_a_fifth_of_a_second() -> None:
    world, mid = _floating(engine.RETAIL)
    z0 = world.mover(mid).position.frame.origin.z
    result = world.step(mid, Vec3(0.0, 0.0, 0.0), 0.5)
    drop, v = _fall([0.2, 0.2, 0.1])  # -1.029 m, -4.9 m/s
    assert result.ok and result.transition_state == "OK"
    assert result.position.frame.origin.z - z0 == pytest.approx(drop, abs=TOL)
    assert world.mover(mid).velocity.z == pytest.approx(v, abs=TOL)


def test_ace_compat_integrates_the_frame_in_one_step() -> None:
    world, mid = _floating(engine.ACE_COMPAT)
    z0 = world.mover(mid).position.frame.origin.z
    world.step(mid, Vec3(0.0, 0.0, 0.0), 0.5)
    # one step from rest: velocity, no displacement
    assert world.mover(mid).position.frame.origin.z == z0
    assert world.mover(mid).velocity.z == pytest.approx(-G * 0.5, abs=TOL)


def test_short_frames_wait_until_a_thirtieth_of_a_second_has_passed() -> None:
    world, mid = _floating(engine.RETAIL)
    z0 = world.mover(mid).position.frame.origin.z
    speeds = []
    for _ in range(6):
        answer = world.step(mid, Vec3(0.0, 0.0, 0.0), 1.0 / 60.0)
        assert answer.ok
        speeds.append(world.mover(mid).velocity.z)
    # every other 60 Hz frame runs one 1/30 s step; the others run nothing
    dv = -G / 30.0
    assert speeds == pytest.approx([0.0, dv, dv, 2 * dv, 2 * dv, 3 * dv], abs=TOL)
    drop, v = _fall([1.0 / 30.0] * 3)
    assert world.mover(mid).position.frame.origin.z - z0 == pytest.approx(drop, abs=TOL)
    assert world.mover(mid).velocity.z == pytest.approx(v, abs=TOL)


def test_a_frame_beyond_the_huge_quantum_is_dropped_and_the_clock_starts_again() -> None:
    world, mid = _floating(engine.RETAIL)
    z0 = world.mover(mid).position.frame.origin.z
    world.step(mid, Vec3(0.0, 0.0, 0.0), 0.02)  # held
    result = world.step(mid, Vec3(0.0, 0.0, 0.0), HUGE_QUANTUM)  # 2.02 s with the held time: dropped
    assert result.transition_state == "NoTransition"
    assert world.mover(mid).position.frame.origin.z == z0 and world.mover(mid).velocity.z == 0.0
    # nothing of the dropped or held time is left over: 0.02 s now waits again
    assert world.step(mid, Vec3(0.0, 0.0, 0.0), 0.02).transition_state == "NoTransition"
    assert world.mover(mid).velocity.z == 0.0


def _walker(settings: engine.EngineSettings) -> tuple[engine.World, int]:
    world = world_from_heights(lambda bx, by, x, y: 100, settings=settings)
    return world, standing(world, 40.0, 50.0)


def test_a_two_second_frame_walks_its_whole_motion() -> None:
    # 20 m in one transition is more than the client's 30 sub-steps of a 0.48 m
    # sphere allow; split into ten 0.2 s steps of 2 m each it is walked
    world, mid = _walker(engine.RETAIL)
    x0 = world.mover(mid).position.frame.origin.x
    result = world.step(mid, Vec3(20.0, 0.0, 0.0), 2.0)
    assert result.ok and result.contact and result.on_walkable
    assert result.position.frame.origin.x - x0 == pytest.approx(20.0, abs=1e-4)

    unsplit, mid = _walker(dataclasses.replace(engine.RETAIL, quantum_ladder=False))
    assert unsplit.step(mid, Vec3(20.0, 0.0, 0.0), 2.0).transition_state == "Invalid"


def test_held_time_keeps_its_motion() -> None:
    world, mid = _walker(engine.RETAIL)
    x0 = world.mover(mid).position.frame.origin.x
    first = world.step(mid, Vec3(0.01, 0.0, 0.0), 0.01)
    assert first.transition_state == "NoTransition" and first.position.frame.origin.x == x0
    world.step(mid, Vec3(0.03, 0.0, 0.0), 0.03)  # 0.04 s with the held time: one step of both motions
    assert world.mover(mid).position.frame.origin.x - x0 == pytest.approx(0.04, abs=TOL)
    # a remainder kept after full quanta keeps its share: 0.23 s = 0.2 run + 0.03 held
    world.step(mid, Vec3(2.3, 0.0, 0.0), 0.23)
    assert world.mover(mid).position.frame.origin.x - x0 == pytest.approx(0.04 + 2.0, abs=TOL)
    world.step(mid, Vec3(0.0, 0.0, 0.0), 0.01)  # 0.04 s: the held 0.3 m goes now
    assert world.mover(mid).position.frame.origin.x - x0 == pytest.approx(0.04 + 2.3, abs=TOL)


# -- sledding: calc_friction and calc_acceleration ------------------------------------------

#: 17 height bytes (8.5 m) a 24 m cell: a plane of atan(8.5 / 24) = 19.5 degrees rising to +x
SLOPE_RISE = 8.5
SLOPE = math.atan2(SLOPE_RISE, 24.0)
SLED = MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.5), 0.5)], state=["Contact", "OnWalkable", "EdgeSlide"], sledding=True)


def _sled(settings: engine.EngineSettings, slope_bytes: int, speed: float) -> tuple[engine.World, int, Vec3]:
    """A sled on a plane rising `slope_bytes` height bytes per 24 m in +x, sliding
    downhill (-x) at `speed`; returns the world, the mover and the downhill direction."""
    world = world_from_heights(lambda bx, by, x, y: 20 + slope_bytes * x, settings=settings)
    mid = standing(world, 170.0, 50.0, SLED)
    angle = math.atan2(slope_bytes * 0.5, 24.0)
    downhill = Vec3(-math.cos(angle), 0.0, -math.sin(angle))
    world.set_velocity(mid, downhill * speed)
    return world, mid, downhill


def _client_friction(speed_sq: float, normal_z: float, sled_slope: bool) -> float:
    """calc_friction's coefficient for a sled (PhysicsState.Sledding)."""
    if speed_sq < 1.5625:
        return 1.0
    if speed_sq >= 6.25:
        steep = normal_z < math.cos(math.radians(10.0))
        if (steep if sled_slope else normal_z > 0.99999536):
            return 0.2
    return 0.95


def _slide(speed: float, angle: float, steps: int, q: float, sled_slope: bool, sled_gravity: bool) -> tuple[list[float], float]:
    """Speeds along the slope and the distance slid, step by step, by the client's
    formulas: friction scales the velocity's in-plane part by (1 - f)^q, the origin
    moves by v q + a q^2 / 2, then v += a q; gravity's in-plane part is g sin(angle).
    The normal part gravity adds is taken off again by the next step's friction and
    by the transition, which keeps the sled on the plane."""
    along = G * math.sin(angle) if sled_gravity else 0.0
    across = G * math.cos(angle) * q if sled_gravity else 0.0  # the normal part v carries into calc_friction
    speeds, distance, t, first = [], 0.0, speed, True
    for _ in range(steps):
        speed_sq = t * t + (0.0 if first else across * across)
        first = False
        if speed_sq - 0.0625 < 0.0002:  # UpdatePhysicsInternal: too slow, stop
            t = 0.0
        else:
            t *= (1.0 - _client_friction(speed_sq, math.cos(angle), sled_slope)) ** q
        if t != 0.0 or along != 0.0:
            distance += t * q + along * 0.5 * q * q
        t += along * q
        speeds.append(t)
    return speeds, distance


def _run(world: engine.World, mid: int, downhill: Vec3, steps: int, q: float) -> tuple[list[float], float]:
    start = world.mover(mid).position.frame.origin
    position = world.mover(mid).position
    speeds = []
    for _ in range(steps):
        result = world.step(mid, Vec3(0.0, 0.0, 0.0), q)
        assert result.contact and result.on_walkable
        # a sled at rest on flat ground is pushed straight into it by gravity: the
        # contact plane leaves nothing of that push, and the transition, as the
        # client's, gives up on an empty first sub-step and leaves the sled where it is
        assert result.ok or (result.position.cell_id, result.position.frame.origin) == (position.cell_id, position.frame.origin)
        position = result.position
        speeds.append(world.mover(mid).velocity.dot(downhill))
    return speeds, (world.mover(mid).position.frame.origin - start).dot(downhill)


def test_a_fast_sled_glides_down_a_20_degree_slope_with_gravity() -> None:
    world, mid, downhill = _sled(engine.RETAIL, 17, 3.0)
    speeds, distance = _run(world, mid, downhill, 12, 0.1)
    want_speeds, want_distance = _slide(3.0, SLOPE, 12, 0.1, sled_slope=True, sled_gravity=True)
    assert speeds == pytest.approx(want_speeds, abs=TOL)
    assert distance == pytest.approx(want_distance, abs=1e-4)
    # the low friction (0.2) and gravity speed it up: 3 m/s -> about 5.8 m/s
    assert speeds[-1] > 5.7


def test_ace_grips_the_same_sled_to_a_stop() -> None:
    world, mid, downhill = _sled(engine.ACE_COMPAT, 17, 3.0)
    speeds, distance = _run(world, mid, downhill, 6, 0.1)
    want_speeds, want_distance = _slide(3.0, SLOPE, 6, 0.1, sled_slope=False, sled_gravity=False)
    assert speeds == pytest.approx(want_speeds, abs=TOL)
    assert distance == pytest.approx(want_distance, abs=1e-4)
    assert speeds[-1] == 0.0  # 3 -> 2.22 -> 1.65 -> 1.22 m/s, then below 1.25 m/s: stopped


@pytest.mark.parametrize(("settings", "stops"), [(engine.RETAIL, True), (engine.ACE_COMPAT, False)])
def test_on_flat_ground_the_client_stops_the_sled_where_ace_lets_it_glide(settings: engine.EngineSettings, stops: bool) -> None:
    world, mid, downhill = _sled(settings, 0, 5.0)
    speeds, _ = _run(world, mid, downhill, 10, 0.1)
    want, _ = _slide(5.0, 0.0, 10, 0.1, sled_slope=settings.sled_slope_friction, sled_gravity=settings.sled_gravity)
    assert speeds == pytest.approx(want, abs=TOL)
    if stops:
        assert speeds[-1] == 0.0  # friction 0.95 from 5 m/s: 3.71, 2.75, 2.04, 1.51, 1.12, 0.83, 0.61, stop
    else:
        assert speeds[-1] == pytest.approx(5.0 * 0.8, abs=1e-4)  # friction 0.2 for 1 s


@pytest.mark.parametrize("field", ["sled_slope_friction", "sled_gravity"])
def test_each_sled_correction_can_be_chosen_alone(field: str) -> None:
    settings = dataclasses.replace(engine.ACE_COMPAT, **{field: True})
    world, mid, downhill = _sled(settings, 17, 3.0)
    speeds, _ = _run(world, mid, downhill, 8, 0.1)
    want, _ = _slide(3.0, SLOPE, 8, 0.1, sled_slope=settings.sled_slope_friction, sled_gravity=settings.sled_gravity)
    assert speeds == pytest.approx(want, abs=TOL)


def test_a_mover_that_is_not_a_sled_keeps_its_friction_and_stands() -> None:
    # the sledding rules touch sleds only: a walker on the slope stays put under RETAIL
    world = world_from_heights(lambda bx, by, x, y: 20 + 17 * x, settings=engine.RETAIL)
    mid = standing(world, 170.0, 50.0)
    start = world.mover(mid).position.frame.origin
    for _ in range(5):
        world.step(mid, Vec3(0.0, 0.0, 0.0), 0.1)
    # (the first step rounds the origin to single precision, as the client keeps it)
    assert (world.mover(mid).position.frame.origin - start).length() < 1e-4
    assert world.mover(mid).acceleration == Vec3(0.0, 0.0, 0.0)


def test_a_motion_given_with_no_time_waits_for_time() -> None:
    world, mid = _walker(engine.RETAIL)
    x0 = world.mover(mid).position.frame.origin.x
    assert world.step(mid, Vec3(0.3, 0.0, 0.0), 0.0).transition_state == "NoTransition"
    assert world.mover(mid).position.frame.origin.x == x0
    world.step(mid, Vec3(0.1, 0.0, 0.0), 0.05)  # one 0.05 s step with both motions
    assert world.mover(mid).position.frame.origin.x - x0 == pytest.approx(0.4, abs=TOL)
