"""A client written from docs/protocol.md alone: raw Zenoh, hand-built msgpack.

Nothing from `clients/` or the service's codec is used here, on purpose:
if this test needs to know something the document does not say, the
document is incomplete.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Iterator
from typing import Any

import msgpack
import pytest
import zenoh

from support.service_harness import ServiceProcess, raw_session, wait_until

P = "acphys"
LB = 0xA9B4
CELL = (LB << 16) | (1 * 8 + 1 + 1)  # outdoor cell cx=1, cy=1: x 24..48, y 24..48
HUMAN = {
    "spheres": [{"center": [0.0, 0.0, 0.48], "radius": 0.48}, {"center": [0.0, 0.0, 1.35], "radius": 0.48}],
    "step_up_height": 0.6,
    "step_down_height": 0.4,
    "state": ["IsPlayer"],
}
STATE_FIELDS = {
    "id", "seq", "ok", "position", "landblock", "transition_state", "contact", "on_walkable", "contact_plane",
    "contact_plane_cell", "collision_normal", "sliding_normal", "water_contact", "frames_stationary_fall",
    "transient_state", "collide_objects",
}


@pytest.fixture(scope="module")
def session() -> Iterator[zenoh.Session]:
    with ServiceProcess() as svc:
        s = raw_session(svc.endpoint)
        # wait for the service's keys to be visible to this session
        assert wait_until(lambda: bool(list(s.get(f"{P}/health", timeout=1.0))), timeout=10.0)
        yield s
        s.close()


def ask(s: zenoh.Session, key: str, body: dict[str, Any] | None) -> tuple[bool, dict[str, Any]]:
    kwargs: dict[str, Any] = {"timeout": 5.0}
    if body is not None:
        kwargs["payload"] = msgpack.packb(body)
    (reply,) = list(s.get(key, **kwargs))
    if reply.ok is not None:
        return True, msgpack.unpackb(reply.ok.payload.to_bytes())
    return False, msgpack.unpackb(reply.err.payload.to_bytes())


def test_register_move_batch_get_remove(session: zenoh.Session) -> None:
    ok, reg = ask(session, f"{P}/lb/A9B4/register",
                  {"v": 1, "id": 0x50000042, "mover": HUMAN, "position": {"cell": CELL, "origin": [30.0, 30.0, 70.0]}})
    assert ok, reg
    st = reg["state"]
    assert reg["v"] == 1 and STATE_FIELDS <= set(st)
    assert st["id"] == 0x50000042 and st["seq"] == 0 and st["landblock"] == LB
    assert st["transition_state"] == "NoTransition"
    assert st["position"] == {"cell": CELL, "origin": [30.0, 30.0, 70.0], "orientation": [1.0, 0.0, 0.0, 0.0]}

    # fall onto the ground with physics steps
    for _ in range(40):
        ok, rep = ask(session, f"{P}/lb/A9B4/move", {"v": 1, "move": {"id": 0x50000042, "motion": [0, 0, 0], "dt": 0.2}})
        assert ok, rep
        if rep["state"]["on_walkable"]:
            break
    st = rep["state"]
    assert st["contact"] and st["on_walkable"]
    n = st["contact_plane"]["normal"]
    assert math.isclose(math.sqrt(sum(c * c for c in n)), 1.0, abs_tol=1e-4) and n[2] > 0.664
    assert st["contact_plane_cell"] == CELL

    # a batch with a tag, a good move, and a move for an unknown mover
    ok, rep = ask(session, f"{P}/lb/A9B4/move", {"v": 1, "moves": [
        {"id": 0x50000042, "offset": [0.5, 0.0, 0.0], "tag": "first"},
        {"id": 0x50000042, "to": {"origin": [31.0, 30.0, st["position"]["origin"][2]]}},
        {"id": 3, "offset": [0, 0, 0]},
    ]})
    assert ok, rep
    first, second, third = rep["results"]
    assert first["tag"] == "first" and first["seq"] == st["seq"] + 1
    assert second["seq"] == st["seq"] + 2 and "tag" not in second
    assert second["position"]["cell"] == CELL  # `to` without a cell keeps the current one
    assert third == {"id": 3, "error": third["error"]} and third["error"]["kind"] == "unknown_mover"

    ok, got = ask(session, f"{P}/lb/A9B4/get", {"v": 1, "id": 0x50000042})
    assert ok and got["state"]["seq"] == second["seq"] and got["mover"]["state"] == ["IsPlayer"]

    # find it from a wildcard key, as the document says
    replies = list(session.get(f"{P}/lb/*/get", payload=msgpack.packb({"v": 1, "id": 0x50000042}),
                               target=zenoh.QueryTarget.ALL, consolidation=zenoh.ConsolidationMode.NONE, timeout=5.0))
    found = [msgpack.unpackb(r.ok.payload.to_bytes()) for r in replies if r.ok is not None]
    assert [f["state"]["landblock"] for f in found] == [LB]

    ok, rem = ask(session, f"{P}/lb/A9B4/remove", {"v": 1, "id": 0x50000042})
    assert ok and rem == {"v": 1, "id": 0x50000042, "removed": True}
    ok, err = ask(session, f"{P}/lb/A9B4/remove", {"v": 1, "id": 0x50000042})
    assert not ok and err["v"] == 1 and err["error"]["kind"] == "unknown_mover" and err["error"]["path"] == "id"


def test_fire_and_forget_states_in_order(session: zenoh.Session) -> None:
    ok, reg = ask(session, f"{P}/lb/A9B4/register",
                  {"v": 1, "mover": HUMAN, "position": {"cell": CELL, "origin": [40.0, 40.0, 70.0]}})
    assert ok
    mover = reg["state"]["id"]
    assert mover >= 1 << 32  # assigned ids sit above 2^32
    states: list[dict[str, Any]] = []
    lock = threading.Lock()

    def on_state(sample: zenoh.Sample) -> None:
        with lock:
            states.append(msgpack.unpackb(sample.payload.to_bytes()))

    sub = session.declare_subscriber(f"{P}/obj/{mover:X}/state", on_state)
    try:
        # zero moves until the subscription is seen to be live
        for _ in range(50):
            ok, rep = ask(session, f"{P}/lb/A9B4/move", {"v": 1, "move": {"id": mover, "offset": [0, 0, 0]}})
            if wait_until(lambda seq=rep["state"]["seq"]: any(m["state"]["seq"] == seq for m in states), timeout=0.2):
                break
        base = rep["state"]["seq"]
        states.clear()
        for k in range(50):
            session.put(f"{P}/lb/A9B4/push", msgpack.packb({"v": 1, "move": {"id": mover, "motion": [0.2, 0, 0],
                                                                              "dt": 0.1, "tag": k}}))
        session.put(f"{P}/lb/A9B4/push", msgpack.packb({"v": 1, "moves": [
            {"id": mover, "offset": [0.1, 0, 0], "tag": 50}, {"id": mover, "offset": [0.1, 0, 0], "tag": 51}]}))
        assert wait_until(lambda: len(states) >= 52, timeout=10.0)
    finally:
        sub.undeclare()
    assert all(m["v"] == 1 and STATE_FIELDS <= set(m["state"]) for m in states)
    assert [m["state"]["seq"] for m in states] == list(range(base + 1, base + 53))
    assert [m["state"]["tag"] for m in states] == list(range(52))


def test_batch_publication(session: zenoh.Session) -> None:
    """`"publish": "batch"`: one message on P/states per request, the resolved States in order, none on the
    mover's own key; `"each"` (the default) publishes per mover as before; an unknown value fails the request."""
    ok, reg = ask(session, f"{P}/lb/A9B4/register",
                  {"v": 1, "mover": HUMAN, "position": {"cell": CELL, "origin": [36.0, 40.0, 70.0]}})
    assert ok
    mover = reg["state"]["id"]
    batches: list[dict[str, Any]] = []
    singles: list[dict[str, Any]] = []
    lock = threading.Lock()

    def on(dest: list[dict[str, Any]]) -> Any:
        def cb(sample: zenoh.Sample) -> None:
            with lock:
                dest.append(msgpack.unpackb(sample.payload.to_bytes()))
        return cb

    subs = [session.declare_subscriber(f"{P}/states", on(batches)),
            session.declare_subscriber(f"{P}/obj/{mover:X}/state", on(singles))]
    try:
        # until both subscriptions are seen to be live (a zero move published each way)
        for _ in range(50):
            ask(session, f"{P}/lb/A9B4/move", {"v": 1, "move": {"id": mover, "offset": [0, 0, 0]}})
            ask(session, f"{P}/lb/A9B4/move", {"v": 1, "move": {"id": mover, "offset": [0, 0, 0]}, "publish": "batch"})
            if wait_until(lambda: bool(batches) and bool(singles), timeout=0.2):
                break
        time.sleep(0.3)
        with lock:
            batches.clear()
            singles.clear()
        moves = [{"id": mover, "offset": [0.1, 0, 0], "tag": 0}, {"id": mover, "offset": [math.nan, 0, 0], "tag": 1},
                 {"id": mover, "offset": [0.1, 0, 0], "tag": 2}]
        ok, rep = ask(session, f"{P}/lb/A9B4/move", {"v": 1, "moves": moves, "publish": "batch"})
        assert ok and rep["results"][1]["error"]["kind"] == "non_finite"
        session.put(f"{P}/lb/A9B4/push", msgpack.packb({"v": 1, "moves": moves[:1], "publish": "batch"}))
        assert wait_until(lambda: len(batches) >= 2, timeout=5.0)
        ok, one = ask(session, f"{P}/lb/A9B4/move", {"v": 1, "move": moves[2], "publish": "each"})
        assert ok and wait_until(lambda: len(singles) >= 1, timeout=5.0)
        time.sleep(0.3)  # anything else published would have arrived by now
        ok, bad = ask(session, f"{P}/lb/A9B4/move", {"v": 1, "moves": moves, "publish": "all"})
        assert not ok and bad["error"]["kind"] == "bad_value" and bad["error"]["path"] == "publish"
    finally:
        for sub in subs:
            sub.undeclare()
    first, second = batches[:2]
    assert first["v"] == 1 and set(first) == {"v", "states"}
    assert first["states"] == [rep["results"][0], rep["results"][2]]  # the resolved moves, in order
    assert [st["tag"] for st in second["states"]] == [0] and second["states"][0]["seq"] == rep["results"][2]["seq"] + 1
    assert len(batches) == 2
    assert singles == [{"v": 1, "state": one["state"]}]  # only the request sent with "each"
    (health,) = [msgpack.unpackb(r.ok.payload.to_bytes()) for r in session.get(f"{P}/health", timeout=5.0)]
    assert health["publish"] == ["each", "batch"]


