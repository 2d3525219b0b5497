"""Spatial queries (engine.queries, World.sight / ray / ground and their
batched forms), tested on worlds whose answers are obvious: flat or planar
terrain, a hill, a building with and without a doorway, a sphere of known
size, and the same missile sweep run as a move."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, example, given, settings, strategies as st

import engine
from engine import MoverSpec, Position, SphereSpec, Vec3
from engine.errors import EngineError, LandblockNotLoadedError, NonFiniteError, OutOfRangeError, UnknownCellError
from engine.queries import CONTACT_TOLERANCE, SIGHT_RADIUS, grounds_array, rays_array, sights_array

from support.indoor_scenes import GROUND, SceneBuilder, box_solid, gfx_obj, room_struct, shell_boxes
from benchmarks.scenes import world_from_heights
from support.mover_slots import mover_state_slot_names
from test_indoor_scenarios import CX, CY, HOUSE_DOOR, HOUSE_HI, HOUSE_LO, house_world

A9B4 = 0xA9B4
FLAT_BYTE = 20  # 10 m
FLAT_Z = FLAT_BYTE * 0.5


def cell(lb: int, x: float, y: float) -> int:
    """The outdoor cell id of landblock-local (x, y)."""
    return (lb << 16) | (int(x // 24) * 8 + int(y // 24) + 1)


def at(lb: int, x: float, y: float, z: float) -> Position:
    return Position.at(cell(lb, x, y), Vec3(x, y, z))


def flat_world(blocks: tuple[tuple[int, int], ...] = ((0xA9, 0xB4),)) -> engine.World:
    return world_from_heights(lambda bx, by, x, y: FLAT_BYTE, list(blocks))


def same_position(a: Position | None, b: Position | None) -> bool:
    if a is None or b is None:
        return a is b
    return a.cell_id == b.cell_id and a.frame.origin == b.frame.origin and a.frame.orientation == b.frame.orientation


def ray_key(hit: engine.queries.RayHit) -> tuple[object, ...]:
    p = hit.position
    return (hit.hit, p.cell_id, p.frame.origin, hit.cell, hit.normal, hit.distance, hit.blocker)


def sight_key(s: engine.queries.SightResult) -> tuple[object, ...]:
    return (s.clear, None if s.stop is None else (s.stop.cell_id, s.stop.frame.origin), s.normal, s.cell, s.blocker)


def mover_states(world: engine.World) -> dict[str, str]:
    """Every slot of every mover, as exact text (floats' repr is exact)."""
    out = {}
    for mid, m in world.movers.items():
        for name in mover_state_slot_names():
            out[f"{mid}.{name}"] = repr(getattr(m, name))
    return out


# -- sight -------------------------------------------------------------------------------------------


def test_sight_across_open_flat_ground_is_clear_and_crosses_landblocks() -> None:
    world = flat_world(((0xA9, 0xB4), (0xAA, 0xB4), (0xAB, 0xB4)))
    # 1.5 m above flat ground, from the first landblock into the third (ACE refuses more than one apart)
    assert world.sight(at(0xA9B4, 100.0, 50.0, FLAT_Z + 1.5), at(0xABB4, 80.0, 60.0, FLAT_Z + 1.5)).clear
    assert world.sight(at(0xA9B4, 10.0, 10.0, FLAT_Z + 1.5), at(0xA9B4, 180.0, 170.0, FLAT_Z + 1.5)).clear


def test_sight_through_a_hill_is_blocked_by_the_terrain() -> None:
    # a 30 m spike at vertex (4, 4) = (96, 96) on 10 m flat ground
    world = world_from_heights(lambda bx, by, x, y: 80 if (x, y) == (4, 4) else FLAT_BYTE)
    result = world.sight(at(A9B4, 40.0, 96.0, FLAT_Z + 2.0), at(A9B4, 150.0, 96.0, FLAT_Z + 2.0))
    assert not result.clear
    assert result.blocker is not None and result.blocker.kind == "terrain"
    assert result.stop is not None and 72.0 < result.stop.frame.origin.x < 96.0  # on the hill's west face
    assert result.normal is not None and result.normal.x < 0.0  # facing back at the viewer
    # the same line 4 m higher than the spike's top is clear
    assert world.sight(at(A9B4, 40.0, 96.0, 44.0), at(A9B4, 150.0, 96.0, 44.0)).clear


def test_sight_through_a_building_shell_is_blocked_and_through_its_doorway_clear() -> None:
    world, room, b = house_world()
    eye = GROUND + 1.5
    outside = b.outdoor_cell(CX, CY)
    # west to east straight through the house: the west wall's outer face is at x = CX - 3.25
    through = world.sight(Position.at(outside, Vec3(CX - 10.0, CY, eye)), Position.at(outside, Vec3(CX + 10.0, CY, eye)))
    assert not through.clear
    assert through.blocker is not None and through.blocker.kind == "building"
    assert through.normal is not None and through.normal.x == pytest.approx(-1.0)
    assert through.stop is not None and CX - 3.25 - SIGHT_RADIUS - 0.1 <= through.stop.frame.origin.x <= CX - 3.25 - SIGHT_RADIUS
    # from 8 m south of the door (1.5 m wide, 2.25 m high, centred on x = CX) into the room: clear
    assert world.sight(Position.at(outside, Vec3(CX, CY - 8.0, eye)), Position.at(room, Vec3(CX, CY, eye))).clear
    # the same line 2 m east meets the south wall
    wall = world.sight(Position.at(outside, Vec3(CX + 2.0, CY - 8.0, eye)), Position.at(room, Vec3(CX + 2.0, CY, eye)))
    assert not wall.clear and wall.normal is not None and wall.normal.y == pytest.approx(-1.0)


def test_sight_out_of_a_closed_room_is_blocked_by_its_walls() -> None:
    b = SceneBuilder()
    room = b.add_struct(room_struct(HOUSE_LO, HOUSE_HI, [HOUSE_DOOR]))
    shell = b.add_gfx_obj(gfx_obj(shell_boxes(HOUSE_LO, HOUSE_HI, 0.25, None)))  # no door in the shell
    inside = b.add_env_cell(room, (CX, CY, GROUND), [(0xFFFF, 0)])
    b.add_building(shell, (CX, CY, GROUND), [(inside, 0)])
    world = b.world()
    eye = GROUND + 1.5
    outside = b.outdoor_cell(CX, CY)
    # in from the south, where the other house has its door: the closed shell stops it
    closed = world.sight(Position.at(outside, Vec3(CX, CY - 8.0, eye)), Position.at(inside, Vec3(CX, CY, eye)))
    assert not closed.clear and closed.blocker is not None and closed.blocker.kind == "building"
    # out of the room eastwards: the room's own east wall (x = CX + 3) stops it first
    out = world.sight(Position.at(inside, Vec3(CX, CY, eye)), Position.at(outside, Vec3(CX + 10.0, CY, eye)))
    assert not out.clear and out.blocker is not None and out.blocker.kind == "cell"
    assert out.stop is not None and CX + 3.0 - SIGHT_RADIUS - 0.1 <= out.stop.frame.origin.x <= CX + 3.0 - SIGHT_RADIUS


@pytest.mark.parametrize("margin, clear", [(0.02, True), (-0.02, False), (0.5, True), (-0.5, False)])
def test_sight_past_an_objects_edge_is_clear_by_more_than_the_sight_radius(margin: float, clear: bool) -> None:
    """A 1 m sphere at (96, 96, 13): a line at distance d from its centre
    meets it when d < 1 + the sight radius."""
    world = flat_world()
    mid = world.add_mover(MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.0), 1.0)], gravity=False), at(A9B4, 96.0, 96.0, 13.0))
    d = 1.0 + SIGHT_RADIUS + margin
    result = world.sight(at(A9B4, 80.0, 96.0 + d, 13.0), at(A9B4, 112.0, 96.0 + d, 13.0))
    assert result.clear is clear
    if not clear:
        assert result.blocker == engine.queries.Blocker("object", mid)


