"""The core's port to the bus: what ServiceCore needs of it, so that the core runs and is tested without
Zenoh (service.bus.publication.ZenohBus is the port on a Zenoh session)."""

from __future__ import annotations

from typing import Any, Protocol

__all__ = ["BusPort"]


class BusPort(Protocol):
    """What the core needs from the bus (service.bus.publication.ZenohBus implements it)."""

    def publish_state(self, mover_id: int, packed_state: bytes) -> None:
        """Publish a State (given packed: the node frames it as `{"v", "state"}`)."""
        ...

    def states_watched(self) -> bool:
        """Whether anyone subscribes to a state key now (else publishing States can be skipped)."""
        ...

    def batch_watched(self) -> bool:
        """Whether anyone subscribes to P/states now."""
        ...

    def publish_batch(self, packed_states: list[bytes]) -> None:
        """Publish one request's States as one message on P/states."""
        ...

    def publish_error(self, mover_id: int | None, error: dict[str, Any], held: bool = False) -> None:
        """Publish a move's error on its mover's error key (P/errors when `mover_id` is None); `held`: the
        mover is this instance's (said only on the engine thread), so its key may be kept."""
        ...

    def forget_mover(self, mover_id: int) -> None:
        """The mover left this instance (removed, or handed over): what the bus keeps for its key may go."""
        ...

    def forward_push(self, lb: int, item: dict[str, Any], publish_batch: bool = False) -> None:
        """Put a fire-and-forget move on `lb`'s push key (with `"publish": "batch"` when it came so)."""
        ...

    def handover(self, lb: int, payload: dict[str, Any]) -> dict[str, Any]:
        """Send a mover to `lb`'s owner; its reply map, or ProtocolError."""
        ...

    def columns_watched(self) -> bool:
        """Whether anyone subscribes to P/state_columns now."""
        ...

    def publish_columns(self, message: bytes) -> None:
        """Put a columnar publication (a whole message) on P/state_columns."""
        ...

    def forward_columns(self, lb: int, message: bytes) -> None:
        """Put a column push (a whole message) on `lb`'s push key."""
        ...
