"""The service's single-move path, run in this process: the node's move callback called with stand-in
queries (no network for the requests), on a node whose session listens on a free loopback port.

What is checked is what docs/protocol.md promises for one move, whichever path runs it: the reply's
shape, the errors, the stats counts, publication only while someone subscribes; and that a request
key read once (and remembered) is still refused when it is not a landblock's key.
"""

from __future__ import annotations

import logging
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
from support.service_harness import DEMO_SCENE, StandInQuery, endpoint, free_port, human, raw_session, register_human, wait_until

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
    assert node.core is not None and (global_to_cell(gx, 40.0)[0] >> 16) == LB
    return register_human(node.core, gx)


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


class _Oversized:
    """A payload one byte over the limit, as Zenoh's ZBytes shows it: its length, and bytes only if asked."""

    def __len__(self) -> int:
        from service.protocol.wire import MAX_PAYLOAD

        return MAX_PAYLOAD + 1

    def to_bytes(self) -> bytes:
        raise AssertionError("an oversized payload is refused by its length, before it is copied")


def _query(key: str, content: dict[str, Any] | None) -> StandInQuery:
    q = StandInQuery(key, content or {})
    if content is None:
        q.payload = _Oversized()  # type: ignore[assignment]
    return q


#: requests the move handler leaves to the general one: the request log on is tried apart
_NOT_PLAIN = {
    "a move with a field the protocol ignores": (MOVE_KEY, {"v": 1, "move": {"id": 1, "offset": [0.1, 0, 0]}, "note": 1}),
    "a batch": (MOVE_KEY, {"v": 1, "moves": [{"id": 1, "offset": [0.1, 0, 0]}]}),
    "a key that is not the landblock's": ("acphys/lb/a9b4/move", {"v": 1, "move": {"id": 1, "offset": [0.1, 0, 0]}}),
    "an oversized payload": (MOVE_KEY, None),
}


def test_the_move_handler_takes_only_a_plain_move_and_leaves_the_rest_to_the_general_handler(
        monkeypatch: pytest.MonkeyPatch) -> None:
    import service.bus.single_move as single_move

    n = ServiceNode(None, zenoh.Config(), NodeOptions())  # nothing runs: the general handler is a recorder
    given: list[Any] = []
    taken: list[Any] = []
    monkeypatch.setattr(single_move, "submit_single",
                        lambda node, query, key_expr, item, batch_mode, received: taken.append((query, item)))
    handler = single_move.move_handler(n, lambda q, key_expr, key: given.append((q, key)))
    for what, (key, content) in _NOT_PLAIN.items():
        q = _query(key, content)
        handler(q, key, key)
        assert given[-1] == (q, key) and not taken, what
    given.clear()
    q = _query(MOVE_KEY, {"v": 1, "move": {"id": 7, "offset": [0.1, 0.0, 0.0]}})
    handler(q, MOVE_KEY, MOVE_KEY)
    assert not given and taken[0][0] is q and taken[0][1].id == 7
    # counted once, by the handler that took it: the general handler counts what it is given itself
    assert n.stats.snapshot()["requests"]["move"] == 1


