"""What a Client asks of a zenoh.Session beyond its requests, for the tests' stand-in sessions."""

from __future__ import annotations

import zenoh

__all__ = ["SessionDouble"]


class SessionDouble:
    """A stand-in session's base: keys it is asked to declare come back parsed (a real session's declared
    key is a KeyExpr too) and are recorded; the session is never closed."""

    def __init__(self) -> None:
        self.declared: list[str] = []

    def declare_keyexpr(self, key: str) -> zenoh.KeyExpr:
        self.declared.append(key)
        return zenoh.KeyExpr(key)

    def is_closed(self) -> bool:
        return False
