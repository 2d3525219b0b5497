"""The spatial queries on the bus (docs/protocol.md, "Spatial queries"): a service on the demo scene
answers sight / ray / ground / place exactly as the library does in this process (same engine, two
ways), with answers whose geometry is obvious (ground under a point is the terrain's height there; a
sight line high above the land is clear, one ending under the ground is stopped by the terrain), the
same error kinds as moves, per-item errors in batches, and no change to any mover. The column form
("Query columns") answers every op exactly as the map form does, bit for bit, a bad item failing alone;
`Client.sights` pairs name their own target and viewer as the map form's items do."""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

from clients import Client, SightQuery
from clients.demo.world import global_to_cell
from clients.errors import ServiceError
from engine.geometry import Position, Vec3
from service.protocol.wire import ErrorKind
from support.service_harness import ServiceProcess, comparable, demo_world, human, raw_query, raw_session

WORLD = demo_world()
A9B4 = 0xA9B4
POINTS = [(40.0, 50.0), (60.0, 50.0), (100.0, 120.0), (150.0, 30.0), (20.0, 170.0)]


def above(gx: float, gy: float, dz: float) -> Position:
    """The point `dz` above (below, when negative) the demo land at global (gx, gy)."""
    cell, x, y = global_to_cell(gx, gy)
    return Position.at(cell, Vec3(x, y, WORLD.terrain_height(cell, x, y) + dz))


def same(a: object, b: object) -> bool:
    """Equal field by field, floats exactly (Position compares by identity; repr spells every float exactly)."""
    return repr(a) == repr(b)


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

    from service.protocol.codec import encode_position

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

    from service.protocol.codec import encode_position

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


def test_a_radius_below_a_millimetre_is_refused_naming_it_and_a_nil_batch_field_is_absent(
        service: ServiceProcess) -> None:
    """A tiny radius used to reach the engine: one single precision rounds to 0 was an `internal` error
    (a division by zero), one of 1e-4 m an invented hit at the start. Now `bad_value` on `OP.radius`."""
    import msgpack

    from service.protocol.codec import encode_position

    seg = {"from": encode_position(above(40.0, 50.0, 1.6)), "to": encode_position(above(42.0, 50.0, 1.6))}
    with raw_session(service.endpoint) as s:
        for op in ("ray", "sight"):
            for radius in (5e-324, 1e-200, 1e-4, 10.5):
                body = msgpack.packb({"v": 1, op: {**seg, "radius": radius}}, use_bin_type=True)
                ok, msg = raw_query(s, f"acphys/lb/A9B4/{op}", body, timeout=10.0)
                assert not ok and msg["error"]["kind"] == ErrorKind.BAD_VALUE, (op, radius, msg)
                assert msg["error"]["path"] == f"{op}.radius", msg
            body = msgpack.packb({"v": 1, op: {**seg, "radius": 0.001}}, use_bin_type=True)
            ok, msg = raw_query(s, f"acphys/lb/A9B4/{op}", body, timeout=10.0)
            assert ok, msg  # the smallest radius allowed is answered
            many = op + "s"
            body = msgpack.packb({"v": 1, many: None, op: {**seg, "radius": 0.1}}, use_bin_type=True)
            ok, msg = raw_query(s, f"acphys/lb/A9B4/{op}", body, timeout=10.0)
            assert ok and op in msg, msg  # nil is as good as absent (docs/protocol.md, Conventions)


# -- the column form (docs/protocol.md, "Query columns") ---------------------------------------------
def _columns_of(positions: list[Position]) -> tuple[np.ndarray[Any, Any], np.ndarray[Any, Any]]:
    return (np.array([p.cell_id for p in positions], dtype=np.uint32),
            np.array([p.frame.origin.as_tuple() for p in positions], dtype=np.float64))


def _bits(v: Any) -> Any:
    """A value as exact text (floats by repr; None and NaN kept apart)."""
    return repr(v.tolist() if isinstance(v, np.ndarray) else v)


def _vec(row: Any, given: bool) -> Any:
    return _bits(row) if given else None


