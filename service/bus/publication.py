"""What an instance puts on the bus besides its replies: States, errors, forwarded moves, hand-overs.

`ZenohBus` is the core's `BusPort` (service/bus_port.py) on an open Zenoh session. It owns the publishers
the node declares for it and the question "would a put here reach anyone", asked once per request, so
an instance nobody watches publishes nothing (docs/protocol.md, "State publication"). The node keeps
the session, the queryables and the engine thread; it lends the bus two things for a hand-over's wait
(`HandoverWait`).

How "would a put reach anyone" stays exact yet cheap (`MatchWatch`): Zenoh's matching listener is told
of a new subscriber by a task Zenoh spawns while it takes in the declaration, so a request that came
after the declaration, even on the same link, may be handled before that task has run. Its "yes" is
therefore trusted (a put after a stale "yes" reaches nobody, which nobody can tell from no put), its
"no" is not: then the routing tables are read, as every request did before. That read lets go of the
GIL and scans every subscription the tables hold (measured ~1 µs with none, ~20 µs with 1000 others).
"""

from __future__ import annotations

import threading
import time
from typing import Any, Protocol

import msgpack
import zenoh

from service.protocol.errors import ProtocolError
from service.bus.request_log import ERRORS
from service.bus.route_keys import RouteKeys
from service.protocol.frames import pack, state_message, states_message
from service.protocol.wire import ErrorKind, Keys

__all__ = ["ZenohBus", "HandoverWait", "MatchWatch"]

#: State keys kept parsed (one per mover published recently)
_KEY_CACHE = 100_000


class HandoverWait(Protocol):
    """How the node stays responsive while the engine thread waits on a hand-over's answer."""

    def wake(self) -> None:
        """The answer has come: stop waiting now."""
        ...

    def serve_until(self, done: threading.Event, deadline: float) -> None:
        """Run the jobs that may not wait (arriving hand-overs) until `done` is set or `deadline` passes."""
        ...


class MatchWatch:
    """Whether a put on `publisher`'s key would reach a subscriber now: Zenoh's notified "yes", else its
    routing tables read at the call (see the module's docstring for why a notified "no" is not enough)."""

    __slots__ = ("publisher", "notified_matching", "_listener")

    def __init__(self, publisher: Any) -> None:
        self.publisher = publisher
        #: the last matching status Zenoh notified (it notifies at once when a subscriber exists already)
        self.notified_matching = False
        # called on Zenoh's thread (indirect=False): one assignment, no Python thread of its own
        self._listener: Any = publisher.declare_matching_listener(
            zenoh.handlers.Callback(self._notified, indirect=False))

    def _notified(self, status: Any) -> None:
        self.notified_matching = bool(status.matching)

    def matching(self) -> bool:
        """A subscriber whose declaration reached this session before the call is always seen."""
        if self.notified_matching:
            return True
        try:
            return bool(self.publisher.matching_status.matching)
        except Exception:  # the publisher is gone (shutting down): publish as without it
            return True

    def close(self) -> None:
        """Undeclare the listener (the publisher stays its owner's to undeclare)."""
        self.notified_matching = False
        try:
            self._listener.undeclare()
        except Exception:  # already gone with the session
            pass


