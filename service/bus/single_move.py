"""One move (`{"v": 1, "move": Move}` on `P/lb/XXYY/move`): the service's most common request, run straight
to its reply.

The node (service/bus/node.py) reads the request (service/protocol/move_structs.py's `plain_single_move`
from the payload's bytes, else the request map's path) and hands the MoveItem here. It runs in the
callback when the engine is idle and nothing is queued (the node's rule for a small request), else it is
queued; either way the same engine call, errors and reply as any move request's, without the closures
and the operation table a request of another kind goes through.
"""

from __future__ import annotations

import logging
from functools import partial
from typing import TYPE_CHECKING

import zenoh

from service.protocol.errors import ProtocolError
from service.protocol.frames import STATE_HEAD
from service.protocol.messages import MoveItem
from service.protocol.wire import ErrorKind

if TYPE_CHECKING:
    from service.bus.node import ServiceNode

__all__ = ["submit_single", "run_single"]

log = logging.getLogger("acphys.service")


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
        packed = core.move_one(item, received, False if later else None, batch_mode)
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