GRID = [(40.0 + 13.0 * i, 50.0 + 7.0 * j) for i in range(4) for j in range(3)]


def test_sight_columns_equal_the_single_form_bit_for_bit(client: Client) -> None:
    eyes = [above(gx, gy, 1.6) for gx, gy in GRID]
    # looking at points above, on and under the land 30 m away: some clear, some stopped by the terrain
    targets = [above(gx + 30.0, gy + 10.0, dz) for (gx, gy), dz in zip(GRID, [5.0, -3.0, 1.6, -10.0] * 3)]
    fc, fo = _columns_of(eyes)
    tc, to = _columns_of(targets)
    cols = client.sight_columns(fc, fo, tc, to)
    assert not cols.errors and cols.flag("resolved").all()
    assert cols.flag("clear").any() and not cols.flag("clear").all()
    for i, (a, b) in enumerate(zip(eyes, targets)):
        one = client.sight(a, b)
        assert bool(cols.flag("clear")[i]) == one.clear
        stop_given = bool(cols.flag("stop given")[i])
        assert stop_given == (one.stop is not None)
        if one.stop is not None:
            assert _bits(cols["stop"][i]) == _bits(np.array(one.stop.frame.origin.as_tuple()))
            assert int(cols["cell"][i]) == one.cell == one.stop.cell_id
        normal = None if one.normal is None else _bits(np.array(one.normal.as_tuple()))
        assert _vec(cols["normal"][i], bool(cols.flag("normal given")[i])) == normal
        assert cols.blocker_kind(i) == (None if one.blocker is None else one.blocker.kind)


def test_ray_columns_equal_the_batch_form_bit_for_bit(client: Client) -> None:
    starts = [above(gx, gy, 3.0) for gx, gy in GRID]
    ends = [above(gx + 20.0, gy, -3.0 if k % 2 else 4.0) for k, (gx, gy) in enumerate(GRID)]
    fc, fo = _columns_of(starts)
    tc, to = _columns_of(ends)
    cols = client.ray_columns(fc, fo, tc, to, 0.1)
    batch = client.rays(list(zip(starts, ends)), 0.1)
    assert not cols.errors
    for i, hit in enumerate(batch):
        assert not isinstance(hit, ServiceError)
        assert bool(cols.flag("hit")[i]) == hit.hit
        assert _bits(cols["position"][i]) == _bits(np.array(hit.position.frame.origin.as_tuple()))
        assert int(cols["cell"][i]) == hit.cell and _bits(cols["distance"][i]) == _bits(np.float64(hit.distance))
        normal = None if hit.normal is None else _bits(np.array(hit.normal.as_tuple()))
        assert _vec(cols["normal"][i], bool(cols.flag("normal given")[i])) == normal
        assert cols.blocker_kind(i) == (None if hit.blocker is None else hit.blocker.kind)
        assert bool(cols.flag("blocker_id given")[i]) == (hit.blocker is not None and hit.blocker.object_id is not None)


def test_ground_columns_equal_the_single_form_and_a_bad_item_fails_alone(client: Client) -> None:
    points = [above(gx, gy, 2.0) for gx, gy in GRID]
    cells, origins = _columns_of(points)
    origins[4, 1] = math.nan
    cells[7] = (A9B4 << 16) | 0x0999  # no such indoor cell: the engine refuses it
    cols = client.ground_columns(cells, origins)
    assert set(cols.errors) == {4, 7}
    e4, e7 = cols.errors[4], cols.errors[7]
    assert isinstance(e4, ServiceError) and (e4.kind, e4.path) == (ErrorKind.NON_FINITE, "columns.origin[4][1]")
    assert isinstance(e7, ServiceError) and e7.kind == ErrorKind.UNKNOWN_CELL and e7.path == "columns.cell[7]"
    assert not cols.flag("resolved")[[4, 7]].any() and np.isnan(cols["z"][[4, 7]]).all()
    for i, p in enumerate(points):
        if i in (4, 7):
            continue
        g = client.ground(p)
        assert g is not None and cols.flag("found")[i] and bool(cols.flag("walkable")[i]) == g.walkable
        n = g.plane.normal
        assert _bits(cols["z"][i]) == _bits(np.float64(g.z))
        assert _bits(cols["plane"][i]) == _bits(np.array([n.x, n.y, n.z, g.plane.d]))
        assert int(cols["cell"][i]) == g.cell and _bits(cols["water_depth"][i]) == _bits(np.float64(g.water_depth))


