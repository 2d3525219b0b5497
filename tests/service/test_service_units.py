"""Service pieces that need no bus: queue, stats, ownership, envelope and codec."""

from __future__ import annotations

import math

import msgpack
import pytest

from engine.geometry import Plane, Position, Quat, Vec3
from engine.world.types import MoveResult
from service.protocol.codec import decode_mover_spec, decode_state, encode_mover_spec, encode_state
from service.protocol.errors import ProtocolError
from service.bus.jobqueue import JobQueue
from service.ownership import Ownership
from service.protocol.requests import ItemError, decode_envelope, parse_moves
from service.stats import LatencyWindow
from service.protocol.wire import Keys, lb_hex, obj_hex
from support.service_harness import human


def test_job_queue_bounds_requests_but_not_priority_work() -> None:
    q = JobQueue(2)
    ran: list[str] = []
    assert q.offer(lambda: ran.append("a")) and q.offer(lambda: ran.append("b"))
    assert not q.offer(lambda: ran.append("c"))  # full: the caller answers busy
    q.put_priority(lambda: ran.append("p"))
    for _ in range(3):
        job = q.get(timeout=0.1)
        assert job is not None
        job()
    assert ran == ["p", "a", "b"]
    assert q.get(timeout=0.01) is None
    q.offer(lambda: ran.append("d"))
    q.close()
    assert not q.offer(lambda: None)
    job = q.get()
    assert job is not None  # queued work is still handed out after close
    job()
    assert q.get() is None and ran[-1] == "d"


def test_job_queue_lanes_are_bounded_apart_and_served_in_turn() -> None:
    q = JobQueue(3)
    other = q.new_lane()
    ran: list[str] = []
    for name in ("a1", "a2", "a3"):
        assert q.offer(lambda n=name: ran.append(n))
    assert not q.offer(lambda: ran.append("a4"))  # lane 0 is full ...
    assert q.offer(lambda: ran.append("b1"), other)  # ... the other lane is not
    assert q.offer(lambda: ran.append("b2"), other)
    assert (q.depth(0), q.depth(other), len(q)) == (3, 2, 5)
    while (job := q.get(timeout=0.01)) is not None:
        job()
        q.task_done()
    # in turn, each lane in its own order
    assert ran == ["a1", "b1", "a2", "b2", "a3"]
    assert q.idle


def test_latency_percentiles() -> None:
    w = LatencyWindow(size=1000)
    for k in range(1, 101):
        w.add(k / 1000.0)
    s = w.summary_ms()
    assert s["count"] == 100 and s["p50"] == pytest.approx(50.0) and s["p99"] == pytest.approx(99.0)
    assert s["max"] == pytest.approx(100.0) and s["mean"] == pytest.approx(50.5)
    assert LatencyWindow().summary_ms()["p50"] == 0.0


def test_ownership() -> None:
    assert Ownership.parse("*").everything and Ownership.parse(None).owns(0x1234)
    o = Ownership.parse("A9B4, aab5")
    assert o.owns(0xA9B4) and o.owns(0xAAB5) and not o.owns(0xAAB4)
    assert o.key_parts() == ["A9B4", "AAB5"] and o.to_wire() == [0xA9B4, 0xAAB5]
    with pytest.raises(ValueError):
        Ownership.parse("A9B")


def test_keys() -> None:
    k = Keys("x")
    assert k.move(0xA9B4) == "x/lb/A9B4/move" and k.state(0x50000001) == "x/obj/50000001/state"
    assert lb_hex(0x0A0B) == "0A0B" and obj_hex(255) == "FF"


def test_envelope() -> None:
    assert decode_envelope(msgpack.packb({"v": 1, "a": 2})) == {"v": 1, "a": 2}
    assert decode_envelope(None, allow_empty=True) == {"v": 1}
    for payload, kind in [(b"", "malformed"), (b"\xc1", "malformed"), (msgpack.packb(3), "malformed"),
                          (msgpack.packb({"v": 3}), "unsupported_version"), (msgpack.packb({"v": True}), "wrong_type"),
                          (msgpack.packb({"x": 1}), "missing_field"), (b"\x00" * (5 << 20), "too_large")]:
        with pytest.raises(ProtocolError) as e:
            decode_envelope(payload)
        assert e.value.kind == kind