def test_sight_aimed_at_a_target_is_clear_when_it_reaches_the_target() -> None:
    world = flat_world()
    target = world.add_mover(MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.0), 0.5)], gravity=False, creature=True), at(A9B4, 96.0, 96.0, 11.5))
    a, b = at(A9B4, 80.0, 96.0, 11.5), at(A9B4, 96.0, 96.0, 11.5)
    assert not world.sight(a, b).clear  # the creature is in the way of a plain sight line
    assert world.sight(a, b, target_id=target).clear  # IsDirectVisible: reaching the target is seeing it


def test_a_viewers_own_body_does_not_block_its_sight_when_it_is_named() -> None:
    """An eye 1.6 m up a player is inside its head sphere (centre 1.35 m, radius
    0.48): the sweep starts in the viewer. Named as the viewer, the sweep
    starts outside it (0.48 + 0.1 m toward the other eye), as IsDirectVisible does."""
    from benchmarks.scenes import PLAYER

    world = flat_world()
    viewer = world.add_mover(PLAYER, at(A9B4, 50.0, 50.0, FLAT_Z))
    a, b = at(A9B4, 50.0, 50.0, FLAT_Z + 1.6), at(A9B4, 65.0, 50.0, FLAT_Z + 1.6)
    blocked = world.sight(a, b)
    assert not blocked.clear and blocked.blocker == engine.queries.Blocker("object", viewer)
    assert world.sight(a, b, viewer_id=viewer).clear
    # a second player in the way still blocks a viewer's sight
    other = world.add_mover(PLAYER, at(A9B4, 58.0, 50.0, FLAT_Z))
    seen = world.sight(a, b, viewer_id=viewer)
    assert not seen.clear and seen.blocker == engine.queries.Blocker("object", other)


