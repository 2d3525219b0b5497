"""The speed/accuracy settings: single against double precision, and the sub-step length."""

from __future__ import annotations

import dataclasses
import struct

import pytest

import engine
from engine import Position, Vec3
from engine.transition.transition import Transition
from benchmarks.scenes import PLAYER, world_from_heights
from test_scenarios import LB, cell_at, standing


def _single(x: float) -> float:
    return struct.unpack("<f", struct.pack("<f", x))[0]


DOUBLE = dataclasses.replace(engine.RETAIL, single_precision=False)


@pytest.mark.parametrize(("settings", "rounded"), [(engine.RETAIL, True), (DOUBLE, False)])
def test_what_a_move_leaves_behind_is_single_precision_only_when_asked(settings: engine.EngineSettings, rounded: bool) -> None:
    # flat ground: a 0.1 m step lands exactly at its target, which is not a float32 number
    world = world_from_heights(lambda bx, by, x, y: 100, settings=settings)
    mid = standing(world, 50.0, 50.0)
    start = world.mover(mid).position.frame.origin
    target = Vec3(start.x + 0.1, start.y + 0.3, start.z)
    assert _single(target.x) != target.x
    result = world.move(mid, Position(cell_at(50.1, 50.3), world.mover(mid).position.frame.with_origin(target)))
    assert result.ok and result.contact
    x = result.position.frame.origin.x
    assert x == (_single(target.x) if rounded else target.x)


def test_double_precision_walks_the_same_path_within_float32_rounding() -> None:
    paths = []
    for settings in (engine.RETAIL, DOUBLE):
        world = world_from_heights(lambda bx, by, x, y: 100 + (x * 7 + y * 3) % 9, settings=settings)
        mid = standing(world, 30.0, 30.0)
        for _ in range(40):
            p = world.mover(mid).position
            world.move(mid, Position(p.cell_id, p.frame.with_origin(p.frame.origin + Vec3(0.4, 0.15, 0.0))))
        paths.append(world.mover(mid).position.frame.origin)
    single, double = paths
    # 16 m of hills: the two agree to well under a millimetre but not bit for bit
    assert (single - double).length() < 1e-3
    assert single != double


def _steps(step_length: float, distance_in_radii: float) -> int:
    settings = dataclasses.replace(engine.RETAIL, step_length=step_length)
    world = world_from_heights(lambda bx, by, x, y: 100, settings=settings)
    mid = standing(world, 50.0, 50.0)
    mover = world.mover(mid)
    t = mover.make_transition(world.landscape, settings)
    start = mover.position
    radius = PLAYER.spheres[0].radius
    end = Position(start.cell_id, start.frame.with_origin(start.frame.origin + Vec3(distance_in_radii * radius, 0.0, 0.0)))
    t.init_path(mover.cell, start, end)
    _, _, num_steps = Transition.calc_num_steps(t)
    return num_steps


@pytest.mark.parametrize(("step_length", "steps"), [(1.0, 3), (2.0, 2), (0.5, 5), (0.25, 10), (3.0, 1)])
def test_a_move_of_2_3_radii_takes_as_many_sub_steps_as_step_lengths_fit_rounded_up(step_length: float, steps: int) -> None:
    assert _steps(step_length, 2.3) == steps


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf")])
def test_a_sub_step_length_must_be_a_positive_number(bad: float) -> None:
    with pytest.raises(ValueError, match="step_length"):
        dataclasses.replace(engine.RETAIL, step_length=bad)


def test_the_client_defaults_are_single_precision_and_one_radius_steps() -> None:
    assert engine.RETAIL.single_precision and engine.ACE_COMPAT.single_precision
    assert engine.RETAIL.step_length == 1.0 == engine.ACE_COMPAT.step_length
    assert LB == 0xA9B40000
