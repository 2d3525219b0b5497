"""Limits at the door, over the bus: every hostile input gets a named error, never `internal`.

A neighbour walks while a hostile client sends, between its moves, every
hostile input: numbers beyond single precision, targets far outside
the landblock, a giant sphere, origins outside the landblock, a velocity of
1e30, a dt the client would not resolve. Each is answered `bad_value` (or
`non_finite`) naming its field; the hostile client's own mover keeps its
state and seq; and the neighbour's States are bit-identical to the engine's
answers for the same walk with no hostile client at all.
"""

from __future__ import annotations

from typing import Any

import msgpack
import pytest
import zenoh

from clients.demo.world import global_to_cell
from engine import World
from engine.constants import HUGE_QUANTUM
from engine.geometry import Plane, Position, Vec3
from service.protocol.codec import encode_mover_spec
from support.service_harness import comparable, demo_world, human, raw_query, start_on_ground

P = "acphys"
NEIGHBOUR, VICTIM = 0x51001, 0x51002
N_CELL, N_X, N_Y = global_to_cell(60.0, 60.0)
V_CELL, V_X, V_Y = global_to_cell(63.0, 61.0)
SPEC = encode_mover_spec(human(contact=True))


def pk(obj: Any) -> bytes:
    return msgpack.packb(obj, use_bin_type=True)


def sphere(radius: float, **extra: Any) -> dict[str, Any]:
    return {"spheres": [{"center": [0.0, 0.0, 1.0], "radius": radius}], **extra}


def start(world: World, cell: int, x: float, y: float) -> dict[str, Any]:
    p = start_on_ground(world, cell, x, y)
    o = p.frame.origin
    return {"cell": cell, "origin": [o.x, o.y, o.z]}


def move(body: dict[str, Any]) -> bytes:
    return pk({"v": 1, "move": {"id": VICTIM, **body}})


def register(mover: dict[str, Any], origin: list[float] | None = None) -> bytes:
    return pk({"v": 1, "mover": mover, "position": {"cell": V_CELL, "origin": origin or [V_X + 1.0, V_Y + 2.0, 80.0]}})


# (name, op, payload, kind, path)
HOSTILE: list[tuple[str, str, bytes, str, str]] = [
    ("offset 1e200", "move", move({"offset": [1e200, 0.0, 0.0]}), "bad_value", "move.offset[0]"),
    ("target 1e300", "move", move({"to": {"origin": [0.0, 1e300, 0.0]}}), "bad_value", "move.to.origin[1]"),
    ("offset 1e30 (a float32, far off)", "move", move({"offset": [0.0, 1e30, 0.0]}), "bad_value", "move.offset[1]"),
    ("target three landblocks east", "move", move({"to": {"origin": [600.0, V_Y, 60.0]}}), "bad_value", "move.to.origin[0]"),
    ("target 20 km up", "move", move({"to": {"origin": [V_X, V_Y, 2e4]}}), "bad_value", "move.to.origin[2]"),
    ("integer beyond any float", "move", move({"offset": [2 ** 63, 0, 0]}), "bad_value",
     "move.offset[0]"),
    ("velocity 1e30", "move", move({"offset": [0.3, 0.0, 0.0], "velocity": [1e30, 0.0, 0.0]}), "bad_value",
     "move.velocity"),
    ("velocity beyond float32", "move", move({"offset": [0.3, 0.0, 0.0], "velocity": [0.0, 1e39, 0.0]}), "bad_value",
     "move.velocity[1]"),
    ("motion 1e30", "move", move({"motion": [1e30, 0.0, 0.0], "dt": 0.1}), "bad_value", "move.motion[0]"),
    ("dt over HUGE_QUANTUM", "move", move({"motion": [0.0, 0.0, 0.0], "dt": HUGE_QUANTUM * 1.5}), "bad_value", "move.dt"),
    ("dt 60", "move", move({"motion": [0.0, 0.0, 0.0], "dt": 60.0}), "bad_value", "move.dt"),
    ("giant sphere 1e39", "register", register(sphere(1e39)), "bad_value", "mover.spheres[0].radius"),
    ("giant sphere 1e30", "register", register(sphere(1e30)), "bad_value", "mover.spheres[0].radius"),
    ("sphere of a kilometre", "register", register(sphere(1000.0)), "bad_value", "mover.spheres[0].radius"),
    ("sphere of a tenth of a millimetre", "register", register(sphere(1e-4)), "bad_value", "mover.spheres[0].radius"),
    ("scale 1e30", "register", register(sphere(0.5, scale=1e30)), "bad_value", "mover.scale"),
    ("step height 1e30", "register", register(sphere(0.5, step_up_height=1e30)), "bad_value", "mover.step_up_height"),
    ("origin at 1e30", "register", register(sphere(0.5), [1e30, 10.0, 60.0]), "bad_value", "position.origin[0]"),
    ("origin outside the landblock", "register", register(sphere(0.5), [250.0, 10.0, 60.0]), "bad_value",
     "position.origin[0]"),
    ("origin 1e30 underground", "register", register(sphere(0.5), [10.0, 10.0, -1e30]), "bad_value",
     "position.origin[2]"),
    ("update to a giant", "update", pk({"v": 1, "id": VICTIM, "mover": sphere(1e30)}), "bad_value",
     "mover.spheres[0].radius"),
]
#: the neighbour's walk: one move between two hostile requests
WALK = [(0.4, 0.0, 0.0), (0.0, 0.4, 0.0), (-0.3, -0.3, 0.0), (0.2, 0.1, 0.0)] * 5