# -- rays --------------------------------------------------------------------------------------------


MISSILE_R = 0.5  # the segments below are at most 30 radii long: the retail step cap of a move


@pytest.mark.parametrize(
    "start, end",
    [
        ((40.0, 96.0, 14.0), (50.0, 96.0, 8.0)),  # into the flat ground
        ((80.0, 96.0, 12.0), (90.0, 97.0, 12.5)),  # nothing in the way
        ((85.0, 95.0, 13.0), (99.5, 96.5, 13.0)),  # into the pillar
    ],
)
def test_a_ray_stops_where_a_missiles_move_on_the_same_segment_stops(start: tuple[float, float, float], end: tuple[float, float, float]) -> None:
    """Same engine, two ways: World.ray against a registered PathClipped
    mover of the same sphere moved along the same segment. The move stops at
    the step before the colliding one; the ray carries on to the contact, so
    it ends no nearer than the move and at most one step (one radius) further,
    with the same surface's normal, and the move from the start to where the
    ray ended gets there."""

    def scene() -> engine.World:
        w = flat_world()
        w.add_mover(MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.0), 1.0)], gravity=False), at(A9B4, 96.0, 96.0, 13.0))
        return w

    s, e = at(A9B4, *start), at(A9B4, *end)
    hit = scene().ray(s, e, MISSILE_R)
    missile = MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.0), MISSILE_R)], state=["PathClipped"], gravity=False, step_down=False)
    world = scene()
    moved = world.move(world.add_mover(missile, s), e)
    assert moved.ok
    assert hit.hit == (moved.collision_normal is not None)
    if hit.hit:
        assert hit.normal is not None and moved.collision_normal is not None
        assert hit.normal.dot(moved.collision_normal) > 0.99
        travelled = s.get_offset(moved.position).length()
        assert travelled - 1e-4 <= hit.distance <= travelled + MISSILE_R + 1e-4
        world = scene()
        to_contact = world.move(world.add_mover(missile, s), hit.position)
        assert to_contact.ok  # it gets there (touching, at most): the ray's stop is not inside anything
        assert (to_contact.position.frame.origin - hit.position.frame.origin).length() < 1e-3
    else:
        assert same_position(hit.position, moved.position)
        # the sweep's steps add up to the end to float32 rounding
        assert hit.position.cell_id == e.cell_id and (e.frame.origin - hit.position.frame.origin).length() < 1e-3
        assert hit.distance == pytest.approx(s.get_offset(e).length(), abs=1e-3)


