"""The spatial queries on the bus (docs/protocol.md, "Spatial queries"): a service on the demo scene
answers sight / ray / ground / place exactly as the library does in this process (same engine, two
ways), with answers whose geometry is obvious (ground under a point is the terrain's height there; a
sight line high above the land is clear, one ending under the ground is stopped by the terrain), the
same error kinds as moves, per-item errors in batches, and no change to any mover."""

from __future__ import annotations

import math
from collections.abc import Iterator

import pytest

from clients import Client
from clients.demo_world import global_to_cell
from clients.errors import ServiceError
from engine.geometry import Position, Vec3
from service.wire import ErrorKind
from service_support import ServiceProcess, comparable, demo_world, human, raw_query, raw_session

WORLD = demo_world()
POINTS = [(40.0, 50.0), (60.0, 50.0), (100.0, 120.0), (150.0, 30.0), (20.0, 170.0)]


def above(gx: float, gy: float, dz: float) -> Position:
    """The point `dz` above (below, when negative) the demo land at global (gx, gy)."""
    cell, x, y = global_to_cell(gx, gy)
    return Position.at(cell, Vec3(x, y, WORLD.terrain_height(cell, x, y) + dz))


def same(a: object, b: object) -> bool:
    """Equal field by field, floats exactly (Position compares by identity; repr spells every float exactly)."""
    return repr(a) == repr(b)


@pytest.fixture(scope="module")
def service() -> Iterator[ServiceProcess]:
    with ServiceProcess() as svc:
        yield svc


@pytest.fixture()
def client(service: ServiceProcess) -> Iterator[Client]:
    with Client([service.endpoint], timeout=10.0) as c:
        c.wait_ready()
        yield c


def test_ground_is_the_terrain_height_and_the_library_answer(client: Client) -> None:
    for gx, gy in POINTS:
        p = above(gx, gy, 2.0)
        g = client.ground(p)
        assert g is not None
        assert g.z == pytest.approx(p.frame.origin.z - 2.0, abs=1e-4)
        assert g == WORLD.ground(p)
    # the batch form answers in order, each as the single form does
    batch = client.grounds([above(gx, gy, 2.0) for gx, gy in POINTS])
    assert batch == [client.ground(above(gx, gy, 2.0)) for gx, gy in POINTS]


def test_sight_high_above_the_land_is_clear_and_into_the_ground_blocked(client: Client) -> None:
    a, b = above(40.0, 50.0, 30.0), above(100.0, 120.0, 30.0)
    hi = max(a.frame.origin.z, b.frame.origin.z)
    a2 = Position.at(a.cell_id, Vec3(a.frame.origin.x, a.frame.origin.y, hi))
    b2 = Position.at(b.cell_id, Vec3(b.frame.origin.x, b.frame.origin.y, hi))
    clear = client.sight(a2, b2)
    assert clear.clear and clear.blocker is None
    buried = above(100.0, 120.0, -5.0)
    blocked = client.sight(a2, buried)
    assert not blocked.clear
    assert blocked.blocker is not None and blocked.blocker.kind == "terrain"
    assert same((clear, blocked), (WORLD.sight(a2, b2), WORLD.sight(a2, buried)))
    assert same(client.sights([(a2, b2), (a2, buried)]), [clear, blocked])


def test_ray_stops_on_the_terrain_as_the_library_does(client: Client) -> None:
    start, end = above(40.0, 50.0, 3.0), above(60.0, 50.0, -3.0)
    hit = client.ray(start, end, 0.1)
    assert hit.hit and hit.blocker is not None and hit.blocker.kind == "terrain"
    s, t = start.frame.origin, end.frame.origin
    assert 0.0 < hit.distance < math.dist((s.x, s.y, s.z), (t.x, t.y, t.z))
    assert same(hit, WORLD.ray(start, end, 0.1))
    assert same(client.rays([(start, end)], 0.1), [hit])


def test_place_matches_the_library_and_changes_no_mover(client: Client) -> None:
    free = above(150.0, 30.0, 0.5)
    assert same(client.place(human(), free), WORLD.place(human(), free))  # no mover there yet: as the library
    st = client.register(human(), free)
    before = client.get(st.id)
    spot = st.position
    # the placement sees the registered player standing there and puts the new one beside it: the two
    # bodies (spheres of radius 0.48 on a vertical axis) no closer than their two radii
    placed = client.place(human(), spot)
    assert placed.ok and placed.position is not None
    o, m = placed.position.frame.origin, spot.frame.origin
    assert math.hypot(o.x - m.x, o.y - m.y) >= 2 * 0.48 - 1e-3
    # every query, aimed at and from the mover's own spot
    client.sight(above(150.0, 30.0, 10.0), spot, target=st.id)
    client.ray(above(150.0, 30.0, 10.0), spot, 0.2, target=st.id)
    client.ground(spot)
    client.places([(human(), spot)] * 3)
    after = client.get(st.id)
    assert after[0].seq == before[0].seq
    assert comparable(after[0]) == comparable(before[0])
    assert after[1] == before[1]
    client.remove(st.id)


