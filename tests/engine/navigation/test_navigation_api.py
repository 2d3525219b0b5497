"""World.path's other faces: a registered mover as the walker, other movers, batches, random points,
shared graphs and their invalidation, and bad input (a clear error or an honest reason, never a crash)."""

from __future__ import annotations

import math

import pytest

import engine
from engine import MoverSpec, Position, SphereSpec, Vec3
from support.indoor_scenes import GROUND, SceneBuilder
from benchmarks.scenes import PLAYER
from support.path_walk import walk, walk_as_spec
from test_navigation_scenes import add_box, at, walled_world


def flat_world() -> engine.World:
    return SceneBuilder().world()


def states(world: engine.World) -> dict[int, tuple]:
    return {mid: (repr(world.mover_state(mid)), world.movers[mid].velocity, world.movers[mid].held_time) for mid in world.movers}


def spot(p: Position) -> tuple[int, float, float, float]:
    o = p.frame.origin
    return p.cell_id, o.x, o.y, o.z


# -- a registered mover walks ---------------------------------------------------------------------------


def test_a_registered_mover_walks_from_where_it_stands_and_the_query_changes_nothing() -> None:
    world = walled_world()
    mover = world.add_mover(PLAYER, at(100.0, 80.0, GROUND), placement="enter_world")
    world.add_mover(PLAYER, at(90.0, 70.0, GROUND), placement="enter_world")  # another mover, to be left alone
    before = states(world)
    path = world.path(mover, None, at(116.0, 80.0, GROUND))
    assert states(world) == before  # the search walked a probe, not the movers
    assert path.found and spot(path.waypoints[0]) == spot(world.mover_state(mover).position)
    walked = walk(world, mover, path.waypoints)
    assert walked.failed_leg is None, walked.why


def test_a_registered_mover_needs_no_start_and_a_spec_needs_one() -> None:
    world = flat_world()
    mover = world.add_mover(PLAYER, at(100.0, 80.0, GROUND), placement="enter_world")
    with pytest.raises(ValueError):
        world.path(mover, at(90.0, 80.0, GROUND), at(110.0, 80.0, GROUND))
    with pytest.raises(ValueError):
        world.path(PLAYER, None, at(110.0, 80.0, GROUND))
    with pytest.raises(engine.UnknownMoverError):
        world.path(999, None, at(110.0, 80.0, GROUND))
    with pytest.raises(TypeError):
        world.path("walker", at(90.0, 80.0, GROUND), at(110.0, 80.0, GROUND))  # type: ignore[arg-type]


# -- other movers ------------------------------------------------------------------------------------------


#: a boulder-sized mover that is no creature: it blocks the wall's gap for whoever collides with it
BOULDER = MoverSpec(spheres=[SphereSpec((0.0, 0.0, 1.5), 1.5)], state=["Contact", "OnWalkable"])


def test_other_movers_are_passed_unless_avoided() -> None:
    """The wall of test_navigation_scenes along x = 108 with its gap at y 83.8..86.2, the gap blocked by
    a boulder; the way round the wall's ends is over 60 m."""
    world = walled_world()
    world.add_mover(BOULDER, at(108.0, 85.0, GROUND), placement="enter_world")
    start, goal = at(100.0, 80.0, GROUND), at(116.0, 80.0, GROUND)
    through = world.path(PLAYER, start, goal)
    assert through.found and through.length < 25.0
    avoiding = world.path(PLAYER, start, goal, avoid_movers=True, max_distance=40.0)
    assert not avoiding.found and avoiding.reason == "unreachable", (avoiding.reason, avoiding.detail)


# -- batches, reachability, random points ----------------------------------------------------------------


def test_paths_answers_each_pair_as_path_does() -> None:
    world = walled_world()
    pairs = [(at(100.0, 80.0, GROUND), at(116.0, 80.0, GROUND)), (at(90.0, 60.0, GROUND), at(90.0, 100.0, GROUND))]
    batch = world.paths(PLAYER, pairs)
    single = [world.path(PLAYER, a, b) for a, b in pairs]
    assert [(r.found, [spot(p) for p in r.waypoints], r.length) for r in batch] == [(r.found, [spot(p) for p in r.waypoints], r.length) for r in single]
    assert world.reachable(PLAYER, *pairs[0])


