"""Which landblock a request key names: `<prefix>/lb/<XXYY>/<op>`, checked against the key layout and
remembered per key (docs/protocol.md, "Key expressions").

A mover's requests come on the same key again and again, so a key is read once: the node asks for each
query's and each push's landblock before it decodes anything (service/bus/node.py).
"""

from __future__ import annotations

from collections.abc import Callable

from service.protocol.errors import ProtocolError
from service.protocol.wire import ErrorKind, Keys, parse_lb_hex

__all__ = ["KeyLandblocks"]

#: Most request keys kept with their landblock read (a few MB at most; past it the cache starts again).
_LB_KEY_CACHE = 65536


class KeyLandblocks:
    """The landblocks of the request keys under one prefix, each key read once."""

    def __init__(self, keys: Keys) -> None:
        self.keys = keys
        self._key_lbs: dict[str, int | None] = {}  # request keys already checked: their landblock
        #: told each new key that names one landblock (service/bus/route_keys.py declares it on the session)
        self.learned: Callable[[str], None] | None = None

    def landblock(self, key: str, op: str) -> int | None:
        """The landblock of `<prefix>/lb/<XXYY>/<op>`; None for a wildcard where the op needs none.
        A key read once is remembered: a mover's requests come on the same key again and again.
        ProtocolError (`bad_value`) for a key that names another operation, none, or no landblock."""
        try:
            return self._key_lbs[key]
        except KeyError:
            pass
        lb = self._read(key, op)
        if lb is not None and self.learned is not None:
            self.learned(key)
        if len(self._key_lbs) >= _LB_KEY_CACHE:
            self._key_lbs.clear()
        self._key_lbs[key] = lb
        return lb

    def _read(self, key: str, op: str) -> int | None:
        part = key.rsplit("/", 2)[-2]
        if key != self.keys.lb(part, op):
            # one request, one operation: `P/lb/XXYY/*` would reach every operation's handler at once. And
            # Zenoh's access control matches a query's key by inclusion, so a wildcard query is not caught by
            # the rule on `P/lb/*/handover`: a hand-over also needs a literal landblock (below)
            raise ProtocolError(ErrorKind.BAD_VALUE, f"key {key!r}: the operation must be named: {self.keys.lb('XXYY', op)}")
        try:
            return parse_lb_hex(part)
        except ValueError:
            if op not in ("load", "unload", "handover") and ("*" in part or "$" in part):
                return None  # e.g. a `get` sent to every instance to find a mover
            raise ProtocolError(ErrorKind.BAD_VALUE, f"key {key!r}: {part!r} is not a landblock id (XXYY)") from None
