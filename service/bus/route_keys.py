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
each), and each new one takes longer the more keys are declared beside it: the last of 1,000 State keys
took 34 µs, of 4,096 151 µs, of 16,384 951 µs (one session alone, 2026-12-07; request keys alike).

Two kinds, two rules:
- Request keys (`learn`) are declared up to `MAX_ROUTE_KEYS`, the first ones met; later ones are served by
  matching, as before. They name landblocks and operations, a few per landblock.
- A held mover's State key (`key_expr`) is always declared, and undeclared when the mover leaves (removed or
  handed over): its memory grows with the movers, as the movers' own records do. A cap would cost more
  than it saves, because an undeclared key's put is matched against the declared keys beside it: with
  1,000 State keys declared under `P/obj`, a put on an undeclared `P/obj/<id>/...` key took 170 to 380 µs,
  with 4,096 about 1 ms, against 8 µs with none (in-process, over loopback; scratch, 2026-12-07). So a
  mover past a cap of 4,096 published each State at about 1 ms. The same holds for every other key under
  `P/obj` that is put on undeclared, a pushed move's error (`P/obj/<id>/error`) among them: that is why a
  held mover's error key is declared at its first error and an error nobody subscribes to is not put
  (service/bus/publication.py, `publish_error`).
"""

from __future__ import annotations

import logging
from typing import Any

import zenoh

__all__ = ["RouteKeys", "MAX_ROUTE_KEYS"]

log = logging.getLogger("acphys.service")

#: most request keys declared per instance (~7 MB); held movers' State keys are not counted
MAX_ROUTE_KEYS = 4096


class RouteKeys:
    """The keys declared on `session` so far: `learn(key)` (a request key, declared under the limit),
    `key_expr(key)` (a held mover's State or error key, declared whatever the count), `forget(key)` undeclaring one,
    `close()` undeclaring them all.

    Called from the callbacks' Python threads and the engine thread, never from Zenoh's own network
    thread (direct callbacks): that would be Zenoh's thread calling back into its session, which
    zenoh-python does not promise to allow."""

    __slots__ = ("session", "limit", "declared", "requests")

    def __init__(self, session: Any, limit: int = MAX_ROUTE_KEYS) -> None:
        self.session = session
        self.limit = limit  # of request keys
        self.declared: dict[str, Any] = {}  # key -> Zenoh's declared KeyExpr
        self.requests = 0  # request keys declared

    def learn(self, key: str) -> None:
        """Declare `key` (a literal key a request came on), once, while under the limit."""
        if key not in self.declared and self.requests < self.limit and self._declare(key) is not None:
            self.requests += 1

    def key_expr(self, key: str) -> Any:
        """The key to put a held mover's State or error on: declared (now, if new), else (the declaration refused: the
        session closing) parsed as any key is."""
        kx = self.declared.get(key)
        if kx is None:
            kx = self._declare(key)
        return kx if kx is not None else zenoh.KeyExpr(key)

    def forget(self, key: str) -> None:
        """Undeclare `key` (a mover's State or error key when the mover leaves)."""
        kx = self.declared.pop(key, None)
        if kx is not None:
            try:
                self.session.undeclare(kx)
            except Exception:  # already gone with the session
                pass

    def _declare(self, key: str) -> Any:
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
        self.requests = 0
