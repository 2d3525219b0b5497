"""The service's single-move path, run in this process: the node's move callback called with stand-in
queries (no network for the requests), on a node whose session listens on a free loopback port.

What is checked is what docs/protocol.md promises for one move, whichever path runs it: the reply's
shape, the errors, the stats counts, publication only while someone subscribes; and that a request
key read once (and remembered) is still refused when it is not a landblock's key.
"""

from __future__ import annotations

import threading
from types import SimpleNamespace
from collections.abc import Iterator
from typing import Any

import msgpack
import pytest
import zenoh

from benchmarks.standins import SilentBus
from clients.demo.world import global_to_cell
from engine import load_scene
from engine.geometry import Position, Vec3
from service.protocol.codec import encode_mover_spec, encode_position
from service.protocol.errors import ProtocolError
from service.bus.node import NodeOptions, ServiceNode
from service.ownership import Ownership
from service.core import ServiceCore
from service.protocol.requests import parse_register
from service.protocol.wire import ErrorKind
from service.bus.zconfig import make_config
from support.service_harness import DEMO_SCENE, StandInQuery, endpoint, free_port, human, raw_session, wait_until

LB = 0xA9B4
MOVE_KEY = "acphys/lb/A9B4/move"


def _node(options: NodeOptions) -> tuple[ServiceNode, str]:
    """A started node on the demo world, listening on a free loopback port (the caller shuts it down)."""
    where = endpoint(free_port())
    n = ServiceNode(load_scene(str(DEMO_SCENE)), make_config(listen=[where]), options)
    n.start()
    return n, where


_ENDPOINTS: dict[int, str] = {}


@pytest.fixture
def node() -> Iterator[ServiceNode]:
    n, where = _node(NodeOptions())
    _ENDPOINTS[id(n)] = where
    try:
        yield n
    finally:
        _ENDPOINTS.pop(id(n), None)
        n.shutdown(timeout=5.0)


def _register(node: ServiceNode, gx: float = 40.0) -> int:
    cell, x, y = global_to_cell(gx, 40.0)
    core = node.core
    assert core is not None and (cell >> 16) == LB
    req = parse_register({"v": 1, "mover": encode_mover_spec(human()),
                          "position": encode_position(Position.at(cell, Vec3(x, y, 60.0)))})
    return int(core.register(req)["state"]["id"])


def _ask(node: ServiceNode, content: dict[str, Any], key: str = MOVE_KEY) -> StandInQuery:
    q = StandInQuery(key, {"v": 1, **content})
    node.lb_queryable("*")(q)
    # a single move runs in the callback when the engine is idle; anything queued is waited for
    assert wait_until(lambda: len(q.ok) + len(q.err) == 1, timeout=10.0)
    assert q.dropped == 1  # every query is finished (Zenoh's final answer) exactly once
    return q


def test_one_move_is_answered_with_its_state_and_counted(node: ServiceNode) -> None:
    mid = _register(node)
    before = node.stats.snapshot()
    q = _ask(node, {"move": {"id": mid, "offset": [0.5, 0.0, 0.0], "tag": "t1"}})
    [reply] = q.ok
    assert set(reply) == {"v", "state"} and reply["v"] == 1
    state = reply["state"]
    assert (state["id"], state["seq"], state["tag"], state["landblock"]) == (mid, 1, "t1", LB)
    after = node.stats.snapshot()
    assert after["requests"]["move"] == before["requests"]["move"] + 1
    assert after["moves"] == before["moves"] + 1
    assert after["latency_ms"]["count"] == before["latency_ms"]["count"] + 1
    assert after["engine_ms"]["count"] == before["engine_ms"]["count"] + 1
    # the latency (receipt to result) includes the engine's time
    assert after["latency_ms"]["max"] >= after["engine_ms"]["max"] > 0.0


def test_a_failed_single_move_is_an_error_reply_and_moves_nothing(node: ServiceNode) -> None:
    mid = _register(node)
    before = node.stats.snapshot()
    q = _ask(node, {"move": {"id": mid + 1, "offset": [0.5, 0.0, 0.0]}})
    assert not q.ok
    assert q.err[0]["error"]["kind"] == ErrorKind.UNKNOWN_MOVER
    q = _ask(node, {"move": {"id": mid, "offset": "east"}})  # not an array: the field is named
    assert q.err[0]["error"]["kind"] == ErrorKind.WRONG_TYPE and q.err[0]["error"]["path"] == "move.offset"
    after = node.stats.snapshot()
    assert after["moves"] == before["moves"]
    assert after["requests"]["move"] == before["requests"]["move"] + 2
    assert after["errors"][ErrorKind.UNKNOWN_MOVER] == before["errors"][ErrorKind.UNKNOWN_MOVER] + 1
    assert after["errors"][ErrorKind.WRONG_TYPE] == before["errors"][ErrorKind.WRONG_TYPE] + 1
    # the mover did not move: its next move is seq 1
    assert _ask(node, {"move": {"id": mid, "offset": [0.0, 0.0, 0.0]}}).ok[0]["state"]["seq"] == 1


