"""The literal request keys this instance has been asked on, declared on its session so that Zenoh keeps
their query routes.

Why: the service's queryables are declared with a wildcard chunk (`P/lb/*/move`, docs/protocol.md, "Key
expressions"), and a query names one landblock (`P/lb/A9B4/move`). Zenoh caches a query's route on the
resource its key names; a key nobody declared has no resource, so Zenoh matches it against every
declaration again at each query. Declaring the key once (`Session.declare_keyexpr`) gives it that resource:
a mover's later requests on the same key take the cached route. Measured on the service benchmark's
node, a one-move round trip 10-20 µs shorter (docs/performance.md, "One move's round trip").

Nothing on the wire changes: a declared key expression is a mapping between this session and its own
routing tables. At most `MAX_ROUTE_KEYS` keys are declared (each is a resource in Zenoh's tables): keys
past that are served as before, by matching.
"""

from __future__ import annotations

import logging
from typing import Any

__all__ = ["RouteKeys", "MAX_ROUTE_KEYS"]

log = logging.getLogger("acphys.service")

#: most literal request keys declared per instance (a few MB of Zenoh's tables at most)
MAX_ROUTE_KEYS = 4096


class RouteKeys:
    """The keys declared on `session` so far; `learn(key)` declares a new one, `close()` undeclares them all."""

    __slots__ = ("session", "limit", "declared")

    def __init__(self, session: Any, limit: int = MAX_ROUTE_KEYS) -> None:
        self.session = session
        self.limit = limit
        self.declared: dict[str, Any] = {}  # key -> Zenoh's declared KeyExpr

    def learn(self, key: str) -> None:
        """Declare `key` (a literal request key this instance was asked on), once, while under the limit."""
        if key in self.declared or len(self.declared) >= self.limit:
            return
        try:
            self.declared[key] = self.session.declare_keyexpr(key)
        except Exception as e:  # the session closing: the key is served by matching, as before
            log.debug("declaring %s failed: %s", key, e)

    def close(self) -> None:
        """Undeclare every key (before the session closes, or when a tenant leaves its host's session)."""
        for kx in self.declared.values():
            try:
                self.session.undeclare(kx)
            except Exception:  # already gone with the session
                pass
        self.declared.clear()