def test_a_single_move_is_answered_alike_with_the_request_log_on_and_off(caplog: pytest.LogCaptureFixture) -> None:
    """The request log on sends every request through the general handler: each answer, error and count must
    be what the short way gives, on two nodes over the same world, asked the same requests."""
    answers: list[list[Any]] = []
    counts: list[dict[str, Any]] = []
    for debug in (False, True):
        caplog.set_level(logging.DEBUG if debug else logging.INFO, logger="acphys.requests")
        n, _ = _node(NodeOptions())
        try:
            mid = _register(n)
            cell, x, y = global_to_cell(41.0, 40.0)
            requests: list[tuple[str, dict[str, Any] | None]] = [
                (MOVE_KEY, {"v": 1, "move": {"id": mid, "offset": [0.5, 0.0, 0.0], "tag": "east"}}),
                (MOVE_KEY, {"v": 1, "move": {"id": mid, "to": encode_position(Position.at(cell, Vec3(x, y, 60.0)))}}),
                (MOVE_KEY, {"v": 1, "move": {"id": mid, "motion": [0.0, 0.8, 0.0], "dt": 0.2}}),
                (MOVE_KEY, {"v": 1, "move": {"id": mid + 1000, "offset": [0.5, 0.0, 0.0]}}),
                ("acphys/lb/a9b4/move", {"v": 1, "move": {"id": mid, "offset": [0.5, 0.0, 0.0]}}),
                (MOVE_KEY, None),
            ]
            before = n.stats.snapshot()
            got: list[tuple[Any, ...]] = []
            for key, content in requests:
                q = _query(key, content)
                n.lb_queryable("*")(q)
                assert wait_until(lambda q=q: len(q.ok) + len(q.err) == 1, timeout=10.0) and q.dropped == 1
                if q.ok:
                    state = dict(q.ok[0]["state"])
                    assert state.pop("id") == mid
                    got.append(("ok", state))
                else:
                    err = q.err[0]["error"]
                    got.append(("err", err["kind"], err.get("path")))
            after = n.stats.snapshot()
            answers.append(got)
            counts.append({"moves": after["moves"] - before["moves"],
                           "requests": after["requests"]["move"] - before["requests"]["move"],
                           "errors": {k: v - before["errors"].get(k, 0) for k, v in after["errors"].items()
                                      if v != before["errors"].get(k, 0)}})
        finally:
            n.shutdown(timeout=5.0)
    short, general = answers
    assert short == general
    assert counts[0] == counts[1]
    # what both must be, by the protocol: three moves (seq 1, 2, 3), then the three errors
    assert [a[0] for a in short] == ["ok", "ok", "ok", "err", "err", "err"]
    assert [a[1]["seq"] for a in short[:3]] == [1, 2, 3] and short[0][1]["tag"] == "east"
    assert [a[1] for a in short[3:]] == [ErrorKind.UNKNOWN_MOVER, ErrorKind.BAD_VALUE, ErrorKind.TOO_LARGE]
    assert counts[0]["moves"] == 3 and counts[0]["requests"] == 6


def test_a_single_move_written_out_gives_what_move_one_gives() -> None:
    """`ServiceCore.move_single` against `move_one` (nothing published), on two cores over two copies of one world:
    every move kind gives the same State bytes and the same counts, and a move either refuses, the same error."""
    from service.stats import ServiceStats

    cores = [ServiceCore(load_scene(str(DEMO_SCENE)), SilentBus(), ownership=Ownership(), instance=name,
                         stats=ServiceStats()) for name in ("written-out", "move-one")]
    cell, x, y = global_to_cell(40.0, 40.0)
    ids = []
    for core in cores:
        core._id_base = 1 << 32  # the same ids on both, so that their States compare bytewise
        ids.append(core.register(parse_register({"v": 1, "mover": encode_mover_spec(human()),
                                                 "position": encode_position(Position.at(cell, Vec3(x, y, 60.0)))}))
                   ["state"]["id"])
    assert ids[0] == ids[1]
    mid = ids[0]
    tcell, tx, ty = global_to_cell(41.5, 40.0)
    moves = [{"id": mid, "offset": [0.5, 0.0, 0.0], "tag": 1},
             {"id": mid, "to": encode_position(Position.at(tcell, Vec3(tx, ty, 60.0))), "tag": "to"},
             {"id": mid, "motion": [0.0, 0.8, 0.0], "dt": 0.2},  # a step: `move_one`'s own way on both
             {"id": mid, "offset": [500.0, 0.0, 0.0]},  # beyond the move's limit: refused by the engine
             {"id": mid + 1, "offset": [0.5, 0.0, 0.0]}]  # no such mover
    from service.protocol.requests import parse_single_move

    for m in moves:
        item, _ = parse_single_move({"v": 1, "move": m})
        got: list[Any] = []
        for core, run in zip(cores, (lambda c, i: c.move_single(i, 0.0), lambda c, i: c.move_one(i, 0.0, False))):
            try:
                got.append(run(core, item))
            except ProtocolError as e:
                got.append((e.kind, e.path))
        assert got[0] == got[1], m
    a, b = (c.stats.snapshot() for c in cores)
    assert a["moves"] == b["moves"] == 3
    assert a["engine_ms"]["count"] == b["engine_ms"]["count"] == 3
    assert [c.movers[mid].seq for c in cores] == [3, 3]
