"""Exceptions the client library raises."""

from __future__ import annotations

from typing import Any

__all__ = ["AcphysError", "ServiceError", "BusyError", "RequestTimeout", "NoServiceError"]


class AcphysError(Exception):
    """Base of every error of the client library."""


class ServiceError(AcphysError):
    """The service answered with an error (docs/protocol.md, "Errors").

    `kind` is the error's kind (`unknown_mover`, `non_finite`, ...), `path`
    the offending field when there is one, `details` the whole error map.
    """

    def __init__(self, kind: str, message: str, path: str | None = None, details: dict[str, Any] | None = None) -> None:
        super().__init__(f"{kind}: {message}")
        self.kind = kind
        self.message = message
        self.path = path
        self.details = details or {}

    @classmethod
    def from_wire(cls, err: Any) -> ServiceError:
        if not isinstance(err, dict):
            return cls("malformed", f"unreadable error reply: {err!r}")
        kind = str(err.get("kind", "internal"))
        sub = BusyError if kind == "busy" else cls
        return sub(kind, str(err.get("message", "")), err.get("path"), err)


class BusyError(ServiceError):
    """The service's queue was full; the request was not run. Retry later."""


class RequestTimeout(AcphysError, TimeoutError):
    """No answer within the timeout."""


class NoServiceError(AcphysError):
    """No service instance serves that key (none running, or none owns the landblock)."""
