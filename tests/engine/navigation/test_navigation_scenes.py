"""Paths on scenes whose answer is obvious: an open field, a wall with a gap, a closed room, a house's
door, stairs, a ledge and a ramp, a dungeon corridor, a landblock border.

Every path found is walked with the public World.move as the contract says (tests/support/path_walk.py)
and must arrive; the expected routes come from the geometry the test builds or reads.
"""

from __future__ import annotations

import math

import pytest

import engine
from engine import Position, Vec3
from support.indoor_scenes import GROUND, SceneBuilder, box_solid, gfx_obj
from benchmarks.scenes import PLAYER
from support.path_walk import walk_as_spec
from support.shared_data import SCENES, needs_shared

LB = 0xA9B4


def at(x: float, y: float, z: float, landblock: int = LB, cell: int | None = None) -> Position:
    """A landblock position in its outdoor cell (or the given indoor cell)."""
    index = int(x // 24) * 8 + int(y // 24) + 1
    return Position.at((landblock << 16) | (cell if cell is not None else index), Vec3(x, y, z))


def global_xy(p: Position) -> tuple[float, float]:
    return ((p.cell_id >> 24) & 0xFF) * 192.0 + p.frame.origin.x, ((p.cell_id >> 16) & 0xFF) * 192.0 + p.frame.origin.y


def crossings(path: engine.navigation.PathResult, x_line: float) -> list[float]:
    """The global y at which the path's polyline crosses the vertical line x = x_line (global metres)."""
    return _crossings([global_xy(p) for p in path.waypoints], x_line)


def _crossings(points: list[tuple[float, float]], line: float) -> list[float]:
    """Where a polyline of (a, b) points crosses a = line: the b there."""
    out = []
    for (a0, b0), (a1, b1) in zip(points, points[1:]):
        if (a0 - line) * (a1 - line) < 0.0:
            out.append(b0 + (b1 - b0) * (line - a0) / (a1 - a0))
    return out


def assert_walks(world: engine.World, path: engine.navigation.PathResult) -> None:
    assert path.found, (path.reason, path.detail)
    walked = walk_as_spec(world, PLAYER, path.waypoints)
    assert walked.failed_leg is None, walked.why


def shared_world(name: str) -> engine.World:
    return engine.load_scene(SCENES / name)


# -- open ground -----------------------------------------------------------------------------------------


@needs_shared
def test_open_field_is_straight_and_as_long_as_the_distance() -> None:
    world = shared_world("flat.json")
    z = world.terrain_height(at(30, 30, 0).cell_id, 30, 30)
    start, goal = at(30.0, 30.0, z), at(150.0, 170.0, z)
    path = world.path(PLAYER, start, goal)
    assert_walks(world, path)
    assert len(path.waypoints) == 2  # nothing in the way: one leg
    assert path.length == pytest.approx(math.hypot(120.0, 140.0), rel=1e-3)


@needs_shared
def test_a_path_across_a_landblock_border() -> None:
    world = shared_world("flat.json")
    z = world.terrain_height(at(170, 90, 0).cell_id, 170, 90)
    start, goal = at(170.0, 90.0, z), at(25.0, 110.0, z, landblock=0xAAB4)
    path = world.path(PLAYER, start, goal)
    assert_walks(world, path)
    assert path.waypoints[-1].cell_id >> 16 == 0xAAB4
    assert path.length == pytest.approx(math.hypot(192.0 + 25.0 - 170.0, 20.0), rel=1e-3)


# -- walls -----------------------------------------------------------------------------------------------


def add_box(b: SceneBuilder, x0: float, y0: float, x1: float, y1: float, height: float) -> None:
    """A static box object standing on the ground. The client registers an object in the one outdoor cell
    holding its origin, and a mover collides with it only while that cell is among the mover's, so each
    box here stays inside one 24 m cell."""
    cx, cy = (x0 + x1) / 2.0, (y0 + y1) / 2.0
    assert int(x0 // 24) == int((x1 - 1e-9) // 24) and int(y0 // 24) == int((y1 - 1e-9) // 24), "a box across cells"
    model = b.add_gfx_obj(gfx_obj([box_solid((x0 - cx, y0 - cy, 0.0), (x1 - cx, y1 - cy, height))]))
    b.add_object(model, (cx, cy, GROUND))


def walled_world() -> engine.World:
    """A 0.5 m thick, 3 m high wall along x = 108 from y = 48 to 120, with a 2.4 m gap at y 83.8..86.2."""
    b = SceneBuilder()
    for y0, y1 in ((48.0, 72.0), (72.0, 83.8), (86.2, 96.0), (96.0, 120.0)):
        add_box(b, 107.75, y0, 108.25, y1, 3.0)
    return b.world()


def test_a_wall_with_a_gap_is_passed_through_the_gap() -> None:
    world = walled_world()
    start, goal = at(100.0, 80.0, GROUND), at(116.0, 80.0, GROUND)
    path = world.path(PLAYER, start, goal)
    assert_walks(world, path)
    ys = [y - 192.0 * 0xB4 for y in crossings(path, 192.0 * 0xA9 + 108.0)]
    assert len(ys) == 1 and 83.8 + 0.48 - 0.25 <= ys[0] <= 86.2 - 0.48 + 0.25, ys
    # through the gap: at least the two straight legs to it, and not much more
    through_gap = 2.0 * math.hypot(8.0, 5.0)
    assert through_gap - 1.0 <= path.length <= 1.15 * through_gap


def test_a_closed_room_is_unreachable_both_ways() -> None:
    b = SceneBuilder()
    # four walls around the square 100..110 x 100..110, all in the outdoor cell 96..120 x 96..120
    for x0, y0, x1, y1 in ((99.5, 99.5, 110.5, 100.0), (99.5, 110.0, 110.5, 110.5), (99.5, 100.0, 100.0, 110.0), (110.0, 100.0, 110.5, 110.0)):
        add_box(b, x0, y0, x1, y1, 3.0)
    world = b.world()
    inside, outside = at(105.0, 105.0, GROUND), at(85.0, 105.0, GROUND)
    into = world.path(PLAYER, outside, inside)
    assert not into.found and into.reason == "unreachable", (into.reason, into.detail)
    out = world.path(PLAYER, inside, outside)
    assert not out.found and out.reason == "unreachable", (out.reason, out.detail)
    assert not world.reachable(PLAYER, inside, outside)


# -- buildings, stairs, ramps, dungeons --------------------------------------------------------------------


@needs_shared
def test_into_the_house_through_its_door_and_out_again() -> None:
    """The shared house: an 8 x 6 m shell around (108, 108), its only door in the south wall (y = 105),
    x 107.25..108.75; the room is EnvCell 0100."""
    world = shared_world("house.json")
    z = 112.5
    outside, inside = at(100.0, 96.0, z), at(107.0, 109.5, z, cell=0x0100)
    into = world.path(PLAYER, outside, inside)
    assert_walks(world, into)
    assert into.waypoints[-1].cell_id == (LB << 16) | 0x0100
    door = [x - 192.0 * 0xA9 for x in crossings_y(into, 105.0)]
    assert door and all(107.25 + 0.48 - 0.25 <= x <= 108.75 - 0.48 + 0.25 for x in door), door
    # out to the north side: back through the same door and around the house
    behind = at(108.0, 116.0, z)
    out = world.path(PLAYER, inside, behind)
    assert_walks(world, out)
    door = [x for x in crossings_y(out, 105.0)]
    assert door and all(107.25 + 0.48 - 0.25 <= x - 192.0 * 0xA9 <= 108.75 - 0.48 + 0.25 for x in door), door


def crossings_y(path: engine.navigation.PathResult, y_line: float) -> list[float]:
    """The global x at which the path crosses the horizontal line y = y_line (landblock metres of A9B4)."""
    return _crossings([(y, x) for x, y in (global_xy(p) for p in path.waypoints)], y_line + 192.0 * 0xB4)


def stairs_world() -> engine.World:
    """A platform 1.5 m high (x 100..110, y 100..110), too high to step onto, with six 0.25 m steps up its
    west side (x 96.4..100, y 104..106)."""
    b = SceneBuilder()
    add_box(b, 100.0, 100.0, 110.0, 110.0, 1.5)
    for k in range(1, 7):
        x0 = 100.0 - 0.6 * (7 - k)
        add_box(b, x0, 104.0, x0 + 0.6, 106.0, 0.25 * k)
    return b.world()


def test_stairs_up_and_down() -> None:
    world = stairs_world()
    ground, top = at(90.0, 96.0, GROUND), at(106.0, 107.0, GROUND + 1.5)
    up = world.path(PLAYER, ground, top)
    assert_walks(world, up)
    assert up.waypoints[-1].frame.origin.z == pytest.approx(GROUND + 1.5, abs=0.01)
    # the platform's west edge (x = 100) is a 1.5 m wall but where the stairs meet it (y 104..106): the
    # path crosses it there (to the walker's radius), and crosses none of its other edges
    for path in (up, world.path(PLAYER, top, ground)):
        assert_walks(world, path)
        edge = [y - 192.0 * 0xB4 for y in crossings(path, 192.0 * 0xA9 + 100.0)]
        assert len(edge) == 1 and 104.0 - 0.48 <= edge[0] <= 106.0 + 0.48, edge
        assert not crossings(path, 192.0 * 0xA9 + 110.0)
        assert not [x for x in crossings_y(path, 100.0) + crossings_y(path, 110.0) if 100.0 <= x - 192.0 * 0xA9 <= 110.0]


@needs_shared
def test_down_the_cellar_ramp_and_up_again() -> None:
    """The shared cellar: from the house's room (EnvCell 0100) a ramp (0101) falls 2.6 m eastward into
    the cellar room 0102 (x 114..120, floor 110.0)."""
    world = shared_world("cellar.json")
    outside, cellar = at(100.0, 100.0, 112.5), at(117.0, 108.0, 110.0, cell=0x0102)
    down = world.path(PLAYER, outside, cellar)
    assert_walks(world, down)
    assert down.waypoints[-1].cell_id == (LB << 16) | 0x0102
    up = world.path(PLAYER, cellar, outside)
    assert_walks(world, up)
    # out through the house's one door, its west wall's portal at x = 106, y 107..109
    door = [y - 192.0 * 0xB4 for y in crossings(up, 192.0 * 0xA9 + 106.0)]
    assert door and all(107.0 <= y <= 109.0 for y in door), door


@needs_shared
def test_a_dungeon_corridor_and_a_doorway_too_low() -> None:
    """The shared dungeon: corridor cells 0100 (x 60..68) and 0101 (68..76) along y 58.5..61.5, 0103
    turning north from 0100 (x 62.5..65.5, y 61.5..71.5), floors at 52.5; and 0102 (x 76..82) behind a
    doorway only 1.625 m high, which a 1.83 m player cannot pass."""
    world = shared_world("dungeon.json")
    start, goal = at(72.0, 60.0, 52.5, cell=0x0101), at(64.0, 70.0, 52.5, cell=0x0103)
    path = world.path(PLAYER, start, goal)
    assert_walks(world, path)
    assert all(p.cell_id & 0xFFFF >= 0x100 for p in path.waypoints)
    corner = (72.0 - 64.0) + 10.0  # along the corridor, round the corner
    assert math.hypot(8.0, 10.0) < path.length <= 1.15 * corner
    # round the corner, not through the walls: every leg keeps inside the corridors' union
    for a, b in zip(path.waypoints, path.waypoints[1:]):
        for k in range(11):
            x = a.frame.origin.x + (b.frame.origin.x - a.frame.origin.x) * k / 10.0
            y = a.frame.origin.y + (b.frame.origin.y - a.frame.origin.y) * k / 10.0
            assert (60.0 <= x <= 76.0 and 58.5 <= y <= 61.5) or (62.5 <= x <= 65.5 and 58.5 <= y <= 71.5), (x, y)
    low = world.path(PLAYER, start, at(77.0, 60.0, 52.5, cell=0x0102))
    assert not low.found and low.reason == "unreachable", (low.reason, low.detail)


# -- the demo world's ledge and ramp ---------------------------------------------------------------------


def demo_world() -> engine.World:
    from clients.demo.world import demo_scene_path

    return engine.load_scene(demo_scene_path())


def demo_at(x: float, y: float, world: engine.World) -> Position:
    block = 0xA9B4 + (0x100 if x >= 192 else 0) + (1 if y >= 192 else 0)
    lx, ly = x % 192.0, y % 192.0
    return at(lx, ly, world.terrain_height(at(lx, ly, 0, landblock=block).cell_id, lx, ly), landblock=block)


#: a creature: the player's shape without the player's EdgeSlide, which keeps a walking player from
#: stepping off a ledge too steep to stand on (it slides along the edge instead, as in the client)
CREATURE = engine.MoverSpec(spheres=PLAYER.spheres, step_up_height=0.4, step_down_height=0.4, state=["Contact", "OnWalkable"])


def test_off_the_mesa_ledge_a_creature_drops_and_cannot_climb_back() -> None:
    """The demo mesa's north edge drops 47 m over one 24 m cell (y 336..360): far too steep to climb,
    a drop to walk off. The only way up is the ramp, 300 m round."""
    world = demo_world()
    top, below = demo_at(288.0, 330.0, world), demo_at(288.0, 372.0, world)
    down = world.path(CREATURE, top, below, max_distance=120.0)
    assert down.found, (down.reason, down.detail)
    walked = walk_as_spec(world, CREATURE, down.waypoints)
    assert walked.failed_leg is None, walked.why
    up = world.path(CREATURE, below, top, max_distance=120.0)
    assert not up.found and up.reason == "unreachable", (up.reason, up.detail)
    # a player's EdgeSlide holds it on the mesa: no way down within the bound either
    held = world.path(PLAYER, top, below, max_distance=120.0)
    assert not held.found and held.reason == "unreachable", (held.reason, held.detail)


def test_up_the_demo_ramp_onto_the_mesa() -> None:
    """The ramp climbs the mesa's south face at x 264..312 (y 72..216); everywhere else the face is too steep."""
    world = demo_world()
    foot, top = demo_at(250.0, 40.0, world), demo_at(300.0, 300.0, world)
    path = world.path(PLAYER, foot, top)
    assert_walks(world, path)
    onto = [x for x in crossings_y(path, 200.0 - 192.0 * 0xB4 + 192.0 * 0xB4)]
    assert onto and all(264.0 <= x - 192.0 * 0xA9 <= 312.0 for x in onto), onto
