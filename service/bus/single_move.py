"""One move (`{"v": 1, "move": Move}` on `P/lb/XXYY/move`): the service's most common request, run straight
to its reply.

`move_handler` is the `move` operation's query handler (service/bus/node.py hands it every query on a move
key). A plain request (service/protocol/move_structs.py's `plain_single_move`, read from the payload's bytes)
on a landblock key, with the per-request log off, goes the short way: checked, counted and, when the engine
is idle and nothing is queued, run in the callback (the node's rule for a small request), else queued.
Anything else (a request of more than one move, a fault to name, a key to refuse, the log on) goes to the
node's general handler, which answers it as any request, a single move included (`submit_single`). Either
way the same engine call, errors and reply, without the closures and the operation table a request of
another kind goes through.

Why a short way at all: in a round trip the callback runs after an idle gap (the asking process waits for the
reply, then sends the next), and after one every step costs several times what it costs back to back
(benchmarks/bench_service.py, `handling`: 6 to 8 times on this project's 2-core machine). Each check the
general handler makes for every operation is such a step.
"""

from __future__ import annotations

import logging
from functools import partial
from time import monotonic
from typing import TYPE_CHECKING

import zenoh

from service.bus.lb_queryable import QueryHandler
from service.bus.request_log import requests_logged
from service.protocol.errors import ProtocolError
from service.protocol.frames import STATE_HEAD
from service.protocol.messages import MoveItem
from service.protocol.move_structs import plain_single_move
from service.protocol.wire import MAX_PAYLOAD, ErrorKind

if TYPE_CHECKING:
    from service.bus.node import ServiceNode

__all__ = ["move_handler", "submit_single", "run_single"]

log = logging.getLogger("acphys.service")


def move_handler(node: ServiceNode, general: QueryHandler) -> QueryHandler:
    """The `move` operation's handler on `node`: a plain single move the short way, anything else `general`'s
    (the node's handler of every operation, which counts, checks and answers it itself)."""
    stats = node.stats
    key_landblock = node._key_lbs.landblock

    def handler(query: zenoh.Query, key_expr: zenoh.KeyExpr, key: str) -> None:
        received = monotonic()  # as the general handler stamps a request: before it is read
        if requests_logged():  # the DEBUG line wraps the query: the general handler's
            general(query, key_expr, key)
            return
        payload = query.payload
        if payload is None or len(payload) > MAX_PAYLOAD:  # refused by its length before it is copied
            general(query, key_expr, key)
            return
        data = payload.to_bytes()
        plain = plain_single_move(data) if data else None
        if plain is None:
            general(query, key_expr, key)
            return
        try:
            key_landblock(key, "move")
        except ProtocolError:  # named by the general handler, in its order of checks
            general(query, key_expr, key)
            return
        node._last_arrival = received
        stats.request("move")
        submit_single(node, query, key_expr, plain[0], plain[1], received)

    return handler


def submit_single(node: ServiceNode, query: zenoh.Query, key_expr: zenoh.KeyExpr, item: MoveItem, batch_mode: bool,
                  received: float) -> None:
    """Run the move now when the engine is idle and nothing is queued (the engine lock held), else queue
    it; `busy` or `shutting_down` when the queue refuses it. `ServiceNode._submit` for this one job, with
    its checks read as plain attributes and no closure when it runs at once."""
    queue, lock = node.queue, node._engine_lock
    if node._inline and not queue.unfinished and not queue.closed and lock.acquire(blocking=False):
        try:
            if not queue.unfinished:  # nothing was queued meanwhile: nothing to overtake
                try:
                    run_single(node, query, key_expr, item, batch_mode, received)
                except Exception:  # never let it reach zenoh's thread
                    log.exception("engine job failed")
                    node.stats.error(ErrorKind.INTERNAL)
                return
        finally:
            lock.release()
    if not queue.offer(partial(run_single, node, query, key_expr, item, batch_mode, received), node._lane):
        node._refuse(query)


def run_single(node: ServiceNode, query: zenoh.Query, key_expr: zenoh.KeyExpr, item: MoveItem, batch_mode: bool,
               received: float) -> None:
    """The move applied (the engine lock held) and answered on `key_expr` (the query's, read once by the
    caller): its State, or its error."""
    core = node.core
    assert core is not None
    # Its State is published after the reply when it may be: asking Zenoh whether anyone subscribes reads its
    # routing tables and lets go of the GIL, a few µs of every round trip otherwise. Still under the engine
    # lock, so a mover's States keep their seq order.
    later = not batch_mode and core.publishes_after_reply
    try:
        packed = core.move_single(item, received) if later else core.move_one(item, received, None, batch_mode)
    except ProtocolError as e:
        node._reply_err(query, e)
        return
    except Exception as e:
        log.exception("move failed")
        node._reply_err(query, ProtocolError(ErrorKind.INTERNAL, "internal error (a fault in the service, logged "
                                            f"there): {str(e) or 'no message'}"))
        return
    try:
        query.reply(key_expr, STATE_HEAD + packed)  # frames.state_message, inlined
    finally:
        query.drop()
    if later:
        core.publish_if_watched(item.id, packed)
