"""Client.path and Client.paths against a real service (a subprocess) on the shared scenes.

The expected answers are obvious geometry (a straight path across the open flat scene is as long as the
distance), the engine's own World.path run here on the same scene loaded locally (an independent
computation of the service's answer), or the protocol's words (a goal in a landblock the instance does
not hold is `not_loaded`; an id no mover has is `unknown_mover`). A path found for a registered mover is
walked over the bus with Client.move as docs/protocol.md's guarantee says, and must arrive.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import pytest

import engine
from clients import Client, ServiceError
from clients.paths import MAX_PATHS_PER_REQUEST
from engine import Position, Vec3
from support.service_harness import ServiceProcess, human
from support.shared_data import SCENES, require_shared

require_shared()

LB = 0xA9B4
#: the flat scene's ground everywhere (height byte 50 of its table)
FLAT_Z = 112.5
#: docs/protocol.md, "Paths": the guarantee's stride and arrival tolerance
STRIDE, TOLERANCE = 3.0, 0.25
WALKER = human()


def at(x: float, y: float, z: float = FLAT_Z, landblock: int = LB, cell: int | None = None) -> Position:
    """A position in the landblock's outdoor cell holding (x, y) (or the indoor cell given)."""
    index = int(x // 24) * 8 + int(y // 24) + 1
    return Position.at((landblock << 16) | (cell if cell is not None else index), Vec3(x, y, z))


def where(p: Position) -> tuple[int, float, float, float]:
    o = p.frame.origin
    return p.cell_id, o.x, o.y, o.z


@pytest.fixture(scope="module")
def flat() -> Iterator[ServiceProcess]:
    with ServiceProcess(SCENES / "flat.json") as svc:
        yield svc


@pytest.fixture(scope="module")
def house() -> Iterator[ServiceProcess]:
    with ServiceProcess(SCENES / "house.json") as svc:
        yield svc


@pytest.fixture()
def client(flat: ServiceProcess) -> Iterator[Client]:
    with Client([flat.endpoint], timeout=60.0) as c:
        yield c


def test_an_open_field_path_is_straight_and_as_long_as_the_distance(client: Client) -> None:
    start, goal = at(30.0, 30.0), at(150.0, 170.0)
    r = client.path(WALKER, start, goal)
    assert r.found and r.reason is None and r.detail == ""
    assert r.length == pytest.approx(math.hypot(120.0, 140.0), rel=0.02)
    first, last = r.waypoints[0], r.waypoints[-1]
    # placed at the start and standing at the goal: the flat ground, in the outdoor cells holding them
    assert first.cell_id == at(30.0, 30.0).cell_id and last.cell_id == at(150.0, 170.0).cell_id
    assert math.hypot(first.frame.origin.x - 30.0, first.frame.origin.y - 30.0) <= TOLERANCE
    assert math.hypot(last.frame.origin.x - 150.0, last.frame.origin.y - 170.0) <= TOLERANCE
    assert last.frame.origin.z == pytest.approx(FLAT_Z, abs=0.05)
    assert r.end is last


def test_a_goal_in_a_landblock_not_loaded_is_answered_not_loaded(client: Client) -> None:
    r = client.path(WALKER, at(30.0, 30.0), at(50.0, 50.0, landblock=0xB0B0))
    assert not r.found and r.reason == "not_loaded" and r.waypoints == []
    assert "b0b0" in r.detail.lower()


def test_a_path_longer_than_max_distance_is_not_found(client: Client) -> None:
    start, goal = at(30.0, 30.0), at(150.0, 170.0)  # 184 m apart, straight
    short = client.path(WALKER, start, goal, max_distance=100.0)
    assert not short.found and short.reason == "unreachable"
    assert client.path(WALKER, start, goal, max_distance=200.0).found


def test_an_unknown_mover_is_an_error(client: Client) -> None:
    # the client cannot know where a mover it has never seen is: it asks every instance, which know none
    with pytest.raises(ServiceError) as e:
        client.path(0x7777777, None, at(50.0, 50.0))
    assert e.value.kind == "unknown_mover"
    # told a landblock, it asks the path key there, and the service answers that no such mover exists
    client.locate(0x7777778, LB)
    with pytest.raises(ServiceError) as e:
        client.path(0x7777778, None, at(50.0, 50.0))
    assert e.value.kind == "unknown_mover"


def test_a_walker_and_start_that_make_no_query_are_refused_before_sending(client: Client) -> None:
    with pytest.raises(ValueError, match="needs a start"):
        client.path(WALKER, None, at(50.0, 50.0))
    with pytest.raises(ValueError, match="start where it stands|starts where it stands"):
        client.path(0x1234, at(30.0, 30.0), at(50.0, 50.0))
    with pytest.raises(ValueError, match="unsigned 64-bit"):
        client.path(0, None, at(50.0, 50.0))
    with pytest.raises(TypeError):
        client.path(True, None, at(50.0, 50.0))
    with pytest.raises(ValueError, match=r"paths\[1\]"):
        client.paths(WALKER, [(at(30.0, 30.0), at(50.0, 50.0)), (None, at(50.0, 50.0))])


def test_paths_answer_in_order_one_request_per_landblock_share_of_64(client: Client,
                                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    """70 paths from A9B4 and 3 from AAB4, interleaved: 2 requests for A9B4's share (64 + 6), 1 for AAB4's."""
    pairs: list[tuple[Position | None, Position]] = []
    expected: list[tuple[int, float, float]] = []  # each answer's goal: cell, x, y
    for k in range(73):
        # (every coordinate off the 24 m cell borders, whose cell either side may hold)
        if k % 25 == 3:  # 3 of them start and end in the landblock east
            start, goal = at(20.5 + k, 40.5, landblock=0xAAB4), at(40.5 + k, 60.5, landblock=0xAAB4)
        else:
            start, goal = at(10.5 + 2.0 * k, 20.5), at(10.5 + 2.0 * k, 30.5 + k)
        pairs.append((start, goal))
        expected.append((goal.cell_id, goal.frame.origin.x, goal.frame.origin.y))
    sent: list[tuple[int, int]] = []
    real = client._lb_request

    def spy(lb: int, op: str, content: dict[str, Any], *rest: Any, **kw: Any) -> dict[str, Any]:
        sent.append((lb, len(content["paths"])))
        return real(lb, op, content, *rest, **kw)

    monkeypatch.setattr(client, "_lb_request", spy)
    answers = client.paths(WALKER, pairs)
    assert sorted(sent) == sorted([(0xA9B4, MAX_PATHS_PER_REQUEST), (0xA9B4, 6), (0xAAB4, 3)])
    assert len(answers) == len(pairs)
    for (start, goal), r, (cell, x, y) in zip(pairs, answers, expected, strict=True):
        assert not isinstance(r, ServiceError), r
        assert r.found, (r.reason, r.detail)
        end = r.waypoints[-1]
        assert end.cell_id == cell and math.hypot(end.frame.origin.x - x, end.frame.origin.y - y) <= TOLERANCE
        assert start is not None
        straight = math.hypot(goal.frame.origin.x - start.frame.origin.x, goal.frame.origin.y - start.frame.origin.y)
        assert r.length == pytest.approx(straight, rel=0.02, abs=0.3)
    assert client.paths(WALKER, []) == []


def test_a_registered_walker_starts_where_it_stands_and_nothing_changes(flat: ServiceProcess) -> None:
    with Client([flat.endpoint], timeout=60.0) as c:
        ground = c.ground(at(60.0, 60.0, FLAT_Z + 1.0))
        assert ground is not None and ground.z == pytest.approx(FLAT_Z)
        st = c.register(human(contact=True), at(60.0, 60.0), contact_plane=ground.plane)  # standing there
        try:
            # a second client that never saw the mover finds where it is first
            with Client([flat.endpoint], timeout=60.0) as other:
                r = other.path(st.id, None, at(100.0, 90.0))
                (rs,) = other.paths(st.id, [(None, at(100.0, 90.0))])
            assert r.found and not isinstance(rs, ServiceError) and rs.found
            assert [where(p) for p in rs.waypoints] == [where(p) for p in r.waypoints]
            assert where(r.waypoints[0])[:3] == (at(60.0, 60.0).cell_id, 60.0, 60.0)
            assert r.length == pytest.approx(math.hypot(40.0, 30.0), rel=0.02)
            after, _ = c.get(st.id)
            assert after.seq == st.seq and where(after.position) == where(st.position)
        finally:
            c.remove(st.id)


def _walk_over_the_bus(c: Client, mover_id: int, waypoints: list[Position]) -> None:
    """Walk the waypoints with Client.move as docs/protocol.md's guarantee says; assert every arrival."""
    for leg, goal in enumerate(waypoints[1:], start=1):
        here = c.get(mover_id)[0].position
        for _ in range(math.ceil(here.get_offset(goal).length() / STRIDE) + 3):
            offset = here.get_offset(goal)
            d = offset.length()
            if d <= TOLERANCE:
                break
            step = offset if d <= STRIDE else offset * (STRIDE / d)
            here = c.move(mover_id, Position(here.cell_id, here.frame.with_origin(here.frame.origin + step))).position
        st = c.get(mover_id)[0]
        assert st.position.get_offset(goal).length() <= TOLERANCE, f"leg {leg}: at {st.position}, not {goal}"
        assert st.contact and st.on_walkable, f"leg {leg}: not standing"
        if goal.cell_id & 0xFFFF >= 0x100:
            assert st.position.cell_id == goal.cell_id, f"leg {leg}: in {st.position.cell_id:08X}"


def test_into_the_house_as_the_engine_here_answers_and_walked_over_the_bus(house: ServiceProcess) -> None:
    """The shared house's room (EnvCell 0100) is entered by its one door; the service's waypoints are the
    ones World.path gives on the same scene loaded here, and walking them with moves arrives."""
    outside, inside = at(100.0, 96.0), at(107.0, 109.5, cell=0x0100)
    local = engine.load_scene(SCENES / "house.json").path(WALKER, outside, inside)
    assert local.found and len(local.waypoints) > 2  # the wall is in the way: not one straight leg
    with Client([house.endpoint], timeout=60.0) as c:
        r = c.path(WALKER, outside, inside)
        assert r.found and r.waypoints[-1].cell_id == (LB << 16) | 0x0100
        assert [p.cell_id for p in r.waypoints] == [p.cell_id for p in local.waypoints]
        for got, want in zip(r.waypoints, local.waypoints, strict=True):
            assert where(got)[1:] == pytest.approx(where(want)[1:], abs=1e-9)
        assert r.length == pytest.approx(local.length, abs=1e-9)
        placed = c.place(human(contact=True), outside)
        assert placed.ok and placed.position is not None
        st = c.register(human(contact=True), placed.position, contact_plane=placed.contact_plane)
        try:
            by_id = c.path(st.id, None, inside)
            assert by_id.found
            _walk_over_the_bus(c, st.id, by_id.waypoints)
        finally:
            c.remove(st.id)


def test_a_pair_refused_alone_is_its_error_in_its_place(client: Client) -> None:
    """A goal in a cell the landblock has not (outdoor cells are 01..40 and A9B4 has no EnvCell 0123)."""
    good = (at(30.5, 30.5), at(40.5, 40.5))
    answers = client.paths(WALKER, [good, (at(30.5, 30.5), at(40.5, 40.5, cell=0x0123)), good])
    first, refused, last = answers
    assert isinstance(refused, ServiceError) and refused.kind == "unknown_cell"
    assert not isinstance(first, ServiceError) and first.found and first.length == pytest.approx(math.hypot(10, 10), rel=0.02)
    assert not isinstance(last, ServiceError) and [where(p) for p in last.waypoints] == [where(p) for p in first.waypoints]


def _distance_to_segment(px: float, py: float, a: Position, b: Position) -> float:
    ax, ay, bx, by = a.frame.origin.x, a.frame.origin.y, b.frame.origin.x, b.frame.origin.y
    dx, dy = bx - ax, by - ay
    t = max(0.0, min(1.0, ((px - ax) * dx + (py - ay) * dy) / (dx * dx + dy * dy)))
    return math.hypot(ax + t * dx - px, ay + t * dy - py)


def test_avoid_movers_goes_round_a_creature_in_the_way(client: Client) -> None:
    """A creature of one 1 m sphere stands on the straight line from (30, 30) to (50, 30): by default other
    movers are no obstacle (one 20 m leg through it); with avoid_movers no leg comes nearer its centre
    than the two radii, 1.0 + 0.48 m, and the way round is longer."""
    rock = engine.MoverSpec(spheres=[engine.SphereSpec((0.0, 0.0, 1.0), 1.0)], state=["Contact", "OnWalkable"],
                            creature=True)
    ground = client.ground(at(40.0, 30.0, FLAT_Z + 1.0))
    assert ground is not None
    st = client.register(rock, at(40.0, 30.0), contact_plane=ground.plane)
    try:
        start, goal = at(30.5, 30.0), at(50.5, 30.0)
        through = client.path(WALKER, start, goal)
        assert through.found and through.length == pytest.approx(20.0, abs=0.01) and len(through.waypoints) == 2
        around = client.path(WALKER, start, goal, avoid_movers=True)
        assert around.found and around.length > 20.0 + 0.1
        gaps = [_distance_to_segment(40.0, 30.0, a, b) for a, b in zip(around.waypoints, around.waypoints[1:])]
        assert min(gaps) >= 1.0 + 0.48 - 0.02, gaps
    finally:
        client.remove(st.id)


def test_a_path_answered_building_is_asked_again_until_it_is_answered() -> None:
    # the demo house from the north hills: a path the graph must find, on a service whose share of graph
    # building per query (--path-work) is small, so that the first ask cannot finish it
    hills = Position.at(0xA9B50038, Vec3(150.0, 180.0, 41.5))
    room = Position.at(0xA9B50100, Vec3(108.0, 108.0, 40.0))
    with ServiceProcess(extra=["--path-work", "500"]) as small, Client([small.endpoint], timeout=60.0) as c:
        c.wait_ready()
        first = c.path(WALKER, hills, room, keep_asking=False)
        assert (first.found, first.reason) == (False, "building")
        found = c.path(WALKER, hills, room)
        assert found.found and found.waypoints[-1].cell_id == 0xA9B50100
        [batch] = c.paths(WALKER, [(hills, room)])  # the graph is built now: answered at the first ask
        assert isinstance(batch, engine.PathResult) and [where(p) for p in batch.waypoints] == [where(p) for p in found.waypoints]


def test_follow_walks_a_registered_mover_along_its_path_and_random_point_finds_somewhere_near(flat: ServiceProcess) -> None:
    start, goal = at(60.0, 60.0), at(120.0, 100.0)
    with Client([flat.endpoint], timeout=30.0) as c:
        c.wait_ready()
        ground = c.ground(at(60.0, 60.0, FLAT_Z + 1.0))
        assert ground is not None
        me = c.register(human(contact=True), start, contact_plane=ground.plane).id  # standing there
        try:
            route = c.path(me, None, goal)
            assert route.found
            seq_before = c.get(me)[0].seq
            walked = c.follow(me, route.waypoints)
            assert walked.arrived(route.waypoints) and walked.reached == len(route.waypoints) - 1
            # open flat ground: the straight distance in strides of 3 m (the last 0.25 m need no move), and at
            # most one short move more a leg
            legs = len(route.waypoints) - 1
            assert math.ceil((route.length - 0.25 * legs) / 3.0) <= walked.moves <= math.ceil(route.length / 3.0) + legs
            assert walked.state.seq == seq_before + walked.moves  # every move the walk sent, counted
            assert walked.state.position.get_offset(goal).length() <= 0.25
            wander = c.random_point(me, None, 10.0, seed=3)
            assert wander.found and wander.end is not None
            d = walked.state.position.get_offset(wander.end)
            assert math.hypot(d.x, d.y) <= 10.0 + 0.25
            again = c.random_point(me, None, 10.0, seed=3)
            assert [where(p) for p in again.waypoints] == [where(p) for p in wander.waypoints]
            # a waypoint the walk cannot reach (48 m up in the air) stops it there: nothing reached
            here = walked.state.position
            up = Position(here.cell_id, here.frame.with_origin(here.frame.origin + Vec3(0.0, 0.0, 48.0)))
            stuck = c.follow(me, [here, up])
            assert stuck.reached == 0 and not stuck.arrived([here, up])
        finally:
            c.remove(me)
