"""ProtocolError: a request the service refuses, with the reason spelled out."""

from __future__ import annotations

from typing import Any

__all__ = ["ProtocolError"]


class ProtocolError(Exception):
    """Raised while decoding or serving a request; becomes an error reply.

    `kind` is one of `wire.ErrorKind`; `path` names the offending field
    ("moves[3].to.origin[2]") when there is one; `extra` carries additional
    fields of the error map (e.g. `landblock` for `moved`).
    """

    def __init__(self, kind: str, message: str, path: str | None = None, **extra: Any) -> None:
        super().__init__(message)
        self.kind = kind
        self.message = message
        self.path = path
        self.extra = extra

    def to_wire(self) -> dict[str, Any]:
        err: dict[str, Any] = {"kind": self.kind, "message": self.message}
        if self.path is not None:
            err["path"] = self.path
        err.update(self.extra)
        return err

    def at(self, prefix: str) -> ProtocolError:
        """The same error with its path nested under `prefix`."""
        if self.path is None:
            path = prefix
        elif self.path.startswith("["):
            path = prefix + self.path
        else:
            path = f"{prefix}.{self.path}"
        return ProtocolError(self.kind, self.message, path, **self.extra)
