"""service/bus/lb_queryable.py: one queryable on `P/lb/<part>/*` hands each query to its operation's handler,
and a query naming no operation to every operation its key meets, ending it once the last has answered."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

from service.bus.lb_queryable import landblock_queryable

P = "acphys"
OPS = ("move", "get", "remove", "place", "path")


class Query:
    """A zenoh.Query stand-in: its key, the replies it got and when it was ended (dropped)."""

    def __init__(self, key: str) -> None:
        self.key_expr = key
        self.payload = b""
        self.errs: list[bytes] = []
        self.drops = 0
        self.errs_when_dropped: int | None = None

    def reply(self, _key: Any, payload: bytes) -> None:
        raise AssertionError("no handler here answers ok")

    def reply_err(self, payload: bytes) -> None:
        assert self.drops == 0, "a reply after the query ended is lost"
        self.errs.append(payload)

    def drop(self) -> None:
        self.drops += 1
        self.errs_when_dropped = len(self.errs)


def dispatcher(calls: list[tuple[str, str]], *, later: str | None = None,
               threads: list[threading.Thread] | None = None) -> Callable[[Any], None]:
    """Handlers that record (op, key) and refuse at once; `later`'s refuses from another thread."""
    def handler_of(op: str) -> Any:
        def handler(query: Any, _key_expr: Any, key: str) -> None:
            calls.append((op, key))

            def answer() -> None:
                query.reply_err(op.encode())
                query.drop()

            if op == later and threads is not None:
                threads.append(threading.Thread(target=answer))
                return
            answer()
        return handler

    return landblock_queryable({op: handler_of(op) for op in OPS}, {op: f"{P}/lb/A9B4/{op}" for op in OPS})


def test_a_key_naming_an_operation_goes_to_that_handler_alone() -> None:
    calls: list[tuple[str, str]] = []
    q = Query(f"{P}/lb/A9B4/get")
    dispatcher(calls)(q)
    assert calls == [("get", f"{P}/lb/A9B4/get")]
    assert q.errs == [b"get"] and q.drops == 1


def test_a_wildcard_operation_goes_to_every_handler_and_ends_once() -> None:
    calls: list[tuple[str, str]] = []
    q = Query(f"{P}/lb/A9B4/*")
    dispatcher(calls)(q)
    assert sorted(op for op, _ in calls) == sorted(OPS)
    assert sorted(q.errs) == sorted(op.encode() for op in OPS)
    assert q.drops == 1 and q.errs_when_dropped == len(OPS)


def test_a_chunk_wildcard_goes_to_the_operations_it_meets() -> None:
    calls: list[tuple[str, str]] = []
    dispatcher(calls)(Query(f"{P}/lb/A9B4/$*e"))  # move, remove, place: not get, not path
    assert sorted(op for op, _ in calls) == ["move", "place", "remove"]


def test_a_key_meeting_no_operation_is_ended_without_a_reply() -> None:
    calls: list[tuple[str, str]] = []
    for op in ("push", "handover"):
        q = Query(f"{P}/lb/A9B4/{op}")
        dispatcher(calls)(q)
        assert q.errs == [] and q.drops == 1
    assert calls == []


def test_the_query_ends_only_when_its_last_handler_has_answered() -> None:
    """One operation answering later, from another thread (a queued job): the query stays open for it."""
    calls: list[tuple[str, str]] = []
    threads: list[threading.Thread] = []
    q = Query(f"{P}/lb/**")
    dispatcher(calls, later="path", threads=threads)(q)
    assert q.drops == 0 and len(q.errs) == len(OPS) - 1
    (t,) = threads
    t.start()
    t.join(5.0)
    assert q.drops == 1 and q.errs_when_dropped == len(OPS)