def test_random_point_is_within_the_radius_reachable_and_repeatable() -> None:
    world = walled_world()
    near = at(100.0, 80.0, GROUND)
    first = world.random_point(PLAYER, near, 15.0, seed=7)
    assert first.found
    end = first.waypoints[-1]
    assert math.hypot(*(lambda o: (o.x, o.y))(near.get_offset(end))) <= 15.0
    assert walk_as_spec(world, PLAYER, first.waypoints).failed_leg is None
    again = world.random_point(PLAYER, near, 15.0, seed=7)
    assert [spot(p) for p in again.waypoints] == [spot(p) for p in first.waypoints]
    others = {tuple(world.random_point(PLAYER, near, 15.0, seed=s).waypoints[-1].frame.origin) for s in range(6)}
    assert len(others) > 1


# -- graphs --------------------------------------------------------------------------------------------------


def test_close_sizes_share_one_graph_and_a_small_walker_gets_its_own() -> None:
    world = walled_world()
    slim = MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.47), 0.47), SphereSpec((0.0, 0.0, 1.35), 0.47)], state=list(PLAYER.state))
    small = MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.3), 0.3)], state=list(PLAYER.state))
    start, goal = at(100.0, 80.0, GROUND), at(116.0, 80.0, GROUND)
    assert world.path(PLAYER, start, goal).found and world.path(slim, start, goal).found
    assert len(world.navigation.graphs) == 1
    assert world.path(small, start, goal).found
    assert len(world.navigation.graphs) == 2


def test_a_graph_forgets_an_unloaded_landblock() -> None:
    b = SceneBuilder()
    add_box(b, 100.0, 100.0, 104.0, 104.0, 2.0)
    world = b.world()
    stats = world.build_navigation(PLAYER, [0xA9B4])
    # flat ground: every node linked to its four lattice neighbours (the diagonals go through them)
    assert stats.nodes > 1000 and stats.edges > 3.9 * stats.nodes and stats.expanded_nodes == stats.nodes
    # no node on the ground under the box, nor within the walker's radius of it; some on its top
    graph = next(iter(world.navigation.graphs.values()))
    on_top = 0
    for tile in graph.tiles.values():
        for i in range(len(tile)):
            x, y, z = tile.gx[i] - 0xA9 * 192.0, tile.gy[i] - 0xB4 * 192.0, tile.z[i]
            under = 100.0 - 0.48 < x < 104.0 + 0.48 and 100.0 - 0.48 < y < 104.0 + 0.48
            assert not (under and z < GROUND + 1.0), (x, y, z)
            on_top += under and z == pytest.approx(GROUND + 2.0, abs=0.02)
    assert on_top >= 4
    world.unload_landblock(0xA9B4)
    gone = world.path(PLAYER, at(90.0, 80.0, GROUND), at(110.0, 80.0, GROUND))
    assert not gone.found and gone.reason == "not_loaded"
    assert graph.stats().nodes == 0


# -- bad input ------------------------------------------------------------------------------------------------


def test_bad_numbers_are_refused_with_a_clear_error() -> None:
    world = flat_world()
    start, goal = at(100.0, 80.0, GROUND), at(110.0, 80.0, GROUND)
    with pytest.raises(engine.NonFiniteError):
        world.path(PLAYER, Position.at(start.cell_id, Vec3(math.nan, 80.0, GROUND)), goal)
    with pytest.raises(engine.EngineError):
        world.path(PLAYER, start, Position.at(start.cell_id, Vec3(110.0, math.inf, GROUND)))
    for budget in (0, -5, 10**12, 2.5, True):
        with pytest.raises(engine.OutOfRangeError):
            world.path(PLAYER, start, goal, budget=budget)  # type: ignore[arg-type]
    for distance in (0.0, -1.0, math.nan, 1e9):
        with pytest.raises(engine.EngineError):
            world.path(PLAYER, start, goal, max_distance=distance)
    with pytest.raises(engine.EngineError):
        world.random_point(PLAYER, start, -3.0)
    with pytest.raises(engine.UnknownCellError):
        world.path(PLAYER, start, Position.at(0xA9B40999, Vec3(10.0, 10.0, GROUND)))


