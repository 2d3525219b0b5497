"""Subscriptions in the client library: Client.subscribe, subscribe_batches and subscribe_errors, and the
`Subscription` they return (docs/protocol.md, "State", "Errors").

The service publishes a mover's States on its state key (or a request's States together on `P/states`,
with `publish="batch"`) and the errors of fire-and-forget moves on the error keys; a subscription calls
its callback with each, decoded, on a Zenoh thread. Every State received also tells the client which
landblock its mover is in, for routing that mover's next request.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import zenoh

from service.protocol.wire import Keys

from clients.errors import ServiceError
from clients.request_channel import unpack_message
from clients.types import MoverState

__all__ = ["Subscription", "SubscriptionCalls"]

log = logging.getLogger("acphys.client")


class Subscription:
    """A live subscription, as `Client.subscribe`, `subscribe_batches` and `subscribe_errors` return it.

    Its callback keeps being called (on a Zenoh thread) until `close()`, or the end of a `with` block:

        with client.subscribe(print, mover_id):
            client.move(mover_id, offset=(1, 0, 0))
    """

    def __init__(self, subscribers: list[Any]) -> None:
        self._subs = subscribers

    def close(self) -> None:
        """Stop the callbacks (undeclare the Zenoh subscribers). Safe to call twice, and after the client
        closed; raises nothing."""
        for s in self._subs:
            try:
                s.undeclare()
            except Exception:  # the session may already be closed
                pass
        self._subs = []

    def __enter__(self) -> Subscription:
        return self

    def __exit__(self, *_: object) -> None:
        self.close()


class SubscriptionCalls:
    """The subscriptions, mixed into `Client` (which gives them its session and keys, and learns each
    mover's landblock from the States received): call them on a Client."""

    session: zenoh.Session
    keys: Keys
    _learn: Callable[[MoverState], MoverState]

    def subscribe(self, callback: Callable[[MoverState], None], mover_id: int | None = None) -> Subscription:
        """Call `callback` with every State published for `mover_id` (or for every mover, when None).

        The service publishes a State after every resolved move (request-reply and fire-and-forget,
        with the default `publish`) and register, in `seq` order per mover. The callback runs on a
        Zenoh thread: keep it short, and hand the State to your own thread (a queue) for real work. A
        subscription receives what is published after its declaration reached the service, which takes
        a moment; a gap in a mover's `seq` means a State was missed. Returns the `Subscription`:
        `close()` it, or use it in a `with` block. Unreadable messages are logged and skipped."""
        key = self.keys.state(mover_id if mover_id is not None else "*")

        def on_sample(sample: zenoh.Sample) -> None:
            try:
                st = MoverState.from_wire(unpack_message(sample.payload.to_bytes())["state"])
            except Exception:
                log.warning("unreadable state on %s", sample.key_expr)
                return
            self._learn(st)
            callback(st)

        return Subscription([self.session.declare_subscriber(key, on_sample)])

    def subscribe_batches(self, callback: Callable[[list[MoverState]], None]) -> Subscription:
        """Call `callback` with the States of every request sent with `publish="batch"`, one list per
        request (in the request's order; failed moves have none), on a Zenoh thread. Returns the
        `Subscription`."""

        def on_sample(sample: zenoh.Sample) -> None:
            try:
                states = [MoverState.from_wire(m) for m in unpack_message(sample.payload.to_bytes())["states"]]
            except Exception:
                log.warning("unreadable states on %s", sample.key_expr)
                return
            for st in states:
                self._learn(st)
            callback(states)

        return Subscription([self.session.declare_subscriber(self.keys.states, on_sample)])

    def subscribe_errors(self, callback: Callable[[int | None, ServiceError], None],
                         mover_id: int | None = None) -> Subscription:
        """Errors of fire-and-forget moves (`push`): `callback(mover_id or None, error)` with the error as
        a ServiceError, on a Zenoh thread. With `mover_id`, that mover's errors; without, every mover's
        and those no mover can be named for (a push that could not be read). As for States, a
        subscription receives the errors of pushes that come after its declaration reached the service
        (the service puts a mover's error only while someone subscribes to an error key). Returns the
        `Subscription`."""

        def on_sample(sample: zenoh.Sample) -> None:
            try:
                msg = unpack_message(sample.payload.to_bytes())
                callback(msg.get("id"), ServiceError.from_wire(msg["error"]))
            except Exception:
                log.warning("unreadable error message on %s", sample.key_expr)

        subs = [self.session.declare_subscriber(self.keys.obj_error(mover_id if mover_id is not None else "*"), on_sample)]
        if mover_id is None:
            subs.append(self.session.declare_subscriber(self.keys.errors, on_sample))
        return Subscription(subs)