def _get(session: zenoh.Session, mover_id: int) -> dict[str, Any]:
    ok, reply = raw_query(session, f"{P}/lb/A9B4/get", pk({"v": 1, "id": mover_id}))
    assert ok, reply
    return dict(reply["state"])


def test_hostile_inputs_are_refused_by_name_and_the_neighbour_never_notices(session: zenoh.Session) -> None:
    world = demo_world()
    n_start, v_start = start(world, N_CELL, N_X, N_Y), start(world, V_CELL, V_X, V_Y)
    for mid, pos in ((NEIGHBOUR, n_start), (VICTIM, v_start)):
        ok, reply = raw_query(session, f"{P}/lb/A9B4/register", pk({"v": 1, "id": mid, "mover": SPEC, "position": pos}))
        assert ok, reply
    # the run without any hostile client: the engine itself, the same two movers and the same walk
    n_eid = world.add_mover(human(contact=True), Position.at(n_start["cell"], Vec3(*n_start["origin"])))
    world.add_mover(human(contact=True), Position.at(v_start["cell"], Vec3(*v_start["origin"])))
    for i, off in enumerate(WALK):
        name, op, payload, kind, path = HOSTILE[i % len(HOSTILE)]
        victim_before = _get(session, VICTIM)
        ok, reply = raw_query(session, f"{P}/lb/A9B4/{op}", payload)
        assert not ok, (name, reply)
        err = reply["error"]
        assert (err["kind"], err.get("path")) == (kind, path), (name, err)
        assert _get(session, VICTIM) == victim_before, name  # state and seq as they were
        ok, reply = raw_query(session, f"{P}/lb/A9B4/move", pk({"v": 1, "move": {"id": NEIGHBOUR, "offset": list(off)}}))
        assert ok, reply
        expected = world.move(n_eid, world.mover(n_eid).position.moved(Vec3(*off)))
        assert comparable(reply["state"]) == comparable(expected), (name, i)


@pytest.mark.parametrize("name,op,payload,kind,path", HOSTILE, ids=[h[0] for h in HOSTILE])
def test_each_hostile_input_alone(session: zenoh.Session, name: str, op: str, payload: bytes, kind: str, path: str) -> None:
    world = demo_world()
    ok, reply = raw_query(session, f"{P}/lb/A9B4/register",
                          pk({"v": 1, "id": VICTIM + 1, "mover": SPEC, "position": start(world, V_CELL, V_X, V_Y)}))
    assert ok, reply
    try:
        if op != "register":  # aim it at this mover
            payload = payload.replace(msgpack.packb(VICTIM), msgpack.packb(VICTIM + 1))
        before = _get(session, VICTIM + 1)
        ok, reply = raw_query(session, f"{P}/lb/A9B4/{op}", payload)
        assert not ok and reply["error"]["kind"] == kind and reply["error"].get("path") == path, reply
        assert _get(session, VICTIM + 1) == before
    finally:
        raw_query(session, f"{P}/lb/A9B4/remove", pk({"v": 1, "id": VICTIM + 1}))