def test_place_columns_equal_the_batch_form_bit_for_bit(client: Client) -> None:
    spots = [above(gx, gy, 0.5) for gx, gy in GRID[:6]]
    cells, origins = _columns_of(spots)
    cols = client.place_columns(human(), cells, origins)
    batch = client.places([(human(), p) for p in spots])
    assert not cols.errors
    for i, placed in enumerate(batch):
        assert not isinstance(placed, ServiceError) and placed.position is not None
        assert cols.placement_result(i) == placed.placement_result == "OK" and cols.flag("ok")[i]
        assert int(cols["cell"][i]) == placed.position.cell_id
        assert _bits(cols["origin"][i]) == _bits(np.array(placed.position.frame.origin.as_tuple()))
        assert _bits(cols["orientation"][i]) == _bits(np.array(placed.position.frame.orientation.as_tuple()))
        for flag in ("contact", "on_walkable", "water_contact"):
            assert bool(cols.flag(flag)[i]) == getattr(placed, flag)
        if placed.contact_plane is not None:
            n = placed.contact_plane.normal
            assert _bits(cols["contact_plane"][i]) == _bits(np.array([n.x, n.y, n.z, placed.contact_plane.d]))
            assert int(cols["contact_plane_cell"][i]) == placed.contact_plane_cell


def test_targets_and_viewers_by_column_and_by_pair(client: Client) -> None:
    st = client.register(human(), above(100.0, 120.0, 0.0))
    try:
        m = st.position.frame.origin
        eye = Position.at(st.position.cell_id, Vec3(m.x, m.y, m.z + 1.6))
        # from inside the mover's body to a point 3 m away and back through it
        out = Position.at(st.position.cell_id, Vec3(m.x + 3.0, m.y, m.z + 1.35))
        pairs: list[tuple[Position, Position] | SightQuery] = [
            SightQuery(eye, out, viewer=st.id), SightQuery(out, eye, target=st.id), SightQuery(out, eye), (out, eye)]
        answers = client.sights(pairs)
        singles = [client.sight(eye, out, viewer=st.id), client.sight(out, eye, target=st.id), client.sight(out, eye),
                   client.sight(out, eye)]
        assert [repr(a) for a in answers] == [repr(s) for s in singles]
        assert answers[1].clear and not answers[2].clear  # type: ignore[union-attr]  # the target ends the sweep as arrived
        fc, fo = _columns_of([eye, out, out, out])
        tc, to = _columns_of([out, eye, eye, eye])
        cols = client.sight_columns(fc, fo, tc, to, targets=np.array([0, st.id, 0, 0xDEAD], dtype=np.uint64),
                                    viewers=np.array([st.id, 0, 0, 0], dtype=np.uint64))
        assert cols.flag("clear")[:3].tolist() == [s.clear for s in singles[:3]]
        assert int(cols["blocker_id"][2]) == st.id and cols.flag("blocker_id given")[2]
        e = cols.errors[3]
        assert isinstance(e, ServiceError) and (e.kind, e.path) == (ErrorKind.UNKNOWN_MOVER, "columns.target[3]")
    finally:
        client.remove(st.id)


def test_health_announces_the_column_form(client: Client) -> None:
    (h,) = client.health()
    assert h.get("query_forms") == ["single", "batch", "columns"]


def test_client_refuses_wrong_shapes_before_sending(client: Client) -> None:
    with pytest.raises(ValueError, match="from_origin"):
        client.sight_columns([0xA9B4000B], np.zeros((2, 3)), [0xA9B4000B], np.zeros((1, 3)))
    with pytest.raises(ValueError, match="radius"):
        client.ray_columns([0xA9B4000B], np.zeros((1, 3)), [0xA9B4000B], np.zeros((1, 3)), [0.1, 0.2])
