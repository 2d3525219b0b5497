"""The operations of the bus, listed once: what each landblock's keys serve and what Stats counts."""

from __future__ import annotations

from typing import Final

from service.protocol.queries import QUERY_OPS

__all__ = ["MOVER_OPS", "LB_OPS", "REQUEST_OPS"]

#: the per-landblock operations on movers and on the landblock itself (`<prefix>/lb/<XXYY>/<op>`)
MOVER_OPS: Final = ("move", "register", "update", "remove", "get", "load", "unload", "handover")
#: every operation served as a queryable on a landblock's keys: those and the queries
LB_OPS: Final = MOVER_OPS + QUERY_OPS
#: every operation counted in Stats' `requests` (each listed, 0 when none came: docs/protocol.md, Stats)
REQUEST_OPS: Final = ("move", "push", *MOVER_OPS[1:], "health", "stats", "landblocks", *QUERY_OPS)
