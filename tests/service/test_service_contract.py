"""Points where docs/protocol.md and the service must say the same thing (each checked against the
doc's own words, quoted beside the test)."""

from __future__ import annotations

from collections.abc import Iterator

import msgpack
import pytest
import zenoh

from clients import Client
from clients.demo.world import global_to_cell
from engine.geometry import Position, Vec3
from support.service_harness import ServiceProcess, human, raw_query, raw_session


@pytest.fixture(scope="module")
def svc() -> Iterator[ServiceProcess]:
    with ServiceProcess() as s:
        yield s


@pytest.fixture()
def session(svc: ServiceProcess) -> Iterator[zenoh.Session]:
    s = raw_session(svc.endpoint)
    with Client(session=s) as c:
        c.wait_ready()
    yield s
    s.close()


def _mover(session: zenoh.Session, gx: float = 40.0, gy: float = 40.0, z: float = 60.0) -> dict:  # type: ignore[type-arg]
    cell, x, y = global_to_cell(gx, gy)
    with Client(session=session) as c:
        st = c.register(human(), Position.at(cell, Vec3(x, y, z)))
    ok, reply = raw_query(session, "acphys/lb/A9B4/get", msgpack.packb({"v": 1, "id": st.id}))
    assert ok
    return reply["state"]  # type: ignore[no-any-return]


# "Health, stats, landblocks: payload empty or {"v": 1}" and "The service refuses any other value [of v]"
@pytest.mark.parametrize("key", ["acphys/health", "acphys/stats", "acphys/landblocks"])
@pytest.mark.parametrize("payload,kind", [
    (b"\xc1", "malformed"),  # not msgpack
    (msgpack.packb([1, 2]), "malformed"),  # not a map
    (msgpack.packb({"v": 2}), "unsupported_version"),
    (msgpack.packb({"x": 1}), "missing_field"),
])
def test_instance_keys_refuse_what_other_requests_refuse(session: zenoh.Session, key: str, payload: bytes,
                                                         kind: str) -> None:
    ok, reply = raw_query(session, key, payload)
    assert not ok and reply["error"]["kind"] == kind


@pytest.mark.parametrize("key", ["acphys/health", "acphys/stats", "acphys/landblocks"])
@pytest.mark.parametrize("payload", [None, msgpack.packb({"v": 1})])
def test_instance_keys_take_an_empty_payload_or_v1(session: zenoh.Session, key: str, payload: bytes | None) -> None:
    ok, reply = raw_query(session, key, payload)
    assert ok and reply["v"] == 1 and isinstance(reply["instance"], str)


# "XXYY is a landblock id as four upper-case hex digits"
def test_lower_case_landblock_keys_are_refused(session: zenoh.Session) -> None:
    st = _mover(session)
    move = msgpack.packb({"v": 1, "move": {"id": st["id"], "offset": [0.5, 0.0, 0.0]}})
    ok, reply = raw_query(session, "acphys/lb/a9b4/move", move)
    assert not ok and reply["error"]["kind"] == "bad_value"
    ok, reply = raw_query(session, "acphys/lb/A9B4/get", msgpack.packb({"v": 1, "id": st["id"]}))
    assert ok and reply["state"]["seq"] == 0  # the refused move did not run


# "An instance serves a mover it holds whatever landblock key the request arrived on ... even the key of a
# landblock that is not loaded"
def test_a_move_on_another_landblocks_key_is_served_by_the_instance_holding_it(session: zenoh.Session) -> None:
    st = _mover(session)
    ok, lbs = raw_query(session, "acphys/landblocks", None)
    assert ok and 0x0101 not in lbs["loaded"]
    ok, reply = raw_query(session, "acphys/lb/0101/move",
                          msgpack.packb({"v": 1, "move": {"id": st["id"], "offset": [0.5, 0.0, 0.0]}}))
    assert ok and reply["state"]["landblock"] == 0xA9B4 and reply["state"]["seq"] == 1


# "A key nobody serves ... the query ends with no reply"
def test_a_key_nobody_serves_gets_no_reply(session: zenoh.Session) -> None:
    for key in ("acphys/lb/A9B4/teleport", "acphys/nothing", "other-prefix/lb/A9B4/move"):
        assert list(session.get(key, payload=msgpack.packb({"v": 1}), timeout=1.0)) == []


def test_a_landblock_nobody_owns_gets_no_reply() -> None:
    with ServiceProcess(own="A9B4") as one:
        s = raw_session(one.endpoint)
        try:
            with Client(session=s) as c:
                c.wait_ready()
            assert list(s.get("acphys/lb/AAB4/move", payload=msgpack.packb({"v": 1}), timeout=1.0)) == []
        finally:
            s.close()


