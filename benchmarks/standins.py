"""Stand-ins for Zenoh and the engine, to time the service's and the client's own per-move work.

No package-relative imports: benchmarks/ab_service.py's children import this module by its file's
directory while the service and the client library come from another source tree.
"""

from __future__ import annotations

from typing import Any

__all__ = ["StandInQuery", "NoEngine", "StandInSession", "SilentBus"]


class _Payload:
    def __init__(self, data: bytes) -> None:
        self.data = data

    def __len__(self) -> int:  # a zenoh.ZBytes' length: the service refuses an oversized payload by it
        return len(self.data)

    def to_bytes(self) -> bytes:
        return self.data


class StandInQuery:
    """What the service's query callback uses of a zenoh.Query; counts the replies."""

    def __init__(self, key: str, payload: bytes) -> None:
        self.key_expr = key
        self.payload = _Payload(payload)
        self.replies = 0

    def reply(self, _key: Any, _payload: bytes) -> None:
        self.replies += 1

    def reply_err(self, payload: bytes) -> None:
        raise AssertionError(f"error reply: {payload!r}")

    def drop(self) -> None:
        pass


class NoEngine:
    """A World stand-in for timing the service's own handling: every move resolves to `result`."""

    def __init__(self, world: Any, result: Any) -> None:
        self._world = world
        self._result = result

    def move(self, _engine_id: int, _target: Any, _velocity: Any = None) -> Any:
        return self._result

    def __getattr__(self, name: str) -> Any:  # everything else (landblocks, cache stats) from the real world
        return getattr(self._world, name)


class _StandInReply:
    def __init__(self, payload: bytes) -> None:
        self.ok = self
        self.err = None
        self.payload = _Payload(payload)


class StandInSession:
    """What `Client.move` uses of a zenoh.Session: `get` answers with one prepared reply."""

    def __init__(self, reply: bytes) -> None:
        self._replies = [_StandInReply(reply)]

    def get(self, _key: Any, **_kwargs: Any) -> Any:
        return iter(self._replies)

    def declare_keyexpr(self, key: str) -> Any:
        import zenoh  # only when asked: this module is loaded by children that never open Zenoh

        return zenoh.KeyExpr(key)

    def is_closed(self) -> bool:
        return False


class SilentBus:
    """A bus nobody listens on: what ServiceCore needs of service.bus.publication.ZenohBus, for a core run
    without Zenoh (the kill harness's mirror, the state log's replay tests)."""

    def publish_state(self, mover_id: int, packed_state: bytes) -> None: ...
    def states_watched(self) -> bool: return False
    def batch_watched(self) -> bool: return False
    def publish_batch(self, packed_states: list[bytes]) -> None: ...
    def publish_error(self, mover_id: int | None, error: dict[str, Any], held: bool = False) -> None: ...
    def forget_mover(self, mover_id: int) -> None: ...
    def forward_push(self, lb: int, item: dict[str, Any], publish_batch: bool = False) -> None: ...
    def handover(self, lb: int, payload: dict[str, Any]) -> dict[str, Any]: raise AssertionError("no hand-over")
    def columns_watched(self) -> bool: return False
    def publish_columns(self, message: bytes) -> None: ...
    def forward_columns(self, lb: int, message: bytes) -> None: ...