def test_move_and_moves_keep_their_meaning_on_every_path(node: ServiceNode) -> None:
    mid = _register(node)
    m = {"id": mid, "offset": [0.1, 0.0, 0.0]}
    # `moves: nil` is an absent batch: a single move, answered as one
    assert set(_ask(node, {"move": m, "moves": None}).ok[0]) == {"v", "state"}
    # `move: nil` beside a batch: the batch
    [reply] = _ask(node, {"move": None, "moves": [m]}).ok
    assert set(reply) == {"v", "results"} and reply["results"][0]["seq"] == 2
    # both given: refused, as docs/protocol.md says (exactly one of move or moves)
    assert _ask(node, {"move": m, "moves": [m]}).err[0]["error"]["kind"] == ErrorKind.BAD_VALUE
    assert _ask(node, {"move": None}).err[0]["error"]["kind"] == ErrorKind.MISSING_FIELD


def test_request_keys_read_once_are_still_checked_every_time() -> None:
    n = ServiceNode(None, zenoh.Config(), NodeOptions())  # `_key_lb` needs neither a world nor a session
    for _ in range(3):  # the first read and the remembered ones agree
        assert n._key_lb(MOVE_KEY, "move") == LB
        assert n._key_lb("acphys/lb/0102/get", "get") == 0x0102
        assert n._key_lb("acphys/lb/*/get", "get") is None  # a `get` sent to every instance
        for key, op in (("acphys/lb/a9b4/move", "move"),  # lower case: not the landblock's one key
                        ("acphys/lb/*/load", "load"),  # a load names its landblock
                        ("acphys/lb/A9B4/*", "move"),  # one request, one operation
                        ("acphys/lb/A9B4/get", "move")):  # another operation's key
            with pytest.raises(ProtocolError) as e:
                n._key_lb(key, op)
            assert e.value.kind == ErrorKind.BAD_VALUE


def test_states_are_published_while_someone_subscribes(node: ServiceNode) -> None:
    mid = _register(node)
    received: list[dict[str, Any]] = []
    lock = threading.Lock()

    def on_sample(sample: Any) -> None:
        with lock:
            received.append(msgpack.unpackb(sample.payload.to_bytes(), raw=False))

    watcher = raw_session(_ENDPOINTS[id(node)])  # a subscriber that comes after the node started
    try:
        sub = watcher.declare_subscriber(f"acphys/obj/{mid:X}/state", on_sample)
        bus = node.bus
        assert bus is not None
        assert wait_until(bus.states_watched, timeout=10.0)
        _ask(node, {"move": {"id": mid, "offset": [0.2, 0.0, 0.0]}})
        assert wait_until(lambda: len(received) == 1, timeout=10.0)
        assert received[0]["v"] == 1 and (received[0]["state"]["id"], received[0]["state"]["seq"]) == (mid, 1)
        sub.undeclare()
        assert wait_until(lambda: not bus.states_watched(), timeout=10.0)
        published: list[int] = []
        real_publish = bus.publish_state
        bus.publish_state = lambda mover_id, packed: published.append(mover_id)  # type: ignore[method-assign, assignment]
        try:
            assert _ask(node, {"move": {"id": mid, "offset": [0.2, 0.0, 0.0]}}).ok[0]["state"]["seq"] == 2
        finally:
            bus.publish_state = real_publish  # type: ignore[method-assign]
        assert published == []  # nobody subscribes: the State is not put
    finally:
        watcher.close()


def test_no_state_is_published_when_publication_is_off() -> None:
    n, _ = _node(NodeOptions(publish_states=False))
    try:
        assert n.bus is not None and not n.bus.states_watched()
        n2, _ = _node(NodeOptions(skip_unwatched_states=False))
        try:
            assert n2.bus is not None and n2.bus.states_watched()  # every State published, whoever listens
        finally:
            n2.shutdown(timeout=5.0)
    finally:
        n.shutdown(timeout=5.0)


def test_a_single_move_is_answered_alike_whichever_reader_takes_it(node: ServiceNode) -> None:
    """A plain `{"v", "move"}` is read from its bytes; one with a field the protocol ignores takes the
    request map's path: both are answered with their State and counted once, and a bad one is refused
    with the map path's error on either."""
    mid = _register(node)
    before = node.stats.snapshot()
    plain = _ask(node, {"move": {"id": mid, "offset": [0.5, 0.0, 0.0], "tag": 4}})
    extra = _ask(node, {"move": {"id": mid, "offset": [-0.5, 0.0, 0.0], "tag": 5, "note": "x"}, "note": 1})
    [a], [b] = plain.ok, extra.ok
    assert (a["state"]["seq"], a["state"]["tag"], b["state"]["seq"], b["state"]["tag"]) == (1, 4, 2, 5)
    assert set(a["state"]) == set(b["state"])
    bad = _ask(node, {"move": {"id": mid, "offset": [0.5, 0.0]}})
    assert (bad.err[0]["error"]["kind"], bad.err[0]["error"]["path"]) == (ErrorKind.BAD_VALUE, "move.offset")
    after = node.stats.snapshot()
    assert after["moves"] == before["moves"] + 2
    assert after["requests"]["move"] == before["requests"]["move"] + 3


