"""The broad phase for crowds: `skip_far_movers` passes over live
movers the path's spheres cannot reach, and changes no answer.

- the box test itself, against hand-placed spheres (engine.cells.broad_phase);
- every field of every move of the benchmark's crowds, and of a mixed crowd
  (ethereal, cylsphere, scaled single-sphere and non-creature movers, a
  player ignoring creatures, falling movers landing on the others in collide
  mode, missiles, placements into the crowd), with the broad phase on and off;
- every case of the reference traces with live movers, on and off (the trace
  replay test runs them with it on, the default, against the reference).
"""

from __future__ import annotations

import dataclasses
import gzip
import json
import math
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

import engine
import engine.objects.obstacle
import engine.transition.state
from engine import MoverSpec, Position, Quat, Sphere, SphereSpec, Vec3
from engine.cells.broad_phase import MARGIN, SLACK, may_touch, mover_bounds, path_reach
from engine.geometry import Frame
from engine.transition.sphere_path import SpherePath
from engine.world import shadows
from support.shared_data import ORACLE, needs_shared

ROOT = Path(__file__).resolve().parents[3]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import crowds as C  # noqa: E402

OFF = dataclasses.replace(engine.RETAIL, skip_far_movers=False)
LB = 0xA9B40000
#: the player's shape: spheres of 0.48 m at heights 0.48 and 1.35
TWO_SPHERES = MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.48), 0.48), SphereSpec((0.0, 0.0, 1.35), 0.48)], creature=True)


def _flat_world() -> engine.World:
    return engine.world_from_scene_dict(C.terrain_scene("flat", C.flat_heights, C.around()))


def _obstacle(world: engine.World, spec: MoverSpec, x: float, y: float, z: float = 50.0, cell: int = LB | 0x13) -> object:
    mid = world.add_mover(spec, Position.at(cell, Vec3(x, y, z)))
    return shadows.obstacle_of(world.mover(mid))


def _path(cell: int, centres: list[Vec3], radius: float = 0.48, collide: bool = False) -> SpherePath:
    path = SpherePath()
    path.num_sphere = len(centres)
    path.global_sphere = [Sphere(c, radius) for c in centres]
    path.check_pos = Position.at(cell, centres[0])
    path.collide = collide
    return path


def test_the_box_holds_the_placed_spheres() -> None:
    world = _flat_world()
    obstacle = _obstacle(world, TWO_SPHERES, 50.0, 50.0)
    b = mover_bounds(obstacle)  # type: ignore[arg-type]
    # x and y: 50 +- 0.48; z: from the foot sphere's bottom (50.0) to the head's top (50 + 1.35 + 0.48)
    assert (b.min_x, b.max_x) == pytest.approx((49.52 - MARGIN, 50.48 + MARGIN))
    assert (b.min_y, b.max_y) == pytest.approx((49.52 - MARGIN, 50.48 + MARGIN))
    assert (b.min_z, b.max_z) == pytest.approx((50.0 - MARGIN, 51.83 + MARGIN))


def test_a_sphere_beside_the_box_is_passed_over_and_one_reaching_it_is_not() -> None:
    world = _flat_world()
    obstacle = _obstacle(world, TWO_SPHERES, 50.0, 50.0)
    cell = LB | 0x13
    # the box reaches x = 50.49; a 0.48 m sphere reaches it from x < 50.97
    assert not may_touch(obstacle, _path(cell, [Vec3(50.98, 50.0, 50.48)]))  # type: ignore[arg-type]
    assert may_touch(obstacle, _path(cell, [Vec3(50.95, 50.0, 50.48)]))  # type: ignore[arg-type]
    # above the head (top 51.84) and below the feet (50.0): only z decides
    assert not may_touch(obstacle, _path(cell, [Vec3(50.0, 50.0, 52.4)]))  # type: ignore[arg-type]
    assert may_touch(obstacle, _path(cell, [Vec3(50.0, 50.0, 52.3)]))  # type: ignore[arg-type]
    # the second (head) sphere alone reaching it is enough
    assert may_touch(obstacle, _path(cell, [Vec3(53.0, 50.0, 50.48), Vec3(50.9, 50.0, 51.35)]))  # type: ignore[arg-type]
    assert not may_touch(obstacle, _path(cell, [Vec3(53.0, 50.0, 50.48), Vec3(51.9, 50.0, 51.35)]))  # type: ignore[arg-type]


