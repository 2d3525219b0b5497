"""Paths on the bus (docs/protocol.md, "Paths"), written from the document alone: raw zenoh queries and
msgpack maps, no client library and no engine types. A path the service answers is walked over the bus
with moves exactly as the guarantee says, and the walker reaches every waypoint; the walker kinds, the
limits and the error paths are the ones the document lists; a goal on land this instance does not hold
is answered `not_loaded`; the batch and column forms answer each item as the single form does."""

from __future__ import annotations

import math
import struct
from typing import Any

import msgpack
import pytest
import zenoh

from support.service_harness import ServiceProcess, raw_query, raw_session

PLAYER = {"spheres": [{"center": [0, 0, 0.48], "radius": 0.48}, {"center": [0, 0, 1.35], "radius": 0.48}],
          "step_up_height": 0.6, "step_down_height": 0.4, "state": ["IsPlayer"]}
KEY = "acphys/lb/A9B4/path"
STRIDE, TOLERANCE = 3.0, 0.25  # the guarantee's numbers, as protocol.md states them


def outdoor_cell(lb: int, x: float, y: float) -> int:
    """An outdoor cell id from landblock-local metres (protocol.md, Position: 8 x 8 cells of 24 m)."""
    return (lb << 16) | (int(x // 24) * 8 + int(y // 24) + 1)


def ask(session: zenoh.Session, key: str, content: dict[str, Any]) -> tuple[bool, Any]:
    return raw_query(session, key, msgpack.packb({"v": 1, **content}), timeout=120.0)


def on_land(session: zenoh.Session, x: float, y: float) -> dict[str, Any]:
    """The Position standing on the demo land at A9B4 (x, y): its height from a ground query."""
    cell = outdoor_cell(0xA9B4, x, y)
    ok, reply = ask(session, "acphys/lb/A9B4/ground", {"ground": {"position": {"cell": cell, "origin": [x, y, 300.0]},
                                                                  "max_drop": 1000.0}})
    assert ok and reply["ground"] is not None
    return {"cell": cell, "origin": [x, y, reply["ground"]["z"]]}


def error_of(session: zenoh.Session, content: dict[str, Any], key: str = KEY) -> dict[str, Any]:
    ok, reply = ask(session, key, content)
    assert not ok, reply
    return reply["error"]  # type: ignore[no-any-return]


def distance(a: list[float], b: list[float]) -> float:
    return math.dist(a, b)


# -- a path found, and walked as the guarantee says ------------------------------------------------------
def test_an_open_field_path_is_about_the_straight_distance_and_walks_as_promised(session: zenoh.Session) -> None:
    start, goal = on_land(session, 40.0, 50.0), on_land(session, 100.0, 120.0)
    ok, reply = ask(session, KEY, {"path": {"mover": PLAYER, "from": start, "to": goal}})
    assert ok
    path = reply["path"]
    assert path["found"] and path["reason"] is None and path["detail"] == ""
    waypoints = path["waypoints"]
    straight = distance(start["origin"], goal["origin"])
    # open rolling land: the path is the straight line, give or take the hills' rise and fall
    assert straight - 0.5 <= path["length"] <= straight * 1.1
    assert path["length"] == pytest.approx(sum(distance(a["origin"], b["origin"]) for a, b in zip(waypoints, waypoints[1:])))
    assert distance(waypoints[0]["origin"][:2], start["origin"][:2]) <= TOLERANCE
    assert distance(waypoints[-1]["origin"][:2], goal["origin"][:2]) <= TOLERANCE

    # the guarantee, over the bus: a walker registered at the first waypoint, moved at most 3 m at a time
    # toward each waypoint in turn, reaches each within 0.25 m, on walkable ground, in its cell
    ok, reg = ask(session, "acphys/lb/A9B4/register", {"mover": {**PLAYER, "state": ["IsPlayer", "Contact", "OnWalkable"]},
                                                       "position": waypoints[0]})
    assert ok
    mover_id, at, landblock = reg["state"]["id"], waypoints[0], reg["state"]["landblock"]
    try:
        for wp in waypoints[1:]:
            leg = distance(at["origin"], wp["origin"])
            for _ in range(math.ceil(leg / STRIDE) + 3):
                here = at["origin"]
                gap = distance(here, wp["origin"])
                if gap <= TOLERANCE:
                    break
                f = min(1.0, STRIDE / gap)
                target = wp["origin"] if f == 1.0 else [h + (w - h) * f for h, w in zip(here, wp["origin"])]
                ok, moved = ask(session, f"acphys/lb/{landblock:04X}/move", {"move": {"id": mover_id, "to": {"origin": target}}})
                assert ok, moved
                state = moved["state"]
                landblock = state["landblock"]
                at = {"cell": state["position"]["cell"], "origin": state["position"]["origin"]}
            assert distance(at["origin"], wp["origin"]) <= TOLERANCE
            indoor = wp["cell"] & 0xFFFF >= 0x100  # protocol.md, Position: indoor cells are 0x100 and up
            assert state["on_walkable"] and (at["cell"] == wp["cell"] if indoor else at["cell"] & 0xFFFF < 0x100)
    finally:
        ask(session, "acphys/lb/A9B4/remove", {"id": mover_id})


def test_a_registered_walker_starts_where_it_stands_and_is_left_as_it_was(session: zenoh.Session) -> None:
    start, goal = on_land(session, 30.0, 30.0), on_land(session, 60.0, 40.0)
    ok, ground = ask(session, "acphys/lb/A9B4/ground", {"ground": {"position": start}})
    standing = {**PLAYER, "state": ["IsPlayer", "Contact", "OnWalkable"]}
    ok, reg = ask(session, "acphys/lb/A9B4/register", {"mover": standing, "position": start,
                                                       "contact_plane": ground["ground"]["plane"]})
    assert ok, reg
    mover_id = reg["state"]["id"]
    try:
        ok, before = ask(session, "acphys/lb/A9B4/get", {"id": mover_id})
        ok, reply = ask(session, KEY, {"path": {"id": mover_id, "to": goal}})
        assert ok and reply["path"]["found"], reply["path"]["detail"]
        assert distance(reply["path"]["waypoints"][0]["origin"][:2], start["origin"][:2]) <= TOLERANCE
        ok, after = ask(session, "acphys/lb/A9B4/get", {"id": mover_id})
        assert after == before  # read-only: the same State, seq and all
        # it stands in A9B4: asked on another landblock's key, the start is refused there
        err = error_of(session, {"path": {"id": mover_id, "to": goal}}, key="acphys/lb/AAB4/path")
        assert (err["kind"], err["path"], err["landblock"]) == ("wrong_landblock", "path.id", 0xA9B4)
    finally:
        ask(session, "acphys/lb/A9B4/remove", {"id": mover_id})


def test_a_goal_on_land_this_instance_does_not_hold_is_answered_not_loaded(session: zenoh.Session) -> None:
    start = on_land(session, 40.0, 50.0)
    far = {"cell": outdoor_cell(0x0101, 10.0, 10.0), "origin": [10.0, 10.0, 50.0]}
    ok, reply = ask(session, KEY, {"path": {"mover": PLAYER, "from": start, "to": far}})
    assert ok
    path = reply["path"]
    assert (path["found"], path["reason"], path["waypoints"]) == (False, "not_loaded", [])
    assert "0101" in path["detail"]


# -- the refusals protocol.md lists ----------------------------------------------------------------------
def test_the_walker_is_exactly_one_of_mover_and_id(session: zenoh.Session) -> None:
    start, goal = on_land(session, 40.0, 50.0), on_land(session, 50.0, 50.0)
    err = error_of(session, {"path": {"from": start, "to": goal}})
    assert (err["kind"], err["path"]) == ("missing_field", "path.mover")
    assert error_of(session, {"path": {"mover": PLAYER, "id": 7, "from": start, "to": goal}})["kind"] == "bad_value"
    err = error_of(session, {"path": {"mover": PLAYER, "to": goal}})
    assert (err["kind"], err["path"]) == ("missing_field", "path.from")
    err = error_of(session, {"path": {"id": 7, "from": start, "to": goal}})
    assert (err["kind"], err["path"]) == ("bad_value", "path.from")
    err = error_of(session, {"path": {"id": 123456789, "to": goal}})
    assert (err["kind"], err["path"]) == ("unknown_mover", "path.id")


@pytest.mark.parametrize(("field", "value", "kind"), [
    ("budget", 0, "bad_value"), ("budget", 100_001, "bad_value"), ("budget", 1.5, "wrong_type"),
    ("max_distance", 0.0, "bad_value"), ("max_distance", 50_000.0, "bad_value"), ("max_distance", math.nan, "non_finite"),
    ("avoid_movers", 1, "wrong_type"),
])
def test_options_outside_their_ranges_are_refused_naming_them(session: zenoh.Session, field: str, value: Any,
                                                                kind: str) -> None:
    start, goal = on_land(session, 40.0, 50.0), on_land(session, 50.0, 50.0)
    err = error_of(session, {"path": {"mover": PLAYER, "from": start, "to": goal, field: value}})
    assert (err["kind"], err["path"]) == (kind, f"path.{field}")


def test_a_start_elsewhere_a_wildcard_and_too_many_paths_are_refused(session: zenoh.Session) -> None:
    start, goal = on_land(session, 40.0, 50.0), on_land(session, 50.0, 50.0)
    elsewhere = {"cell": outdoor_cell(0xAAB4, 40.0, 50.0), "origin": [40.0, 50.0, 60.0]}
    err = error_of(session, {"path": {"mover": PLAYER, "from": elsewhere, "to": goal}})
    assert (err["kind"], err["path"], err["landblock"]) == ("wrong_landblock", "path.from", 0xAAB4)
    assert error_of(session, {"path": {"mover": PLAYER, "from": start, "to": goal}}, key="acphys/lb/*/path")["kind"] == "bad_value"
    item = {"mover": PLAYER, "from": start, "to": goal}
    err = error_of(session, {"paths": [item] * 65})
    assert (err["kind"], err["path"]) == ("too_large", "paths")
    nan = {"cell": goal["cell"], "origin": [math.nan, 50.0, 40.0]}
    err = error_of(session, {"paths": [item, {**item, "to": nan}]})
    assert (err["kind"], err["path"]) == ("non_finite", "paths[1].to.origin[0]")


# -- batch and column forms ----------------------------------------------------------------------------
def test_a_batch_answers_each_item_as_the_single_form_and_an_engine_refusal_alone(session: zenoh.Session) -> None:
    start, near, far = on_land(session, 40.0, 50.0), on_land(session, 70.0, 60.0), on_land(session, 20.0, 150.0)
    bad_cell = {"cell": 0xA9B4FFF0, "origin": [40.0, 50.0, 40.0]}
    items = [{"mover": PLAYER, "from": start, "to": near}, {"mover": PLAYER, "from": start, "to": bad_cell},
             {"mover": PLAYER, "from": start, "to": far}]
    ok, reply = ask(session, KEY, {"paths": items})
    assert ok
    answers = reply["paths"]
    assert answers[1]["error"]["kind"] == "unknown_cell"
    for i in (0, 2):
        ok, single = ask(session, KEY, {"path": items[i]})
        assert answers[i] == single["path"]


def _pack(fmt: str, *values: Any) -> bytes:
    return struct.pack("<" + fmt, *values)


def test_the_column_form_answers_as_the_map_form_with_ragged_waypoints(session: zenoh.Session) -> None:
    start, near, far = on_land(session, 40.0, 50.0), on_land(session, 70.0, 60.0), on_land(session, 20.0, 150.0)
    away = {"cell": outdoor_cell(0x0101, 10.0, 10.0), "origin": [10.0, 10.0, 50.0]}
    goals = [near, away, far]
    columns = {
        "from_cell": _pack("3I", *[start["cell"]] * 3), "from_origin": _pack("9d", *start["origin"] * 3),
        "to_cell": _pack("3I", *(g["cell"] for g in goals)),
        "to_origin": _pack("9d", *(v for g in goals for v in g["origin"])),
    }
    ok, reply = ask(session, KEY, {"mover": PLAYER, "columns": columns})
    assert ok, reply
    assert reply["n"] == 3 and reply["errors"] == []
    c = reply["columns"]
    flags = struct.unpack("<3I", c["flags"])
    reason = list(c["reason"])
    length = struct.unpack("<3d", c["length"])
    first = struct.unpack("<3I", c["waypoint_start"])
    count = struct.unpack("<3I", c["waypoint_count"])
    w = sum(count)
    cells = struct.unpack(f"<{w}I", c["waypoint_cell"])
    origins = struct.unpack(f"<{3 * w}d", c["waypoint_origin"])
    for i, goal in enumerate(goals):
        ok, single = ask(session, KEY, {"path": {"mover": PLAYER, "from": start, "to": goal}})
        path = single["path"]
        assert bool(flags[i] & 1)  # resolved
        assert bool(flags[i] & 2) == path["found"]
        assert reason[i] == (255 if path["found"] else ["unreachable", "budget", "not_loaded", "start_invalid",
                                                         "goal_invalid"].index(path["reason"]))
        assert length[i] == path["length"]
        assert count[i] == len(path["waypoints"])
        rows = range(first[i], first[i] + count[i])
        assert [cells[r] for r in rows] == [p["cell"] for p in path["waypoints"]]
        assert [list(origins[3 * r:3 * r + 3]) for r in rows] == [p["origin"] for p in path["waypoints"]]
    assert reason[1] == 2 and count[1] == 0  # not_loaded


def test_health_lists_the_path_query_and_stats_count_it(session: zenoh.Session) -> None:
    ok, health = ask(session, "acphys/health", {})
    assert "path" in health["queries"]
    ok, stats = ask(session, "acphys/stats", {})
    assert stats["requests"]["path"] > 0


# -- a share of graph building per query (protocol.md, "Cost, and `building`") ---------------------------------
#: from the north hills into the demo house's room (EnvCell A9B50100): round the house and in at its door,
#: a path only the graph finds
HILLS = {"cell": 0xA9B50038, "origin": [150.0, 180.0, 41.5]}
ROOM = {"cell": 0xA9B50100, "origin": [108.0, 108.0, 40.0]}


def test_a_query_past_its_share_of_building_is_answered_building_and_asked_again_finishes(session: zenoh.Session) -> None:
    with ServiceProcess(extra=["--path-work", "500"]) as small:
        s = raw_session(small.endpoint)
        try:
            answers = []
            for _ in range(200):  # bounded: each ask builds 500 placements and walks more, and keeps them
                ok, reply = raw_query(s, "acphys/lb/A9B5/path", msgpack.packb(
                    {"v": 1, "path": {"mover": PLAYER, "from": HILLS, "to": ROOM}}), timeout=120.0)
                assert ok
                answers.append(reply["path"])
                if answers[-1]["reason"] != "building":
                    break
        finally:
            s.close()
    first, last = answers[0], answers[-1]
    assert (first["found"], first["reason"], first["waypoints"]) == (False, "building", [])
    assert "ask again" in first["detail"]
    assert len(answers) > 2
    # the service with the default share (the module's) builds the same graph in fewer asks: same answer
    ok, reply = ask(session, "acphys/lb/A9B5/path", {"path": {"mover": PLAYER, "from": HILLS, "to": ROOM}})
    for _ in range(50):
        if reply["path"]["reason"] != "building":
            break
        ok, reply = ask(session, "acphys/lb/A9B5/path", {"path": {"mover": PLAYER, "from": HILLS, "to": ROOM}})
    assert last["found"] and last == reply["path"]
    assert last["waypoints"][-1]["cell"] == ROOM["cell"]


# -- random points (protocol.md, "Random points") ------------------------------------------------------------
def test_a_random_point_is_within_its_radius_repeatable_by_seed_and_a_path_there(session: zenoh.Session) -> None:
    near = on_land(session, 60.0, 60.0)
    query = {"mover": PLAYER, "near": near, "radius": 15.0, "seed": 11}
    ok, reply = ask(session, "acphys/lb/A9B4/random_point", {"random_point": query})
    assert ok
    point = reply["random_point"]
    assert point["found"] and point["reason"] is None
    end = point["waypoints"][-1]["origin"]
    assert distance(end[:2], near["origin"][:2]) <= 15.0 + TOLERANCE
    assert distance(point["waypoints"][0]["origin"][:2], near["origin"][:2]) <= TOLERANCE
    # the same seed, the same point; the answer is a path, as a path query to that point would walk
    ok, again = ask(session, "acphys/lb/A9B4/random_point", {"random_point": query})
    assert again["random_point"] == point
    ok, batch = ask(session, "acphys/lb/A9B4/random_point", {"random_points": [query, {**query, "seed": 12}]})
    assert batch["random_points"][0] == point


def test_random_point_refusals_name_their_fields(session: zenoh.Session) -> None:
    near = on_land(session, 60.0, 60.0)
    key = "acphys/lb/A9B4/random_point"
    for radius, kind in ((0.0, "bad_value"), (1000.5, "bad_value"), (-3.0, "bad_value"), ("far", "wrong_type")):
        err = error_of(session, {"random_point": {"mover": PLAYER, "near": near, "radius": radius}}, key=key)
        assert (err["kind"], err["path"]) == (kind, "random_point.radius")
    err = error_of(session, {"random_point": {"mover": PLAYER, "radius": 5.0}}, key=key)
    assert (err["kind"], err["path"]) == ("missing_field", "random_point.near")
    err = error_of(session, {"random_point": {"mover": PLAYER, "near": near}}, key=key)
    assert (err["kind"], err["path"]) == ("missing_field", "random_point.radius")
    err = error_of(session, {"random_point": {"mover": PLAYER, "near": near, "radius": 5.0, "seed": -1}}, key=key)
    assert (err["kind"], err["path"]) == ("bad_value", "random_point.seed")


def test_random_point_columns_answer_as_the_map_form(session: zenoh.Session) -> None:
    near = on_land(session, 60.0, 60.0)
    columns = {"near_cell": _pack("2I", near["cell"], near["cell"]), "near_origin": _pack("6d", *near["origin"] * 2),
               "radius": _pack("2d", 15.0, 2000.0), "seed": _pack("2Q", 11, 11)}
    ok, reply = ask(session, "acphys/lb/A9B4/random_point", {"mover": PLAYER, "columns": columns})
    assert ok, reply
    assert [(e["index"], e["error"]["kind"], e["error"]["path"]) for e in reply["errors"]] == \
        [(1, "bad_value", "columns.radius[1]")]
    c = reply["columns"]
    count = struct.unpack("<2I", c["waypoint_count"])
    ok, single = ask(session, "acphys/lb/A9B4/random_point",
                     {"random_point": {"mover": PLAYER, "near": near, "radius": 15.0, "seed": 11}})
    waypoints = single["random_point"]["waypoints"]
    assert count == (len(waypoints), 0)
    origins = struct.unpack(f"<{3 * count[0]}d", c["waypoint_origin"])
    assert [list(origins[3 * r:3 * r + 3]) for r in range(count[0])] == [p["origin"] for p in waypoints]