# "requests: requests received per operation (move, push, register, update, remove, get, load, unload,
# handover, health, stats, landblocks, sight, ray, ground, place, path, random_point)"; errors by kind; "every
# known key is listed,
# 0 when none"
def test_stats_list_every_operation_and_error_kind_with_zero() -> None:
    documented_ops = {"move", "push", "register", "update", "remove", "get", "load", "unload", "handover",
                      "health", "stats", "landblocks", "sight", "ray", "ground", "place", "path", "random_point"}
    documented_kinds = {"malformed", "too_large", "unsupported_version", "missing_field", "wrong_type",
                        "bad_value", "non_finite", "unknown_mover", "duplicate_mover", "wrong_landblock", "moved",
                        "unknown_cell", "landblock_not_loaded", "landblock_unavailable", "landblock_in_use", "forbidden",
                        "no_owner", "busy", "shutting_down", "engine_error", "internal"}
    with ServiceProcess() as fresh:
        s = raw_session(fresh.endpoint)
        try:
            ok, stats = raw_query(s, "acphys/stats", None)
            assert ok
            assert set(stats["requests"]) == documented_ops
            assert stats["requests"] == {op: (1 if op == "stats" else 0) for op in documented_ops}
            assert stats["errors"] == {k: 0 for k in documented_kinds}
            assert stats["handovers"] == {"out": 0, "in": 0, "failed": 0}
        finally:
            s.close()


# "seq: +1 for every move the service resolved ... including a move that changes nothing": the first
# physics step of a mover at rest in the air sets its velocity but does not move it yet
def test_a_step_that_changes_nothing_still_counts(session: zenoh.Session) -> None:
    st = _mover(session, 60.0, 60.0, 80.0)
    step = msgpack.packb({"v": 1, "move": {"id": st["id"], "motion": [0.0, 0.0, 0.0], "dt": 0.2}})
    ok, first = raw_query(session, "acphys/lb/A9B4/move", step)
    assert ok
    first = first["state"]
    assert first["seq"] == 1 and first["transition_state"] == "NoTransition"
    assert first["position"] == st["position"]
    ok, second = raw_query(session, "acphys/lb/A9B4/move", step)
    assert ok and second["state"]["seq"] == 2
    # the second step moves it: with the speed the first gave (v = g dt) and gravity over dt,
    # v dt + g dt^2 / 2 = 9.8 * 0.2 * 0.2 + 9.8 * 0.04 / 2 = 0.588 m down
    assert second["state"]["position"]["origin"][2] == pytest.approx(80.0 - 0.588, abs=1e-3)


# "too_large: payload over 4 MiB" for a push too: answered on P/errors and counted; "a payload over 5 MiB
# never reaches the service": Zenoh drops it, unanswered and uncounted. The Python client refuses to send one
# (Zenoh's default DROP congestion control may lose it unseen)
def test_an_oversized_push_is_answered_and_counted(session: zenoh.Session) -> None:
    import threading

    from clients import Move, ServiceError
    from support.service_harness import wait_until

    st = _mover(session)
    errors: list[dict] = []  # type: ignore[type-arg]
    lock = threading.Lock()

    def on_error(sample: zenoh.Sample) -> None:
        with lock:
            errors.append(msgpack.unpackb(sample.payload.to_bytes(), raw=False))

    sub = session.declare_subscriber("acphys/errors", on_error)
    try:
        ok, before = raw_query(session, "acphys/stats", None)
        # with congestion control BLOCK both reach the service's Zenoh session, in order: 50 MiB, over its
        # receive limit (transport/link/rx/max_message_size), is dropped there; 4 MiB and 200 kB is answered
        session.put("acphys/lb/A9B4/push", b"\x00" * (50 << 20), congestion_control=zenoh.CongestionControl.BLOCK)
        session.put("acphys/lb/A9B4/push", b"\x00" * ((4 << 20) + 200_000),
                    congestion_control=zenoh.CongestionControl.BLOCK)
        assert wait_until(lambda: bool(errors), timeout=20.0)
        assert len(errors) == 1
        assert errors[0]["error"]["kind"] == "too_large" and errors[0]["key"] == "acphys/lb/A9B4/push"
        ok, after = raw_query(session, "acphys/stats", None)
        assert after["errors"]["too_large"] == before["errors"]["too_large"] + 1
        assert after["requests"]["push"] == before["requests"]["push"] + 1
        with Client(session=session) as c:
            big = [Move(st["id"], offset=(0.0, 0.0, 0.0), tag="t" * 250) for _ in range(20000)]  # > 4 MiB
            with pytest.raises(ServiceError) as e:
                c.push(big)
            assert e.value.kind == "too_large"
            assert c.get(st["id"])[0].seq == 0  # nothing of it was sent
    finally:
        sub.undeclare()