def test_a_small_head_reaches_as_far_as_the_foot() -> None:
    # the obstacle tests measure the head sphere's overlap with radsum, made of the foot sphere's radius
    world = _flat_world()
    obstacle = _obstacle(world, TWO_SPHERES, 50.0, 50.0)
    path = _path(LB | 0x13, [Vec3(45.0, 50.0, 50.48), Vec3(51.2, 50.0, 51.35)], radius=0.75)
    path.global_sphere[1].radius = 0.3  # by its own radius it would need x <= 50.49 + 0.3; with the foot's, 51.24
    assert may_touch(obstacle, path)  # type: ignore[arg-type]
    path.global_sphere[1].center = Vec3(51.3, 50.0, 51.35)  # beyond 50.49 + 0.75
    assert not may_touch(obstacle, path)  # type: ignore[arg-type]


def test_the_footprint_the_cell_loop_looks_at_first() -> None:
    # a foot of 0.75 m at (45, 50) and a head of 0.3 m at (51.2, 50.5): both reach 0.75 m (the foot's radius)
    path = _path(LB | 0x13, [Vec3(45.0, 50.0, 50.48), Vec3(51.2, 50.5, 51.35)], radius=0.75)
    path.global_sphere[1].radius = 0.3
    look, block, lo_x, hi_x, lo_y, hi_y = path_reach(path)
    assert look and block == LB >> 16
    assert (lo_x, hi_x) == pytest.approx((44.25 - SLACK, 51.95 + SLACK), abs=1e-12)
    assert (lo_y, hi_y) == pytest.approx((49.25 - SLACK, 51.25 + SLACK), abs=1e-12)
    # nothing is looked past when may_touch culls nothing
    assert not path_reach(_path(LB | 0x13, [Vec3(45.0, 50.0, 50.48)], collide=True))[0]


def test_a_box_outside_the_footprint_fails_may_touch() -> None:
    # the cell loop passes over a mover whose box misses the footprint without asking may_touch: it must say no
    world = _flat_world()
    obstacle = _obstacle(world, TWO_SPHERES, 50.0, 50.0)
    b = mover_bounds(obstacle)  # type: ignore[arg-type]
    for x in (50.90, 50.96, 50.97, 50.98, 51.5, 49.03, 49.04, 48.0):
        for y in (50.0, 50.97, 50.98):
            path = _path(LB | 0x13, [Vec3(x, y, 50.48), Vec3(x, y, 51.35)])
            _, _, lo_x, hi_x, lo_y, hi_y = path_reach(path)
            if b.max_x < lo_x or b.min_x > hi_x or b.max_y < lo_y or b.min_y > hi_y:
                assert not may_touch(obstacle, path), (x, y)  # type: ignore[arg-type]
    # the box reaches x = 50.49; from x = 50.98 the footprint misses it, at 50.96 it does not
    assert path_reach(_path(LB | 0x13, [Vec3(50.98, 50.0, 50.48)]))[2] > b.max_x
    assert path_reach(_path(LB | 0x13, [Vec3(50.96, 50.0, 50.48)]))[2] < b.max_x


def test_a_single_sphere_in_collide_mode_is_never_culled() -> None:
    # its landing solve against a sphere runs without an overlap
    world = _flat_world()
    obstacle = _obstacle(world, TWO_SPHERES, 50.0, 50.0)
    far = Vec3(60.0, 60.0, 50.48)
    assert may_touch(obstacle, _path(LB | 0x13, [far], collide=True))  # type: ignore[arg-type]
    assert not may_touch(obstacle, _path(LB | 0x13, [far, far + Vec3(0, 0, 1)], collide=True))  # type: ignore[arg-type]