class ZenohBus:
    """The core's view of the bus (BusPort), on `session` under `keys`'s prefix."""

    def __init__(self, session: zenoh.Session, keys: Keys, wait: HandoverWait, *, publish_states: bool,
                 skip_unwatched_states: bool, handover_timeout: float, route_keys: RouteKeys | None = None) -> None:
        self.session = session
        #: declares each mover's State key on the session, so that a put on it takes a cached route
        #: (service/bus/route_keys.py); None: keys parsed only (direct callbacks)
        self.route_keys = route_keys
        self.keys = keys
        self.publish_states = publish_states
        self.skip_unwatched_states = skip_unwatched_states
        self.handover_timeout = handover_timeout
        self._wait = wait
        self._state_keys: dict[int, zenoh.KeyExpr] = {}
        # a publisher on P/obj/*/state only for its matching status; kept until the queued requests are
        # answered at shutdown (they ask it)
        self._state_watch: MatchWatch | None = (
            MatchWatch(session.declare_publisher(keys.state("*"))) if skip_unwatched_states else None)
        self._batch_pub: Any = session.declare_publisher(keys.states)
        self._columns_pub: Any = session.declare_publisher(keys.state_columns)
        self._batch_watch: MatchWatch | None = MatchWatch(self._batch_pub) if skip_unwatched_states else None
        self._columns_watch: MatchWatch | None = MatchWatch(self._columns_pub) if skip_unwatched_states else None
        # a publisher on P/obj/*/error only for its matching status, as for the States
        self._error_watch: MatchWatch | None = (
            MatchWatch(session.declare_publisher(keys.obj_error("*"))) if skip_unwatched_states else None)
        self._open = True

    def close(self) -> None:
        """Undeclare the publishers and their listeners (the session stays the node's to close)."""
        self._open = False
        for watch in (self._state_watch, self._batch_watch, self._columns_watch, self._error_watch):
            if watch is not None:
                watch.close()
        state_pub = self._state_watch.publisher if self._state_watch is not None else None
        error_pub = self._error_watch.publisher if self._error_watch is not None else None
        for pub in (state_pub, self._batch_pub, self._columns_pub, error_pub):
            if pub is not None:
                try:
                    pub.undeclare()
                except Exception:  # already gone with the session
                    pass
        self._state_watch = self._batch_watch = self._columns_watch = self._error_watch = None
        self._batch_pub = self._columns_pub = None

    # -- would a put reach anyone -------------------------------------------------
    def states_watched(self) -> bool:
        """Whether anyone subscribes to a state key now (else the States need not be published)."""
        if not self.publish_states or not self._open:
            return False
        watch = self._state_watch
        if watch is None:
            return True
        return watch.matching()

    def _watched(self, pub: Any, watch: MatchWatch | None) -> bool:
        """Whether a put on `pub`'s key would reach anyone (`watch`'s answer when skipping unwatched puts)."""
        if not self.publish_states or pub is None:
            return False
        if watch is None:
            return True
        return watch.matching()

    def errors_watched(self) -> bool:
        """Whether anyone subscribes to an error key `P/obj/*/error` now (else a mover's error is not put)."""
        if not self._open:
            return False
        watch = self._error_watch
        return True if watch is None else watch.matching()

    def batch_watched(self) -> bool:
        """Whether anyone subscribes to P/states now."""
        return self._watched(self._batch_pub, self._batch_watch)

    def columns_watched(self) -> bool:
        """Whether anyone subscribes to P/state_columns now."""
        return self._watched(self._columns_pub, self._columns_watch)

    # -- puts ----------------------------------------------------------------------
    def publish_state(self, mover_id: int, packed_state: bytes) -> None:
        """A mover's State (given packed) on its key, framed as `{"v", "state"}`."""
        if not self.publish_states or not self._open:
            return
        key = self._state_keys.get(mover_id)
        if key is None:  # parsing (or declaring) the key expression costs more than the put itself
            if len(self._state_keys) >= _KEY_CACHE:
                self._state_keys.clear()
            text = self.keys.state(mover_id)
            rk = self.route_keys
            key = self._state_keys[mover_id] = zenoh.KeyExpr(text) if rk is None else rk.key_expr(text)
        self.session.put(key, state_message(packed_state))

    def forget_mover(self, mover_id: int) -> None:
        """The mover left: its State key and error key are let go (undeclared, when they were declared).
        Asked of the route keys themselves: the parsed-key cache may have been emptied since the declaration."""
        self._state_keys.pop(mover_id, None)
        if self.route_keys is not None:
            self.route_keys.forget(self.keys.state(mover_id))
            self.route_keys.forget(self.keys.obj_error(mover_id))

    def publish_batch(self, packed_states: list[bytes]) -> None:
        """One request's States as one message on P/states."""
        pub = self._batch_pub
        if pub is not None:
            pub.put(states_message(packed_states))

    def publish_columns(self, message: bytes) -> None:
        """A columnar publication (a whole message) on P/state_columns."""
        pub = self._columns_pub
        if pub is not None:
            pub.put(message)

    def publish_error(self, mover_id: int | None, error: dict[str, Any], held: bool = False) -> None:
        """An error on the mover's error key, or on P/errors when no mover is known; logged either way.

        A mover's error is put only while someone subscribes to an error key, as for the States. Why: a put
        on an undeclared `P/obj/<id>/...` key costs time in proportion to the keys declared beside it (about
        0.2 µs each: service/bus/route_keys.py), so a push of many failing moves among thousands of held
        movers would hold the engine thread for seconds, for nobody. `held` (the mover is this instance's:
        only the engine thread, which alone lets movers go, may say so) declares the key at its first error
        and keeps it while the mover stays, so a held mover's later errors take the cached route. An
        unknown id's key is declared for its put alone (`_put_once`): ids are the sender's to choose, and
        each kept key would stay. On direct callbacks (no route keys) nothing is declared: the node's busy
        errors are published from Zenoh's own threads there."""
        key = self.keys.errors if mover_id is None else self.keys.obj_error(mover_id)
        detail = error.get("error")
        if isinstance(detail, dict):  # a pushed move's error: answered here, so logged (rate-limited)
            ERRORS.error(str(detail.get("kind")), "push", key, str(detail.get("message")), id=mover_id)
        if mover_id is None:
            self.put(key, error)
            return
        if not self.errors_watched():
            return
        payload, rk = pack(error), self.route_keys
        if rk is None:  # direct callbacks: nothing is declared from Zenoh's own threads
            self.session.put(key, payload)
            return
        kx = rk.key_expr(key) if held else rk.declared.get(key)
        if kx is not None:
            self.session.put(kx, payload)
        else:
            self._put_once(key, payload)

    def _put_once(self, key: str, payload: bytes) -> None:
        """A put on a key declared for it alone. Why: Zenoh walks the keys declared beside a key once when
        it is declared, but at every put when it is not, and from about a hundred declared keys on, declaring,
        putting and undeclaring cost about 2.5 times less than the undeclared put (scratch, 2026-12-07: 72
        against 184 µs among 1,600 declared keys); below that the two cost about the same (7 µs with none)."""
        try:
            kx = self.session.declare_keyexpr(key)
        except Exception:  # the session closing: put on the text, as any key
            self.session.put(key, payload)
            return
        try:
            self.session.put(kx, payload)
        finally:
            try:
                self.session.undeclare(kx)
            except Exception:  # already gone with the session
                pass

    def forward_push(self, lb: int, item: dict[str, Any], publish_batch: bool = False) -> None:
        """A fire-and-forget move on `lb`'s push key (with `"publish": "batch"` when it came so)."""
        self.put(self.keys.push(lb), {"move": item, "publish": "batch"} if publish_batch else {"move": item})

    def forward_columns(self, lb: int, message: bytes) -> None:
        """A column push (a whole message) on `lb`'s push key."""
        if self._open:
            self.session.put(self.keys.push(lb), message)

    def put(self, key: str, content: dict[str, Any]) -> None:
        """Any map, packed, on `key`."""
        if self._open:
            self.session.put(key, pack(content))

    # -- hand-over -----------------------------------------------------------------
    def handover(self, lb: int, payload: dict[str, Any]) -> dict[str, Any]:
        """Ask `lb`'s owner to take a mover; its reply map, or ProtocolError. Arriving hand-overs are
        served meanwhile (two instances handing movers to each other must not wait on each other)."""
        replies: list[zenoh.Reply] = []
        done = threading.Event()

        def on_done() -> None:
            done.set()
            self._wait.wake()

        self.session.get(
            self.keys.lb(lb, "handover"),
            zenoh.handlers.Callback(replies.append, on_done),
            payload=pack(payload),
            timeout=self.handover_timeout,
        )
        self._wait.serve_until(done, time.monotonic() + self.handover_timeout + 1.0)
        for r in replies:
            if r.ok is not None:
                return dict(msgpack.unpackb(r.ok.payload.to_bytes(), raw=False))
        for r in replies:
            if r.err is None:
                continue
            raw = r.err.payload.to_bytes()
            try:
                err = msgpack.unpackb(raw, raw=False)["error"]
                raise ProtocolError(err.get("kind", ErrorKind.INTERNAL), err.get("message", ""))
            except ProtocolError:
                raise
            except Exception:
                raise ProtocolError(ErrorKind.NO_OWNER, raw.decode("utf-8", "replace")) from None
        raise ProtocolError(ErrorKind.NO_OWNER, "no instance owns that landblock")
