"""The publication promise of docs/protocol.md ("State publication"), on real Zenoh sessions: a subscriber
whose declaration reached the instance before a request gets that request's States. The instance reads
"is anyone watching" cheaply (service/bus/publication.py, `MatchWatch`), and Zenoh tells its matching
listener of a new subscriber later than it hands the next request on the same link to the queryable;
these tests race exactly that, round after round. On an idle machine Zenoh's notification mostly wins
that race, so each test also runs with the notifications held back (as a loaded machine may hold them):
then a shortcut trusting a stale "nobody" fails every round.

And the other half: once the subscriber is gone, the instance stops putting States.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from typing import Any

import msgpack
import pytest
import zenoh

from clients.demo.world import global_to_cell
from engine import load_scene
from service.bus.node import NodeOptions, ServiceNode
from service.bus.publication import MatchWatch
from service.bus.zconfig import make_config
from support.service_harness import DEMO_SCENE, endpoint, free_port, raw_session, register_human, wait_until

LB = 0xA9B4
PREFIX = "acphys"
MOVE_KEY = f"{PREFIX}/lb/A9B4/move"
ROUNDS_ONE_SESSION = 40
ROUNDS_FRESH_SESSION = 8


class Node:
    """A started service node on the demo world, listening on a free loopback port, and one mover in it."""

    def __init__(self) -> None:
        self.endpoint = endpoint(free_port())
        self.node = ServiceNode(load_scene(str(DEMO_SCENE)), make_config(listen=[self.endpoint]), NodeOptions())
        self.node.start()
        assert (global_to_cell(40.0, 40.0)[0] >> 16) == LB
        self.mover = register_human(self.node.core)

    @property
    def bus(self) -> Any:
        assert self.node.bus is not None
        return self.node.bus


#: how long Zenoh's matching notifications are held back: none (the race as it comes), and long enough
#: that every request of a round is handled before the notification of its subscriber
NOTIFICATION_DELAYS = [0.0, 0.05]


@pytest.fixture(params=NOTIFICATION_DELAYS, ids=["notified-at-once", "notified-late"])
def running(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> Iterator[Node]:
    delay = float(request.param)
    if delay:
        on_time = MatchWatch._notified

        def late(watch: MatchWatch, status: Any) -> None:
            time.sleep(delay)  # on Zenoh's thread, the GIL let go: requests go on meanwhile
            on_time(watch, status)

        monkeypatch.setattr(MatchWatch, "_notified", late)  # before the node declares its watches
    n = Node()
    try:
        yield n
    finally:
        n.node.shutdown(timeout=5.0)


class Inbox:
    """The seqs of the States a subscriber received: on P/obj/ID/state one a message, on P/states a list."""

    def __init__(self) -> None:
        self.seqs: list[int] = []
        self._lock = threading.Lock()

    def __call__(self, sample: zenoh.Sample) -> None:
        message = msgpack.unpackb(sample.payload.to_bytes(), raw=False)
        states = message["states"] if "states" in message else [message["state"]]
        with self._lock:
            self.seqs.extend(int(state["seq"]) for state in states)

    def has(self, seq: int) -> bool:
        with self._lock:
            return seq in self.seqs

    def gets(self, seq: int) -> bool:
        """Whether the State of `seq` comes (waited for a while)."""
        return wait_until(lambda: self.has(seq), timeout=5.0)


def move(session: zenoh.Session, mover: int, publish: str | None = None) -> int:
    """One move asked on `session`; the seq of the State it was answered."""
    body: dict[str, Any] = {"v": 1, "move": {"id": mover, "offset": [0.01, 0.0, 0.0]}}
    if publish is not None:
        body["publish"] = publish
    replies = list(session.get(MOVE_KEY, payload=msgpack.packb(body, use_bin_type=True), timeout=10.0))
    assert len(replies) == 1 and replies[0].ok is not None, "the move was not answered with a State"
    return int(msgpack.unpackb(replies[0].ok.payload.to_bytes(), raw=False)["state"]["seq"])


def subscribe_then_move(client: zenoh.Session, key: str, mover: int, publish: str | None = None) -> tuple[int, bool]:
    """A subscriber on `key` declared, then at once a move asked on the same session: the move's seq and
    whether the subscriber got its State. The subscriber is undeclared after."""
    inbox = Inbox()
    sub = client.declare_subscriber(key, inbox)
    try:
        seq = move(client, mover, publish)
        return seq, inbox.gets(seq)
    finally:
        sub.undeclare()


def link_up(client: zenoh.Session) -> bool:
    return wait_until(lambda: bool(list(client.info.peers_zid())), timeout=10.0)


def nobody_watches(n: Node) -> bool:
    return wait_until(lambda: not n.bus.states_watched(), timeout=10.0)


def test_a_subscriber_declared_just_before_a_move_on_its_session_gets_that_moves_state(running: Node) -> None:
    client = raw_session(running.endpoint)
    try:
        assert link_up(client)
        for round_ in range(ROUNDS_ONE_SESSION):
            assert nobody_watches(running), f"round {round_}: the last subscriber is still seen"
            seq, got = subscribe_then_move(client, f"{PREFIX}/obj/{running.mover:X}/state", running.mover)
            assert got, f"round {round_}: State {seq} never came"
    finally:
        client.close()


def test_a_fresh_session_subscribing_then_moving_gets_the_state(running: Node) -> None:
    for round_ in range(ROUNDS_FRESH_SESSION):
        assert nobody_watches(running), f"round {round_}: the last subscriber is still seen"
        client = raw_session(running.endpoint)
        try:
            assert link_up(client)
            # a wildcard subscription, then the session's first request at once
            seq, got = subscribe_then_move(client, f"{PREFIX}/obj/*/state", running.mover)
            assert got, f"round {round_}: State {seq} never came"
        finally:
            client.close()


def test_a_batch_subscriber_declared_just_before_a_move_gets_its_batch(running: Node) -> None:
    client = raw_session(running.endpoint)
    try:
        assert link_up(client)
        for round_ in range(ROUNDS_ONE_SESSION // 4):
            assert wait_until(lambda: not running.bus.batch_watched(), timeout=10.0)
            seq, got = subscribe_then_move(client, f"{PREFIX}/states", running.mover, publish="batch")
            assert got, f"round {round_}: the batch of {seq} never came"
    finally:
        client.close()


def test_a_subscriber_on_the_instances_own_session_is_seen_at_once(running: Node) -> None:
    session = running.node.session
    assert session is not None
    assert not running.bus.states_watched()
    sub = session.declare_subscriber(f"{PREFIX}/obj/*/state", lambda _s: None)
    try:
        assert running.bus.states_watched()  # no wait: the declaration is this session's own
    finally:
        sub.undeclare()
    assert nobody_watches(running)


def test_states_stop_being_put_once_the_subscriber_is_gone(running: Node) -> None:
    bus = running.bus
    watcher, asker = raw_session(running.endpoint), raw_session(running.endpoint)
    put: list[int] = []
    real_publish = bus.publish_state

    def counting_publish(mover_id: int, packed: bytes) -> None:
        put.append(mover_id)
        real_publish(mover_id, packed)

    bus.publish_state = counting_publish
    try:
        inbox = Inbox()
        watcher.declare_subscriber(f"{PREFIX}/obj/*/state", inbox)
        assert inbox.gets(move(watcher, running.mover))
        assert put == [running.mover]
        watcher.close()  # the subscription ends with its session
        assert nobody_watches(running)
        del put[:]
        for _ in range(5):
            move(asker, running.mover)  # a session that subscribes to nothing
        assert put == []  # nobody subscribes: no State is put
    finally:
        bus.publish_state = real_publish
        for session in (watcher, asker):
            if not session.is_closed():
                session.close()