def test_across_a_landblock_edge_the_spheres_are_moved_into_the_movers_landblock() -> None:
    world = _flat_world()
    # the mover stands 0.5 m south of the edge with A9B5 (y = 191.5 in A9B4)
    obstacle = _obstacle(world, TWO_SPHERES, 100.0, 191.5, cell=LB | 0x28)
    north = 0xA9B50000 | 0x21  # A9B5 cell of x 96..120, y 0..24
    # y 0.3 in A9B5 is y 192.3 in A9B4: within 191.98 + 0.48 of the box; y 0.9 (192.9) is not
    assert may_touch(obstacle, _path(north, [Vec3(100.0, 0.3, 50.48)]))  # type: ignore[arg-type]
    assert not may_touch(obstacle, _path(north, [Vec3(100.0, 0.9, 50.48)]))  # type: ignore[arg-type]


def test_the_box_follows_a_turn_that_casts_no_new_shadow() -> None:
    # a sphere 1 m ahead of the mover's origin; a turn in place is a move within
    # EPSILON (no transition, no reshadow): the box must turn with it
    world = _flat_world()
    spec = MoverSpec(spheres=[SphereSpec((1.0, 0.0, 0.5), 0.5)])
    mid = world.add_mover(spec, Position.at(LB | 0x13, Vec3(60.0, 60.0, 50.0)))
    obstacle = shadows.obstacle_of(world.mover(mid))
    before = mover_bounds(obstacle)
    assert (before.min_x, before.max_x, before.min_y, before.max_y) == pytest.approx((60.5 - MARGIN, 61.5 + MARGIN, 59.5 - MARGIN, 60.5 + MARGIN))
    quarter = Quat(math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4))  # +90 degrees about z: x ahead becomes y
    result = world.move(mid, Position(LB | 0x13, Frame(Vec3(60.0, 60.0, 50.0), quarter)))
    assert result.transition_state == "NoTransition"
    after = mover_bounds(obstacle)
    assert (after.min_x, after.max_x, after.min_y, after.max_y) == pytest.approx((59.5 - MARGIN, 60.5 + MARGIN, 60.5 - MARGIN, 61.5 + MARGIN))


@pytest.mark.parametrize("crowd", C.CROWDS, ids=[c.name for c in C.CROWDS])
def test_a_crowd_moves_the_same_with_the_broad_phase_on_and_off(crowd: C.Crowd) -> None:
    moves = max(600, crowd.count + 200)  # every creature out at least once
    on = C.run_crowd(crowd, engine.RETAIL, moves)
    off = C.run_crowd(crowd, OFF, moves)
    assert len(on) == len(off) == moves + crowd.count
    differ = [i for i, (a, b) in enumerate(zip(on, off)) if a != b]
    assert differ == [], f"{len(differ)} answers differ, first at {differ[:5]}"
    if crowd.spacing < 1.1:  # packed: the comparison covered real collisions
        assert sum(1 for r in on[:moves] if dict(r)["collide_objects"]) > moves // 2


@pytest.mark.parametrize("settings", [engine.RETAIL, engine.ACE_COMPAT], ids=["retail", "ace-compat"])
def test_a_mixed_crowd_moves_the_same_with_the_broad_phase_on_and_off(settings: engine.EngineSettings) -> None:
    on = C.run_mixed(settings)
    off = C.run_mixed(dataclasses.replace(settings, skip_far_movers=False))
    assert len(on) == len(off)
    differ = [i for i, (a, b) in enumerate(zip(on, off)) if a != b]
    assert differ == [], f"{len(differ)} answers differ, first at {differ[:5]}"
    # the workload reaches what the broad phase must leave alone: objects hit, ethereal ones walked through
    hits = [dict(r)["collide_objects"] for r in on if isinstance(r, tuple)]
    assert sum(1 for h in hits if h) > 100


