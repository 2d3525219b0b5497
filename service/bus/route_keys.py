"""The literal keys an instance is asked on and publishes to, declared on its session so that Zenoh keeps
their routes.

Why: Zenoh caches a message's route on the resource its key names, and a key nobody declared has no
resource: each query or put on it is matched against every declaration again.
- The service's queryables are declared with a wildcard chunk (`P/lb/*/move`, docs/protocol.md, "Key
  expressions"), and a query names one landblock (`P/lb/A9B4/move`). Declaring the key the first time a
  query comes on it (`Session.declare_keyexpr`) lets a mover's later requests take the cached route: in
  one node's process, 10-20 µs less per one-move round trip on this machine.
- A State is put on its mover's own key (`P/obj/<id>/state`). Declared, a put costs about 1.3 µs;
  undeclared, 40-48 µs (a put loop to one subscriber process over loopback, 0 and 50 other subscriptions).

Nothing on the wire changes: a declared key expression is a mapping between this session and its own
routing tables. A declaration is not free: 4,096 of them raised a process's RSS by 7.4 MB (about 1.8 KB
each), and each new one takes longer the more there are (10 µs with a thousand, 13 µs with four
thousand, 41 µs with sixteen thousand: Zenoh looks its name up among the session's). So at most
`MAX_ROUTE_KEYS` keys are declared, the first ones met; keys past that are served as before, by
matching. A mover's State key is undeclared when the mover leaves the instance (removed or handed
over); an instance with more movers than that publishes the States of the others on parsed keys.
"""

from __future__ import annotations

import logging
from typing import Any

import zenoh

__all__ = ["RouteKeys", "MAX_ROUTE_KEYS"]

log = logging.getLogger("acphys.service")

#: most literal keys declared per instance (request keys and State keys together): at most ~7 MB
MAX_ROUTE_KEYS = 4096


class RouteKeys:
    """The keys declared on `session` so far: `key_expr(key)` (declaring a new one), `learn(key)` (the same,
    for a key only received on), `forget(key)` undeclaring one, `close()` undeclaring them all.

    Called from the callbacks' Python threads and the engine thread, never from Zenoh's own network
    thread (direct callbacks): that would be Zenoh's thread calling back into its session, which
    zenoh-python does not promise to allow."""

    __slots__ = ("session", "limit", "declared")

    def __init__(self, session: Any, limit: int = MAX_ROUTE_KEYS) -> None:
        self.session = session
        self.limit = limit
        self.declared: dict[str, Any] = {}  # key -> Zenoh's declared KeyExpr

    def learn(self, key: str) -> None:
        """Declare `key` (a literal key a request came on), once, while under the limit."""
        if key not in self.declared:
            self._declare(key)

    def key_expr(self, key: str) -> Any:
        """The key to put on: declared (now, if new and under the limit), else parsed as any key is."""
        kx = self.declared.get(key)
        if kx is None:
            kx = self._declare(key)
        return kx if kx is not None else zenoh.KeyExpr(key)

    def forget(self, key: str) -> None:
        """Undeclare `key` (a mover's State key when the mover leaves), freeing its place under the limit."""
        kx = self.declared.pop(key, None)
        if kx is not None:
            try:
                self.session.undeclare(kx)
            except Exception:  # already gone with the session
                pass

    def _declare(self, key: str) -> Any:
        if len(self.declared) >= self.limit:
            return None
        try:
            kx = self.declared[key] = self.session.declare_keyexpr(key)
        except Exception as e:  # the session closing: the key is served by matching, as before
            log.debug("declaring %s failed: %s", key, e)
            return None
        return kx

    def close(self) -> None:
        """Undeclare every key (before the session closes, or when a tenant leaves its host's session)."""
        for kx in self.declared.values():
            try:
                self.session.undeclare(kx)
            except Exception:  # already gone with the session
                pass
        self.declared.clear()