@pytest.mark.parametrize("radius", [0.05, 0.1, 0.3, 1.0])
def test_a_ray_stops_touching_what_it_meets_with_that_surfaces_normal(radius: float) -> None:
    """The sphere's centre ends one radius before the surface along the ray: at x = wall - r before a
    wall facing -x, at z = ground + r over flat ground, at centre distance 1 + r from a 1 m sphere;
    the normal is the surface's (found to CONTACT_TOLERANCE, float32 coordinates)."""
    tol = 2 * CONTACT_TOLERANCE
    world, room, b = house_world()
    eye = GROUND + 1.5
    outside = b.outdoor_cell(CX, CY)
    wall = world.ray(Position.at(outside, Vec3(CX - 10.0, CY, eye)), Position.at(outside, Vec3(CX + 10.0, CY, eye)), radius)
    assert wall.hit and wall.blocker == engine.queries.Blocker("building")
    assert wall.position.frame.origin.x == pytest.approx(CX - 3.25 - radius, abs=tol)
    assert wall.normal is not None and wall.normal.x == pytest.approx(-1.0) and abs(wall.normal.y) < 1e-6
    assert wall.distance == pytest.approx(10.0 - 3.25 - radius, abs=tol)
    # from inside the room eastwards: the room's own east wall (x = CX + 3, its inner face looking -x)
    inner = world.ray(Position.at(room, Vec3(CX, CY, eye)), Position.at(outside, Vec3(CX + 10.0, CY, eye)), min(radius, 0.5))
    assert inner.hit and inner.blocker == engine.queries.Blocker("cell")
    assert inner.position.frame.origin.x == pytest.approx(CX + 3.0 - min(radius, 0.5), abs=tol)
    assert inner.normal is not None and inner.normal.x == pytest.approx(-1.0)

    flat = flat_world()
    down = flat.ray(at(A9B4, 10.0, 10.0, 14.0), at(A9B4, 10.0, 10.0, 5.0), radius)
    assert down.hit and down.blocker == engine.queries.Blocker("terrain")
    assert down.position.frame.origin.z == pytest.approx(FLAT_Z + radius, abs=tol)
    assert down.normal == Vec3(0.0, 0.0, 1.0)
    ball = flat.add_mover(MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.0), 1.0)], gravity=False), at(A9B4, 96.0, 96.0, 13.0))
    side = flat.ray(at(A9B4, 80.0, 96.0, 13.0), at(A9B4, 112.0, 96.0, 13.0), radius)
    assert side.hit and side.blocker == engine.queries.Blocker("object", ball)
    assert side.position.frame.origin.x == pytest.approx(96.0 - 1.0 - radius, abs=tol)
    assert side.normal is not None and side.normal.x == pytest.approx(-1.0)


def test_a_ray_into_flat_ground_rests_on_it() -> None:
    world = flat_world()
    hit = world.ray(at(A9B4, 10.0, 10.0, 14.0), at(A9B4, 20.0, 10.0, 5.0), 0.5)
    assert hit.hit and hit.blocker == engine.queries.Blocker("terrain")
    assert hit.normal == Vec3(0.0, 0.0, 1.0)
    # the sphere ends on the ground (centre one radius up), not further along than the ground line
    assert hit.position.frame.origin.z == pytest.approx(FLAT_Z + 0.5, abs=1e-4)
    assert 10.0 < hit.position.frame.origin.x <= 10.0 + 10.0 * 3.5 / 9.0 + 0.5


def test_batched_rays_equal_single_rays_and_take_numpy_columns() -> None:
    world = flat_world()
    starts = [at(A9B4, 10.0 + i, 10.0, 14.0) for i in range(5)]
    ends = [at(A9B4, 20.0 + i, 10.0 + i, 5.0 + i * 2.0) for i in range(5)]
    singles = [world.ray(s, e, 0.5) for s, e in zip(starts, ends)]
    assert [ray_key(h) for h in world.rays(starts, ends, 0.5)] == [ray_key(h) for h in singles]
    columns = rays_array(
        world,
        np.array([s.cell_id for s in starts], dtype=np.uint32),
        np.array([(s.frame.origin.x, s.frame.origin.y, s.frame.origin.z) for s in starts]),
        np.array([e.cell_id for e in ends], dtype=np.uint32),
        np.array([(e.frame.origin.x, e.frame.origin.y, e.frame.origin.z) for e in ends]),
        0.5,
    )
    assert [ray_key(h) for h in columns] == [ray_key(h) for h in singles]
    assert [sight_key(r) for r in world.sights(starts, ends)] == [sight_key(world.sight(s, e)) for s, e in zip(starts, ends)]
    cols = [
        np.array([p.cell_id for p in starts], dtype=np.int64),
        np.array([(p.frame.origin.x, p.frame.origin.y, p.frame.origin.z) for p in starts]),
        np.array([p.cell_id for p in ends], dtype=np.int64),
        np.array([(p.frame.origin.x, p.frame.origin.y, p.frame.origin.z) for p in ends]),
    ]
    assert [sight_key(r) for r in sights_array(world, *cols)] == [sight_key(world.sight(s, e)) for s, e in zip(starts, ends)]
    assert grounds_array(world, cols[0], cols[1]) == [world.ground(p) for p in starts]
    with pytest.raises(ValueError, match="shape"):
        rays_array(world, cols[0], cols[1][:, :2], cols[2], cols[3], 0.5)