# -- what a passed-over obstacle's test would have done: nothing ----------------------------------------------
#: the local-space sphere cache: every reader makes it for its own object first (engine.cells.broad_phase)
_REMADE_BY_READERS = {"local_space_sphere", "local_space_low_point", "local_space_curr_center", "local_space_pos",
                      "local_space_z", "_lss_curr", "_lss_check", "_lss_sums"}


def _state(transition: Any) -> dict[str, str]:
    out = {}
    for part in (transition.sphere_path, transition.collision_info, transition.object_info):
        for name in type(part).__slots__:
            if name in _REMADE_BY_READERS:
                continue
            value = getattr(part, name, None)
            out[f"{type(part).__name__}.{name}"] = repr([repr(v) for v in value] if isinstance(value, list) else value)
    return out


def _check_passed_over(monkeypatch: pytest.MonkeyPatch, run: Callable[[], object]) -> int:
    """Run `run` with the broad phase off, testing every obstacle it would pass
    over: the test must answer OK and leave the transition's path, collision
    info and object info exactly as they were. How many were checked."""
    from engine.objects.obstacle import MoverObstacle

    checked = 0
    original = MoverObstacle.find_obj_collisions

    def find_obj_collisions(self: MoverObstacle, transition: Any) -> int:
        nonlocal checked
        if transition.object_info.obj is self.mover or may_touch(self, transition.sphere_path):
            return original(self, transition)
        before = _state(transition)
        state = original(self, transition)
        after = _state(transition)
        changed = {k: (before[k], after[k]) for k in before if before[k] != after[k]}
        assert state == engine.transition.state.TransitionState.OK and not changed, (state, changed)
        checked += 1
        return state

    monkeypatch.setattr(MoverObstacle, "find_obj_collisions", find_obj_collisions)
    run()
    return checked


_compiled = engine.objects.obstacle.__file__.endswith((".so", ".pyd"))


@pytest.mark.skipif(_compiled, reason="wraps an engine class: needs the pure-Python engine")
def test_every_obstacle_passed_over_in_a_crowd_answers_ok_and_changes_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    packed = next(c for c in C.CROWDS if c.count == 400)
    checked = _check_passed_over(monkeypatch, lambda: (C.run_mixed(OFF, rounds=2), C.run_crowd(packed, OFF, 120)))
    assert checked > 20_000  # most of each cell's movers are out of reach


@needs_shared
@pytest.mark.skipif(_compiled, reason="wraps an engine class: needs the pure-Python engine")
def test_every_obstacle_passed_over_in_the_mover_traces_answers_ok_and_changes_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    off = dataclasses.replace(engine.ACE_COMPAT, skip_far_movers=False)

    def run() -> None:
        for name in MOVER_TRACES:
            with gzip.open(ORACLE / "traces" / f"{name}.trace.json.gz", "rt") as f:
                trace = json.load(f)
            world = engine.load_scene(ORACLE / "scenes" / trace["scene"])
            for case in trace["cases"]:
                engine.run_case(world, case, settings=off)

    assert _check_passed_over(monkeypatch, run) > 1000


MOVER_TRACES = ["objects-movers", "house-movers", "interior-movers", "rolling-movers"]


@needs_shared
@pytest.mark.parametrize("name", MOVER_TRACES)
def test_reference_traces_with_movers_replay_the_same_with_the_broad_phase_off(name: str) -> None:
    with gzip.open(ORACLE / "traces" / f"{name}.trace.json.gz", "rt") as f:
        trace = json.load(f)
    world = engine.load_scene(ORACLE / "scenes" / trace["scene"])
    off = dataclasses.replace(engine.ACE_COMPAT, skip_far_movers=False)
    assert engine.ACE_COMPAT.skip_far_movers and engine.RETAIL.skip_far_movers
    for case in trace["cases"]:
        assert engine.run_case(world, case, settings=off) == engine.run_case(world, case), case["id"]
