"""One queryable per landblock key part, `P/lb/<part>/*`, handing each query to its operation's handler.

Why one and not one per operation: a Zenoh session matches every query it receives against every queryable
it declared, a key-expression intersection each, before any callback runs. With the 13 or 14 operations
declared one by one that matching was about 8,000 instructions of each request's round trip
(benchmarks/instructions_round_trip.py); one queryable per part makes it one intersection.

What a client sees is what separate queryables gave it (docs/protocol.md, "Key expressions"):
- a key whose last chunk names an operation goes to that operation's handler;
- a key whose last chunk is a wildcard (`P/lb/XXYY/*`, `P/lb/**`, `P/lb/XXYY/mo$*`) goes to every operation
  whose key it meets, and each refuses it with `bad_value`: one error reply per operation, as before;
- a key that meets no operation served here (`P/lb/XXYY/push`, or `handover` on an instance that takes
  none) gets no reply at all, as when no queryable matched it.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping
from typing import Any

import zenoh

__all__ = ["landblock_queryable", "QueryHandler"]

#: an operation's handler: the query, its key expression (read once: Zenoh makes a new one at each read) and its text
QueryHandler = Callable[[Any, Any, str], None]


def landblock_queryable(handlers: Mapping[str, QueryHandler], op_keys: Mapping[str, str]) -> Callable[[Any], None]:
    """The callback of the queryable on `P/lb/<part>/*`: each query to the handler its key's last chunk names.

    `handlers`: each operation served under this part; `op_keys`: each one's key (`P/lb/<part>/<op>`). A
    closure, not an object with `__call__`: Zenoh calls it once per request, and a plain function call is
    the cheaper (about 900 instructions a request, benchmarks/instructions_single_move.py)."""
    table = dict(handlers)
    handler_of = table.get
    keys = [(op, zenoh.KeyExpr(op_keys[op])) for op in table]

    def dispatch(query: Any) -> None:
        key_expr = query.key_expr
        key = str(key_expr)
        handler = handler_of(key[key.rfind("/") + 1:])
        if handler is not None:
            handler(query, key_expr, key)
            return
        asked = zenoh.KeyExpr(key)
        met = [op for op, op_key in keys if asked.intersects(op_key)]
        if not met:
            query.drop()  # no operation here: answered with no reply, as if no queryable matched
            return
        shared = _SharedQuery(query, len(met))
        for op in met:
            table[op](shared, key_expr, key)

    return dispatch


class _SharedQuery:
    """One query handed to several operations' handlers: each may reply, and the query ends (Zenoh's final
    reply) when the last of them drops it, as the separate queries of separate queryables each ended."""

    __slots__ = ("query", "key_expr", "_left", "_lock")

    def __init__(self, query: Any, handlers: int) -> None:
        self.query = query
        self.key_expr = query.key_expr
        self._left = handlers
        self._lock = threading.Lock()  # a handler may answer from the engine thread, the others from this one

    @property
    def payload(self) -> Any:
        return self.query.payload

    def reply(self, key: Any, payload: Any) -> None:
        self.query.reply(key, payload)

    def reply_err(self, payload: bytes) -> None:
        self.query.reply_err(payload)

    def drop(self) -> None:
        with self._lock:
            self._left -= 1
            last = self._left == 0
        if last:
            self.query.drop()
