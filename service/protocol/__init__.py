"""The wire's vocabulary, one declaration per message, and its readers and writers; no I/O.

Today it holds the list of operations and the queries on `P/lb/XXYY/<op>` (sight, ray, ground, place, path: `QUERIES`), in their
map, batch and column forms. The service reads requests and writes answers with it; the client library
writes requests and reads answers with it; the test of docs/protocol.md's tables reads it. Moves,
movers and the other messages are declared in service/messages.py and service/columns.py still.
"""

from __future__ import annotations

from .queries import (
    BATCH_FIELDS,
    BLOCKER_CODES,
    MAX_PATH_BATCH,
    MAX_PATH_BUDGET,
    NO_CODE,
    PLACEMENT_CODES,
    PLACEMENT_MODES,
    QUERIES,
    QUERY_COLUMNS,
    QUERY_FORMS,
    QUERY_OPS,
    REASON_CODES,
    QueryColumns,
    QueryKind,
)
from .operations import LB_OPS, MOVER_OPS, REQUEST_OPS
from .readers import Item, count_items, read_answer, read_item, read_options, read_request
from .writers import write_answer, write_query

__all__ = [
    "MOVER_OPS", "LB_OPS", "REQUEST_OPS", "QUERIES", "QUERY_OPS", "BATCH_FIELDS", "QUERY_COLUMNS", "QUERY_FORMS", "QueryKind", "QueryColumns",
    "BLOCKER_CODES", "PLACEMENT_CODES", "REASON_CODES", "NO_CODE", "PLACEMENT_MODES", "MAX_PATH_BATCH",
    "MAX_PATH_BUDGET", "Item", "read_request", "read_item", "read_options", "read_answer", "count_items",
    "write_answer", "write_query",
]