def test_bad_queries_get_the_move_error_kinds_and_the_service_keeps_serving(client: Client) -> None:
    good = above(40.0, 50.0, 2.0)
    nan = Position.at(good.cell_id, Vec3(good.frame.origin.x, math.nan, good.frame.origin.z))
    with pytest.raises(ServiceError) as e:
        client.ground(nan)
    assert e.value.kind == ErrorKind.NON_FINITE
    with pytest.raises(ServiceError) as e:
        client.ground(Position.at((0xA9B4 << 16) | 0x0999, Vec3(10.0, 10.0, 10.0)))
    assert e.value.kind == ErrorKind.UNKNOWN_CELL
    with pytest.raises(ServiceError) as e:
        client.sight(Position.at(0x12340001, Vec3(10.0, 10.0, 10.0)), good)
    assert e.value.kind == ErrorKind.LANDBLOCK_NOT_LOADED
    with pytest.raises(ServiceError) as e:
        client.ray(good, above(60.0, 50.0, 2.0), -1.0)
    assert e.value.kind == ErrorKind.BAD_VALUE
    # a batch answers each item: the bad one an error in its place, the others as alone
    mixed = client.grounds([good, Position.at(0x12340001, Vec3(1.0, 1.0, 1.0)), good])
    assert isinstance(mixed[1], ServiceError) and mixed[1].kind == ErrorKind.LANDBLOCK_NOT_LOADED
    assert mixed[0] == mixed[2] == WORLD.ground(good)


def test_query_keys_are_checked_like_move_keys(service: ServiceProcess) -> None:
    import msgpack

    from service.codec import encode_position

    good = above(40.0, 50.0, 2.0)
    body = msgpack.packb({"v": 1, "ground": {"position": encode_position(good)}}, use_bin_type=True)
    with raw_session(service.endpoint) as s:
        ok, msg = raw_query(s, "acphys/lb/A9B4/ground", body, timeout=10.0)
        assert ok and msg["ground"]["z"] == pytest.approx(good.frame.origin.z - 2.0, abs=1e-4)
        # a position outside the key's landblock: wrong_landblock naming the right one
        ok, msg = raw_query(s, "acphys/lb/A9B5/ground", body, timeout=10.0)
        assert not ok and msg["error"]["kind"] == ErrorKind.WRONG_LANDBLOCK and msg["error"]["landblock"] == 0xA9B4
        # neither form, or both
        ok, msg = raw_query(s, "acphys/lb/A9B4/ground", msgpack.packb({"v": 1}), timeout=10.0)
        assert not ok and msg["error"]["kind"] == ErrorKind.MISSING_FIELD
        both = {"v": 1, "ground": {"position": encode_position(good)}, "grounds": []}
        ok, msg = raw_query(s, "acphys/lb/A9B4/ground", msgpack.packb(both, use_bin_type=True), timeout=10.0)
        assert not ok and msg["error"]["kind"] == ErrorKind.BAD_VALUE


def test_a_registered_mover_blocks_a_ray_and_is_named_by_its_wire_id(client: Client) -> None:
    st = client.register(human(), above(100.0, 120.0, 0.0))
    try:
        m = st.position.frame.origin
        # a horizontal segment through the upper sphere's centre (0.48 m sphere at 1.35 m), 2 m either side
        start = Position.at(st.position.cell_id, Vec3(m.x - 2.0, m.y, m.z + 1.35))
        end = Position.at(st.position.cell_id, Vec3(m.x + 2.0, m.y, m.z + 1.35))
        hit = client.ray(start, end, 0.1)
        assert hit.hit and hit.blocker is not None
        assert hit.blocker.kind == "object" and hit.blocker.object_id == st.id
        # the centre stops at the touch of the two spheres (0.48 + 0.1 before the body's axis), never inside,
        # and at most a few centimetres short of it
        assert m.x - 0.58 - 0.05 <= hit.position.frame.origin.x <= m.x - 0.58 + 1e-6
        seen = client.sight(start, end, target=st.id)
        assert seen.clear  # looking at it: touching the target is arriving
    finally:
        client.remove(st.id)


def test_an_unknown_viewer_or_target_is_named_by_its_own_path(service: ServiceProcess) -> None:
    import msgpack

    from service.codec import encode_position

    a, b = above(40.0, 50.0, 1.6), above(60.0, 50.0, 1.6)
    sight = {"from": encode_position(a), "to": encode_position(b)}
    with raw_session(service.endpoint) as s:
        for field, path in (("viewer", "sight.viewer"), ("target", "sight.target")):
            body = msgpack.packb({"v": 1, "sight": {**sight, field: 0x7777777}}, use_bin_type=True)
            ok, msg = raw_query(s, "acphys/lb/A9B4/sight", body, timeout=10.0)
            assert not ok and msg["error"]["kind"] == ErrorKind.UNKNOWN_MOVER and msg["error"]["path"] == path, msg
        body = msgpack.packb({"v": 1, "sights": [sight, {**sight, "viewer": 0x7777777}]}, use_bin_type=True)
        ok, msg = raw_query(s, "acphys/lb/A9B4/sight", body, timeout=10.0)
        assert ok and "error" not in msg["sights"][0]
        assert msg["sights"][1]["error"]["path"] == "sights[1].viewer"