def test_a_hostile_item_in_a_batch_fails_alone(session: zenoh.Session) -> None:
    world = demo_world()
    mid = 0x51010
    ok, reply = raw_query(session, f"{P}/lb/A9B4/register",
                          pk({"v": 1, "id": mid, "mover": SPEC, "position": start(world, V_CELL, V_X + 5.0, V_Y)}))
    assert ok, reply
    batch = [{"id": mid, "offset": [0.3, 0.0, 0.0]}, {"id": mid, "offset": [1e5, 0.0, 0.0]},
             {"id": mid, "to": {"origin": [0.0, 0.0, 1e38]}}, {"id": mid, "offset": [0.3, 0.0, 0.0]}]
    ok, reply = raw_query(session, f"{P}/lb/A9B4/move", pk({"v": 1, "moves": batch}))
    assert ok, reply
    r = reply["results"]
    assert [x.get("error", {}).get("path") for x in r] == [None, "moves[1].offset[0]", "moves[2].to.origin[2]", None]
    assert r[1]["error"]["kind"] == r[2]["error"]["kind"] == "bad_value"
    assert r[0]["seq"] == 1 and r[3]["seq"] == 2  # the refused items did not count
    raw_query(session, f"{P}/lb/A9B4/remove", pk({"v": 1, "id": mid}))


def test_a_velocity_sent_with_a_move_is_gone_by_the_next_physics_step(session: zenoh.Session) -> None:
    world = demo_world()
    mid = 0x51020
    x, y = V_X + 9.0, V_Y + 3.0
    z = world.terrain_height(V_CELL, x, y)  # standing on the ground, in contact with it
    n = world.landblocks[V_CELL >> 16].terrain.normal_at(x, y)
    plane = Plane(n, -n.dot(Vec3(x, y, z)))
    ok, reply = raw_query(session, f"{P}/lb/A9B4/register", pk({
        "v": 1, "id": mid, "mover": SPEC, "position": {"cell": V_CELL, "origin": [x, y, z]},
        "contact_plane": {"normal": [n.x, n.y, n.z], "d": plane.d}}))
    assert ok, reply
    eid = world.add_mover(human(contact=True), Position.at(V_CELL, Vec3(x, y, z)), plane, V_CELL)
    pushed = {"offset": [0.3, 0.0, 0.0], "velocity": [0.0, 30.0, 40.0]}
    step = {"motion": [0.0, 0.1, 0.0], "dt": 1.0 / 30.0}
    got = []
    for body in (pushed, step):
        ok, reply = raw_query(session, f"{P}/lb/A9B4/move", pk({"v": 1, "move": {"id": mid, **body}}))
        assert ok, reply
        got.append(reply["state"])
    m = world.mover(eid)
    world.move(eid, m.position.moved(Vec3(0.3, 0.0, 0.0)), Vec3(0.0, 30.0, 40.0))
    expected = world.step(eid, Vec3(0.0, 0.1, 0.0), 1.0 / 30.0)
    assert comparable(got[1]) == comparable(expected)
    # the pushed move lifted it off its slope; from rest, airborne, the client's physics step moves it
    # nowhere in its first frame (no velocity yet: UpdatePhysicsInternal adds nothing). A leftover
    # 30 m/s north and 40 m/s up would have carried it 1 m north and 1.3 m up.
    assert got[1]["position"]["origin"] == got[0]["position"]["origin"]
    raw_query(session, f"{P}/lb/A9B4/remove", pk({"v": 1, "id": mid}))