def test_a_single_move_waits_behind_queued_work_and_is_refused_once_closed() -> None:
    """Run in the callback only while nothing is queued (a move never overtakes a queued request); queued
    otherwise, and answered `shutting_down` once the queue is closed. No session: the engine thread's
    part is played here."""
    n = ServiceNode(load_scene(str(DEMO_SCENE)), zenoh.Config(), NodeOptions())
    n.core = ServiceCore(n.world, SilentBus(), ownership=n.options.ownership, instance="t", stats=n.stats)
    mid = _register(n)
    order: list[str] = []
    assert n.queue.offer(lambda: order.append("queued first"))
    q = StandInQuery(MOVE_KEY, {"v": 1, "move": {"id": mid, "offset": [0.1, 0.0, 0.0]}})
    n.lb_queryable("*")(q)
    assert not q.ok and not q.err and n.queue.unfinished == 2  # queued behind the first job, not run
    for _ in range(2):
        job = n.queue.get(timeout=1.0)
        assert job is not None
        n._run_job(job)
        order.append(f"answered {len(q.ok)}")
    assert order == ["queued first", "answered 0", "answered 1"] and q.ok[0]["state"]["seq"] == 1
    n.queue.close()
    closed = StandInQuery(MOVE_KEY, {"v": 1, "move": {"id": mid, "offset": [0.1, 0.0, 0.0]}})
    n.lb_queryable("*")(closed)
    assert closed.err[0]["error"]["kind"] == ErrorKind.SHUTTING_DOWN and closed.dropped == 1


class _RecordingBus(SilentBus):
    """A bus someone always watches, writing down when it is asked and when it publishes."""

    def __init__(self, events: list[str]) -> None:
        self.events = events

    def states_watched(self) -> bool:
        self.events.append("watched?")
        return True

    def publish_state(self, mover_id: int, packed_state: bytes) -> None:
        self.events.append(f"published {msgpack.unpackb(packed_state)['seq']}")


class _RecordingQuery(StandInQuery):
    def __init__(self, events: list[str], content: dict[str, Any]) -> None:
        super().__init__(MOVE_KEY, content)
        self.events = events

    def reply(self, key: Any, payload: bytes) -> None:
        super().reply(key, payload)
        self.events.append(f"replied {self.ok[-1]['state']['seq']}")

    def drop(self) -> None:
        super().drop()
        self.events.append("dropped")


@pytest.mark.parametrize("ownership", [Ownership(), Ownership(frozenset({LB}))], ids=["everything", "one landblock"])
def test_a_single_moves_state_is_published_after_its_reply_only_where_nothing_can_take_the_mover(
        ownership: Ownership) -> None:
    """Owning every landblock, the State goes out after the reply (the question "does anyone subscribe"
    costs the round trip nothing), the moves' States still in seq order; owning only some, a move may hand
    the mover over, and the State is published (or handed over) before the reply, as a batch's are."""
    events: list[str] = []
    n = ServiceNode(load_scene(str(DEMO_SCENE)), zenoh.Config(), NodeOptions(ownership=ownership))
    n.core = ServiceCore(n.world, _RecordingBus(events), ownership=ownership, instance="t", stats=n.stats)
    mid = _register(n)
    events.clear()  # the register's own publication
    for dx in (0.1, -0.1):
        q = _RecordingQuery(events, {"v": 1, "move": {"id": mid, "offset": [dx, 0.0, 0.0]}})
        n.lb_queryable("*")(q)
        if not ownership.everything:  # run on the engine thread, whose part is played here (as above)
            job = n.queue.get(timeout=1.0)
            assert job is not None
            n._run_job(job)
        assert q.dropped == 1 and len(q.ok) == 1
    if ownership.everything:
        assert events == ["replied 1", "dropped", "watched?", "published 1",
                          "replied 2", "dropped", "watched?", "published 2"]
    else:
        assert events == ["watched?", "published 1", "replied 1", "dropped",
                          "watched?", "published 2", "replied 2", "dropped"]


def test_states_held_for_a_sync_are_not_published_after_the_reply() -> None:
    """Under `--state-sync always` a State waits for its records' sync, which comes before the reply: a
    single move's State is then published the way a batch's is, not after the reply."""
    n = ServiceNode(load_scene(str(DEMO_SCENE)), zenoh.Config(), NodeOptions())
    core = ServiceCore(n.world, SilentBus(), ownership=n.options.ownership, instance="t", stats=n.stats)
    assert core.publishes_after_reply
    core.attach_log(SimpleNamespace(always=True))  # type: ignore[arg-type]  # all attach_log reads of a log
    assert not core.publishes_after_reply
    core.attach_log(SimpleNamespace(always=False))  # type: ignore[arg-type]  # `--state-sync` every/never
    assert core.publishes_after_reply