def test_batched_sights_take_a_target_and_a_viewer_per_pair() -> None:
    from benchmarks.scenes import PLAYER

    world = flat_world()
    viewer = world.add_mover(PLAYER, at(A9B4, 50.0, 50.0, FLAT_Z))
    target = world.add_mover(PLAYER, at(A9B4, 65.0, 50.0, FLAT_Z))
    a, b = at(A9B4, 50.0, 50.0, FLAT_Z + 1.6), at(A9B4, 65.0, 50.0, FLAT_Z + 1.6)
    got = world.sights([a, a, a], [b, b, b], target_ids=[0, target, target], viewer_ids=[0, 0, viewer])
    # plain: blocked by the viewer's own head; aimed at a target: every other
    # creature, the viewer too, is passed (MissileIgnore); named viewer: starts outside it
    assert [r.clear for r in got] == [False, True, True]
    assert got[0].blocker == engine.queries.Blocker("object", viewer)
    with pytest.raises(EngineError, match="query 0"):
        world.sights([a], [b], viewer_ids=[99])


# -- ground ------------------------------------------------------------------------------------------


def planar_byte(bx: int, by: int, x: int, y: int) -> int:
    return 20 + 4 * x + y


def planar_height(x: float, y: float) -> float:
    """The terrain of planar_byte in metres: every triangulation of a plane is that plane."""
    return 0.5 * (20.0 + 4.0 * x / 24.0 + y / 24.0)


@settings(max_examples=60, deadline=None)
@given(st.floats(0.0, 191.9), st.floats(0.0, 191.9), st.floats(0.0, 30.0))
def test_ground_outdoors_is_the_terrain_height(x: float, y: float, above: float) -> None:
    world = world_from_heights(planar_byte)
    z = planar_height(x, y)
    g = world.ground(at(A9B4, x, y, z + above))
    assert g is not None
    assert g.z == pytest.approx(z, abs=1e-4)
    assert g.cell == cell(A9B4, x, y) and g.walkable and g.water_depth == 0.0
    n = Vec3(-2.0 / 24.0, -0.5 / 24.0, 1.0)  # the plane's upward normal, unnormalised
    assert g.plane.normal.x == pytest.approx(n.x / n.length(), abs=1e-6)
    assert g.plane.normal.z == pytest.approx(1.0 / n.length(), abs=1e-6)


def test_ground_outdoors_past_the_landblock_edge_is_the_next_landblocks_terrain() -> None:
    world = world_from_heights(planar_byte, [(0xA9, 0xB4), (0xAA, 0xB4)])
    g = world.ground(Position.at(0xA9B40001, Vec3(200.0, 10.0, 40.0)))  # 8 m into AAB4
    assert g is not None and g.cell == cell(0xAAB4, 8.0, 10.0)
    assert g.z == pytest.approx(planar_height(8.0, 10.0), abs=1e-4)