def test_unloaded_places_walls_and_a_small_budget_get_honest_reasons() -> None:
    world = walled_world()
    start = at(100.0, 80.0, GROUND)
    far = world.path(PLAYER, start, Position.at(0x12340001, Vec3(10.0, 10.0, 0.0)))
    assert not far.found and far.reason == "not_loaded" and "1234" in far.detail
    in_wall = world.path(PLAYER, start, at(108.0, 70.0, GROUND + 1.0))
    assert not in_wall.found and in_wall.reason == "goal_invalid", in_wall
    from_wall = world.path(PLAYER, at(108.0, 70.0, GROUND + 1.0), start)
    assert not from_wall.found and from_wall.reason == "start_invalid", from_wall
    stingy = world.path(PLAYER, start, at(116.0, 80.0, GROUND), budget=2)
    assert not stingy.found and stingy.reason == "budget" and stingy.expanded <= 2
    beyond = world.path(PLAYER, start, at(116.0, 80.0, GROUND), max_distance=10.0)
    assert not beyond.found and beyond.reason == "unreachable"


# -- following a path -----------------------------------------------------------------------------------------


def test_follow_walks_a_found_path_and_stops_at_a_wall() -> None:
    """World.follow is the walk of the guarantee on a registered mover: a found path is followed to its
    end; straight through the wall (x = 108, its gap at y 83.8..86.2) the mover stops at the first leg."""
    world = walled_world()
    start, goal = at(100.0, 80.0, GROUND), at(116.0, 80.0, GROUND)
    path = world.path(PLAYER, start, goal)
    mover = world.add_mover(PLAYER, path.waypoints[0], placement="enter_world")
    assert world.follow(mover, path.waypoints) == len(path.waypoints) - 1 >= 2
    assert world.mover_state(mover).position.get_offset(goal).length() <= 0.25
    blocked = world.add_mover(PLAYER, start, placement="enter_world")
    assert world.follow(blocked, [start, goal]) == 0
    here = world.mover_state(blocked).position.frame.origin
    assert here.x < 108.0 - 0.25 - 0.48 + 0.05  # held on the wall's west face


# -- a share of graph building per query -------------------------------------------------------------------


def test_a_share_of_building_answers_building_and_asking_again_finishes_the_same_path() -> None:
    start, goal = at(100.0, 80.0, GROUND), at(116.0, 80.0, GROUND)  # across the wall: the graph is needed
    expected = walled_world().path(PLAYER, start, goal)  # another world, its graph built in one go
    assert expected.found and expected.expanded > 0
    world = walled_world()
    answers = []
    for _ in range(400):  # bounded: each ask builds at least one tile or one node's edges
        answers.append(world.path(PLAYER, start, goal, work=40))
        if answers[-1].reason != "building":
            break
    first, last = answers[0], answers[-1]
    assert first.reason == "building" and not first.found and first.waypoints == []
    assert "ask again" in first.detail
    assert len(answers) > 2  # the building was spread over several asks
    # what each ask built was kept: the last answer is the one a graph built in one go gives
    assert last.found and [spot(p) for p in last.waypoints] == [spot(p) for p in expected.waypoints]
    assert last.length == expected.length
    # and a built graph answers at once, whatever the share
    again = world.path(PLAYER, start, goal, work=1)
    assert again.found and [spot(p) for p in again.waypoints] == [spot(p) for p in expected.waypoints]
    with pytest.raises(engine.OutOfRangeError):
        world.path(PLAYER, start, goal, work=0)
