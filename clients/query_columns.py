"""The column form of the spatial queries, client side: numpy arrays in, numpy arrays out.

`Client.sight_columns` / `ray_columns` / `ground_columns` / `place_columns`
(clients/spatial.py) pack their arguments into the request columns declared
in service/protocol/queries.py, send one column request per landblock (the
landblock of each query's start), and put the reply columns back together
in the order asked as a `QueryColumnResults`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from service.protocol.columns import pack_columns, unpack_column
from service.protocol import BLOCKER_CODES, NO_CODE, PLACEMENT_CODES, QUERY_COLUMNS
from service.protocol.wire import ErrorKind

from clients.batch import _reindexed, column_rows
from clients.errors import AcphysError, ServiceError

if TYPE_CHECKING:
    from collections.abc import Callable

__all__ = ["QueryColumnResults", "query_columns"]

Array = np.ndarray[Any, Any]


@dataclass(slots=True)
class QueryColumnResults:
    """The answers of a column query, one row per query in the order given: `columns` by name
    (docs/protocol.md, "Query columns", for every column's meaning and missing value). A failed
    query's row holds the missing values and its error is in `errors`, by index.

    `op` is the query ("sight", "ray", "ground" or "place"); `columns` its answer columns, numpy arrays of
    one row per query: cell ids as uint32 (0xXXYYIIII), positions and distances in landblock-local metres
    (float64; NaN when missing), planes as normal x y z then d, `flags` bits read by `flag`, codes read by
    `blocker_kind` and `placement_result`.

        cols = client.ground_columns(cells, origins)
        cols["z"][cols.flag("found")]
    """

    op: str
    columns: dict[str, Array]
    errors: dict[int, AcphysError] = field(default_factory=dict)

    @classmethod
    def empty(cls, op: str, n: int) -> QueryColumnResults:
        """Answers of `n` queries of `op` that all hold the missing values, with no errors."""
        return cls(op, {col.name: col.missing_rows(n) for col in QUERY_COLUMNS[op].reply})

    def __len__(self) -> int:
        """The number of queries (rows)."""
        return len(self.columns["flags"])

    def __getitem__(self, name: str) -> Array:
        """The answer column `name` (e.g. "z", "stop", "distance"); KeyError for a name the op has not."""
        return self.columns[name]

    def flag(self, name: str) -> Array:
        """The `flags` bit `name` of every row, as booleans (e.g. "resolved", "clear", "hit", "found",
        "walkable", "ok"; docs/protocol.md, "Query columns", lists each op's bits). ValueError for a bit
        the op has not."""
        return (self.columns["flags"] & QUERY_COLUMNS[self.op].bit(name)) != 0

    def blocker_kind(self, i: int) -> str | None:
        """What stopped sight or ray `i`: "terrain", "cell", "building" or "object"; None when nothing did
        (or the query failed)."""
        code = int(self.columns["blocker"][i])
        return None if code == NO_CODE else BLOCKER_CODES[code]

    def placement_result(self, i: int) -> str | None:
        """Place query `i`'s outcome: "OK", "NoValidPosition" or "NoCell(lost)"; None when it failed."""
        code = int(self.columns["placement_result"][i])
        return None if code == NO_CODE else PLACEMENT_CODES[code]


def _rows(op: str, name: str, value: Any, n: int) -> Array:
    """An argument as its request column: (n,) or (n, width); a scalar is repeated for every row."""
    return column_rows(QUERY_COLUMNS[op].request_column(name), value, n)


def _read_reply(op: str, reply: dict[str, Any], m: int) -> tuple[dict[str, Array], list[Any]]:
    cols_raw, errors = reply.get("columns"), reply.get("errors")
    if reply.get("n") != m or not isinstance(cols_raw, dict) or not isinstance(errors, list):
        raise ServiceError(ErrorKind.MALFORMED, "column reply does not match the request")
    try:
        return {c.name: unpack_column(c, cols_raw[c.name], m) for c in QUERY_COLUMNS[op].reply}, errors
    except (KeyError, ValueError, TypeError) as e:
        raise ServiceError(ErrorKind.MALFORMED, f"unreadable column reply: {e}") from None


def query_columns(request: Callable[[int, dict[str, Any]], dict[str, Any]], op: str, named: dict[str, Any],
                  options: dict[str, Any] | None = None) -> QueryColumnResults:
    """Send the queries `named` (column name -> array; None: not given) as column requests of `op`,
    one per landblock of the start cell, via `request(lb, body)`; their answers in the order given."""
    spec = QUERY_COLUMNS[op]
    first = np.asarray(named[spec.count], dtype=np.uint32).reshape(-1)
    n = len(first)
    arrays = {name: _rows(op, name, v, n) for name, v in named.items() if v is not None}
    for col in spec.request:
        if op in col.required and col.name not in arrays:
            raise ValueError(f"{col.name} is required")
    out = QueryColumnResults.empty(op, n)
    lbs = (first >> 16) & 0xFFFF
    for lb in np.unique(lbs).tolist():
        idx = np.flatnonzero(lbs == lb)
        body: dict[str, Any] = {"columns": pack_columns(spec.request, {k: a[idx] for k, a in arrays.items()})}
        body.update(options or {})
        try:
            cols, errors = _read_reply(op, request(int(lb), body), len(idx))
        except AcphysError as e:
            for i in idx.tolist():
                out.errors[i] = e
            continue
        for name, a in cols.items():
            out.columns[name][idx] = a
        for entry in errors:
            j = entry.get("index") if isinstance(entry, dict) else None
            if type(j) is int and 0 <= j < len(idx):
                i = int(idx[j])
                out.errors[i] = _reindexed(ServiceError.from_wire(entry.get("error")), j, i)
    return out