def test_ground_outdoors_is_what_stands_on_the_land_where_something_does() -> None:
    """A 4 x 4 x 3 m static block on the land (its top 3 m up), a house with a flat roof (3.25 m up),
    a 1 m ball (not a creature) floating with its top 14 m up and a player standing on flat land:
    the ground over the block, the roof and the ball is their top, where a falling mover rests
    (test_indoor_scenarios: a flat roof catches a falling mover); beside them, and over the player
    (a creature's head is not ground), it is the land."""
    b = SceneBuilder()
    block = b.add_gfx_obj(gfx_obj([box_solid((-2.0, -2.0, 0.0), (2.0, 2.0, 3.0))]))
    b.add_object(block, (CX, CY, GROUND))
    world = b.world()
    outside = b.outdoor_cell(CX, CY)
    for dx, want in ((0.5, GROUND + 3.0), (1.9, GROUND + 3.0), (-1.5, GROUND + 3.0), (2.1, GROUND), (5.0, GROUND)):
        g = world.ground(Position.at(outside, Vec3(CX + dx, CY - 0.5, GROUND + 8.0)))
        assert g is not None and g.z == pytest.approx(want, abs=5e-4), dx
        assert g.walkable and g.plane.normal == Vec3(0.0, 0.0, 1.0) and g.cell == outside
    # a point between the land and the block's top, beside the block: the land
    g = world.ground(Position.at(outside, Vec3(CX + 2.5, CY, GROUND + 1.0)))
    assert g is not None and g.z == pytest.approx(GROUND)

    house, _room, hb = house_world()
    roof = house.ground(Position.at(hb.outdoor_cell(CX, CY), Vec3(CX + 1.0, CY + 1.0, GROUND + 8.0)))
    assert roof is not None and roof.z == pytest.approx(GROUND + HOUSE_HI[2] + 0.25, abs=5e-4) and roof.walkable

    from benchmarks.scenes import PLAYER

    flat = flat_world()
    flat.add_mover(MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.0), 1.0)], gravity=False), at(A9B4, 96.0, 96.0, 13.0))
    top = flat.ground(at(A9B4, 96.0, 96.0, 20.0))
    assert top is not None and top.z == pytest.approx(14.0, abs=5e-4) and top.plane.normal.z == pytest.approx(1.0)
    flat.add_mover(PLAYER, at(A9B4, 50.0, 50.0, FLAT_Z))
    over_head = flat.ground(at(A9B4, 50.0, 50.0, FLAT_Z + 4.0))
    assert over_head is not None and over_head.z == pytest.approx(FLAT_Z) and over_head.water_depth == 0.0


@pytest.mark.parametrize("height", [0.0, 1.5, 2.9])
def test_ground_indoors_is_the_floor_polygon(height: float) -> None:
    world, room, _ = house_world()
    g = world.ground(Position.at(room, Vec3(CX + 1.0, CY + 1.0, GROUND + height)))
    assert g is not None
    assert g.z == pytest.approx(GROUND, abs=1e-3)  # the room's floor, HOUSE_LO z = 0 at GROUND
    assert g.cell == room and g.walkable
    assert g.plane.normal == Vec3(0.0, 0.0, 1.0)


def test_batched_grounds_equal_single_grounds() -> None:
    world, room, b = house_world()
    points = [Position.at(room, Vec3(CX, CY, GROUND + 1.0)), Position.at(b.outdoor_cell(20.0, 20.0), Vec3(20.0, 20.0, GROUND + 3.0))]
    assert world.grounds(points) == [world.ground(p) for p in points]


# -- bad input, and no query changes a mover ------------------------------------------------------------


def test_bad_queries_get_clear_errors() -> None:
    world = flat_world()
    good = at(A9B4, 10.0, 10.0, 12.0)
    with pytest.raises(NonFiniteError):
        world.sight(good, at(A9B4, 20.0, 10.0, math.nan))
    with pytest.raises(EngineError):
        world.ray(Position.at(good.cell_id, Vec3(math.inf, 10.0, 12.0)), good, 0.5)
    with pytest.raises(UnknownCellError):
        world.ground(Position.at(0xA9B40150, Vec3(10.0, 10.0, 12.0)))  # no such indoor cell
    with pytest.raises(LandblockNotLoadedError):
        world.sight(good, Position.at(0xAAB40001, Vec3(10.0, 10.0, 12.0)))
    with pytest.raises(OutOfRangeError):
        world.ray(good, at(A9B4, 20.0, 10.0, 12.0), 0.0)
    with pytest.raises(EngineError, match="query 1"):
        world.rays([good, good], [good, at(A9B4, 20.0, 10.0, math.nan)], 0.5)


def test_a_sweep_that_would_cross_unloaded_land_is_refused() -> None:
    # A9B4 and ABB4 loaded, AAB4 between them not
    world = flat_world(((0xA9, 0xB4), (0xAB, 0xB4)))
    with pytest.raises(LandblockNotLoadedError, match="AAB4"):
        world.sight(at(0xA9B4, 100.0, 50.0, 12.0), at(0xABB4, 80.0, 50.0, 12.0))