def test_batch_items_fail_alone() -> None:
    b = parse_moves({"v": 1, "moves": [{"id": 1, "offset": [0, 0, 0]}, {"id": 2, "offset": [0, 0, math.inf], "tag": 9},
                                       "junk"]})
    assert not b.single and len(b.items) == 3
    assert isinstance(b.items[1], ItemError) and b.items[1].id == 2 and b.items[1].tag == 9
    assert b.items[1].error.path == "moves[1].offset[2]"
    assert isinstance(b.items[2], ItemError) and b.items[2].id is None and b.items[2].error.kind == "wrong_type"
    with pytest.raises(ProtocolError) as e:
        parse_moves({"v": 1, "moves": [{}] * 5000})
    assert e.value.kind == "too_large"


def test_state_round_trip() -> None:
    r = MoveResult(
        ok=True, position=Position.at(0xA9B40001, Vec3(1.0, 2.0, 3.0), Quat(0.0, 0.0, 0.0, 1.0)),
        transition_state="Slid", contact=True, on_walkable=False,
        contact_plane=Plane(Vec3(0.0, 0.6, 0.8), -4.0), contact_plane_cell=0xA9B40001,
        collision_normal=Vec3(1.0, 0.0, 0.0), sliding_normal=None, water_contact=False,
        frames_stationary_fall=None, transient_state=["Contact", "Sliding"], collide_objects=[],
    )
    wire = msgpack.unpackb(msgpack.packb(encode_state(7, 3, r, [9], "t")))
    mover_id, seq, tag, back = decode_state(wire)
    assert (mover_id, seq, tag) == (7, 3, "t")
    assert encode_state(7, 3, back, [9], "t") == encode_state(7, 3, r, [9], "t")


def test_mover_spec_round_trip() -> None:
    spec = human()
    assert decode_mover_spec(msgpack.unpackb(msgpack.packb(encode_mover_spec(spec))), "mover") == spec


def test_a_sled_keeps_its_sledding_flag_on_the_wire() -> None:
    from dataclasses import replace

    sled = replace(human(), sledding=True)
    wire = encode_mover_spec(sled)
    assert wire["sledding"] is True
    assert decode_mover_spec(msgpack.unpackb(msgpack.packb(wire)), "mover").sledding is True
    # absent: not a sled (old clients); a non-boolean is refused with its path
    del wire["sledding"]
    assert decode_mover_spec(wire, "mover").sledding is False
    wire["sledding"] = 1
    with pytest.raises(ProtocolError) as e:
        decode_mover_spec(wire, "mover")
    assert e.value.path == "mover.sledding"


def test_a_failed_batch_item_echoes_its_tag_only_when_the_protocol_allows_it() -> None:
    """An item's error carries its tag back (to match answers to requests), but never one the protocol
    refuses: a 300-character string is not sent back, nor a 3 MB one."""
    b = parse_moves({"v": 1, "moves": [{"id": 5, "offset": "x", "tag": "a" * 300},
                                       {"id": 6, "offset": "x", "tag": "b" * 256},
                                       {"id": 7, "offset": "x", "tag": -(1 << 63)},
                                       {"id": 8, "offset": "x", "tag": 1 << 64},
                                       {"id": 9, "offset": "x", "tag": True}]})
    errors = [item for item in b.items if isinstance(item, ItemError)]
    assert [(e.id, e.tag) for e in errors] == [(5, None), (6, "b" * 256), (7, -(1 << 63)), (8, None), (9, None)]
    assert "tag" not in errors[0].to_wire() and errors[1].to_wire()["tag"] == "b" * 256