def test_per_instance_keys(session: zenoh.Session) -> None:
    def all_replies(key: str) -> list[dict[str, Any]]:
        rs = session.get(key, target=zenoh.QueryTarget.ALL, consolidation=zenoh.ConsolidationMode.NONE, timeout=5.0)
        return [msgpack.unpackb(r.ok.payload.to_bytes()) for r in rs if r.ok is not None]

    (health,) = all_replies(f"{P}/health")  # empty payload is allowed here
    assert health["status"] == "ok" and health["protocol"] == 1 and health["queue_capacity"] >= 1
    (lbs,) = all_replies(f"{P}/landblocks")
    assert lbs["owned"] == "*" and LB in lbs["loaded"] and lbs["instance"] == health["instance"]
    (stats,) = all_replies(f"{P}/stats")
    for key in ("requests", "moves", "errors", "latency_ms", "engine_ms", "loaded_landblocks", "cache", "handovers"):
        assert key in stats
    assert {"count", "window", "p50", "p90", "p99", "max", "mean"} <= set(stats["latency_ms"])
    ok, loaded = ask(session, f"{P}/lb/A9B4/load", None)
    assert ok and loaded == {"v": 1, "landblock": LB, "loaded": True, "already": True}


def test_spatial_queries_from_the_doc(session: zenoh.Session) -> None:
    """Ground and sight as docs/protocol.md, "Spatial queries", describes them."""
    high = {"cell": CELL, "origin": [30.0, 30.0, 500.0]}  # far above any land of the demo scene
    ok, rep = ask(session, f"{P}/lb/A9B4/ground", {"v": 1, "ground": {"position": high, "max_drop": 1000.0}})
    assert ok, rep
    g = rep["ground"]
    assert set(g) == {"z", "plane", "cell", "walkable", "water_depth"}
    n, d = g["plane"]["normal"], g["plane"]["d"]
    assert math.isclose(math.hypot(*n), 1.0, abs_tol=1e-4)
    assert abs(n[0] * 30.0 + n[1] * 30.0 + n[2] * g["z"] + d) < 1e-3  # the surface point under (30, 30) is on the plane
    z = g["z"]
    # eye to eye 2 m above that ground, 1 m apart along x in the same cell: clear; to 5 m under the ground: blocked
    eye = {"cell": CELL, "origin": [30.0, 30.0, z + 2.0]}
    near = {"cell": CELL, "origin": [31.0, 30.0, z + 2.0 + n[0] * -1.0 / n[2]]}
    ok, rep = ask(session, f"{P}/lb/A9B4/sight", {"v": 1, "sights": [
        {"from": eye, "to": near},
        {"from": eye, "to": {"cell": CELL, "origin": [30.0, 30.0, z - 5.0]}},
    ]})
    assert ok, rep
    clear, blocked = rep["sights"]
    assert clear["clear"] is True and clear["blocker"] is None and clear["stop"] is None
    assert blocked["clear"] is False and blocked["blocker"] == {"kind": "terrain", "object_id": None}
    assert z - 5.0 <= blocked["stop"]["origin"][2] <= z + 2.0
    # a position outside the key's landblock
    ok, rep = ask(session, f"{P}/lb/A9B5/ground", {"v": 1, "ground": {"position": high}})
    assert not ok and rep["error"]["kind"] == "wrong_landblock" and rep["error"]["landblock"] == LB