def test_no_query_changes_any_mover() -> None:
    world = flat_world()
    from benchmarks.scenes import PLAYER

    ids = [
        world.add_mover(PLAYER, at(A9B4, 50.0, 50.0, FLAT_Z)),
        world.add_mover(MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.0), 1.0)], gravity=False, creature=True), at(A9B4, 96.0, 96.0, 13.0)),
    ]
    world.move(ids[0], at(A9B4, 51.0, 50.0, FLAT_Z))
    before = mover_states(world)
    world.sight(at(A9B4, 40.0, 50.0, 11.0), at(A9B4, 60.0, 50.0, 11.0))  # through the player
    world.sight(at(A9B4, 80.0, 96.0, 13.0), at(A9B4, 110.0, 96.0, 13.0), target_id=ids[1])
    world.ray(at(A9B4, 80.0, 96.0, 13.0), at(A9B4, 110.0, 96.0, 13.0), 0.5)
    world.rays([at(A9B4, 49.0, 49.0, 14.0)], [at(A9B4, 51.0, 50.0, 9.0)], 0.5)
    world.ground(at(A9B4, 50.0, 50.0, 12.0))
    assert mover_states(world) == before
    assert world.move(ids[0], at(A9B4, 52.0, 50.0, FLAT_Z)).ok  # and the world moves on as before


# -- property: above the terrain is clear, under it blocked -----------------------------------------------


def bumpy_byte(bx: int, by: int, x: int, y: int) -> int:
    return 20 + (x * 7 + y * 13) % 11  # 10 .. 15 m


def terrain_bounds(x: float, y: float) -> tuple[float, float]:
    """The lowest and highest the terrain can be at (x, y) whichever diagonal
    splits the cell: the min and max of the two triangulations' heights."""
    cx, cy = min(int(x // 24), 7), min(int(y // 24), 7)
    u, v = x / 24.0 - cx, y / 24.0 - cy
    h = {(i, j): 0.5 * bumpy_byte(0xA9, 0xB4, cx + i, cy + j) for i in (0, 1) for j in (0, 1)}
    # diagonal (0,0)-(1,1)
    if u > v:
        a = h[0, 0] + u * (h[1, 0] - h[0, 0]) + v * (h[1, 1] - h[1, 0])
    else:
        a = h[0, 0] + v * (h[0, 1] - h[0, 0]) + u * (h[1, 1] - h[0, 1])
    # diagonal (1,0)-(0,1)
    if u + v < 1.0:
        b = h[0, 0] + u * (h[1, 0] - h[0, 0]) + v * (h[0, 1] - h[0, 0])
    else:
        b = h[1, 1] + (1.0 - u) * (h[0, 1] - h[1, 1]) + (1.0 - v) * (h[1, 0] - h[1, 1])
    return min(a, b), max(a, b)


_BUMPY = world_from_heights(bumpy_byte)
_COORD = st.floats(2.0, 190.0)
_HEIGHT = st.floats(10.0, 20.0)


def _samples(p: tuple[float, float, float], q: tuple[float, float, float]) -> list[tuple[float, float, float]]:
    n = max(2, int(math.dist(p[:2], q[:2]) / 0.1))
    return [tuple(a + (b - a) * i / n for a, b in zip(p, q)) for i in range(n + 1)]  # type: ignore[misc]


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])
@given(_COORD, _COORD, _HEIGHT, _COORD, _COORD, _HEIGHT)
@example(20.0, 2.0, 20.0, 19.999999999999996, 2.0, 20.0)  # a segment of a few ulps: once refused as blocked
def test_a_segment_a_metre_above_the_terrain_is_clear(x0: float, y0: float, z0: float, x1: float, y1: float, z1: float) -> None:
    samples = _samples((x0, y0, z0), (x1, y1, z1))
    assume(all(z - terrain_bounds(x, y)[1] >= 1.0 for x, y, z in samples))
    assert _BUMPY.sight(at(A9B4, x0, y0, z0), at(A9B4, x1, y1, z1)).clear


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])
@given(_COORD, _COORD, _HEIGHT, _COORD, _COORD, _HEIGHT)
def test_a_segment_dipping_a_metre_under_the_terrain_is_blocked(x0: float, y0: float, z0: float, x1: float, y1: float, z1: float) -> None:
    samples = _samples((x0, y0, z0), (x1, y1, z1))
    # it starts in the open (its sphere clear of the ground) and somewhere goes a metre under
    assume(z0 - terrain_bounds(x0, y0)[1] >= 0.5)
    assume(any(terrain_bounds(x, y)[0] - z >= 1.0 for x, y, z in samples))
    result = _BUMPY.sight(at(A9B4, x0, y0, z0), at(A9B4, x1, y1, z1))
    assert not result.clear
    assert result.blocker is not None and result.blocker.kind == "terrain"
