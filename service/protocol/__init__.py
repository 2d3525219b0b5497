"""The wire's vocabulary: every message declared once, its readers and writers; no I/O.

The queries on `P/lb/XXYY/<op>` (sight, ray, ground, place, path: `QUERIES`) in their map, batch and
column forms are declared in queries.py, the operation lists in operations.py; the moves and mover
messages in messages.py (map form) and columns.py (column form); wire.py holds keys, limits and the
error kinds. The service reads requests and writes answers with it, the client library writes requests
and reads answers with it, and the test of docs/protocol.md's tables reads it.
"""

from __future__ import annotations

from service.protocol.queries import (
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
from service.protocol.operations import LB_OPS, MOVER_OPS, REQUEST_OPS
from service.protocol.readers import Item, count_items, read_answer, read_item, read_options, read_request
from service.protocol.writers import write_answer, write_query

__all__ = [
    "MOVER_OPS", "LB_OPS", "REQUEST_OPS", "QUERIES", "QUERY_OPS", "BATCH_FIELDS", "QUERY_COLUMNS", "QUERY_FORMS", "QueryKind", "QueryColumns",
    "BLOCKER_CODES", "PLACEMENT_CODES", "REASON_CODES", "NO_CODE", "PLACEMENT_MODES", "MAX_PATH_BATCH",
    "MAX_PATH_BUDGET", "Item", "read_request", "read_item", "read_options", "read_answer", "count_items",
    "write_answer", "write_query",
]
