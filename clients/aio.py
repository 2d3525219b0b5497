"""asyncio front of the client: each call runs the synchronous one in a thread.

    async with AsyncClient() as c:
        st = await c.move(mover_id, offset=(1, 0, 0))

Zenoh's Python binding is synchronous; a thread per call keeps the event
loop free without a second implementation of the protocol.
"""

from __future__ import annotations

import asyncio
import functools
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

from .batch import BatchResults
from .client import Client
from .errors import AcphysError
from .types import InstanceInfo, Move, MoverState

__all__ = ["AsyncClient"]

T = TypeVar("T")


class AsyncClient:
    def __init__(self, *args: Any, **kwargs: Any) -> None:
        """Same arguments as Client."""
        self.sync = Client(*args, **kwargs)

    async def _run(self, fn: Callable[..., T], *args: Any, **kwargs: Any) -> T:
        return await asyncio.to_thread(functools.partial(fn, *args, **kwargs))

    async def register(self, *args: Any, **kwargs: Any) -> MoverState:
        return await self._run(self.sync.register, *args, **kwargs)

    async def move(self, *args: Any, **kwargs: Any) -> MoverState:
        return await self._run(self.sync.move, *args, **kwargs)

    async def step(self, *args: Any, **kwargs: Any) -> MoverState:
        return await self._run(self.sync.step, *args, **kwargs)

    async def move_many(self, moves: Sequence[Move], timeout: float | None = None,
                        publish: str | None = None) -> list[MoverState | AcphysError]:
        return await self._run(self.sync.move_many, moves, timeout, publish)

    async def move_many_maps(self, moves: Sequence[Move], timeout: float | None = None,
                             publish: str | None = None) -> list[dict[str, Any] | AcphysError]:
        return await self._run(self.sync.move_many_maps, moves, timeout, publish)

    async def move_batch(self, *args: Any, **kwargs: Any) -> BatchResults:
        """`Client.move_batch`, in a thread."""
        return await self._run(self.sync.move_batch, *args, **kwargs)

    async def remove(self, mover_id: int) -> None:
        await self._run(self.sync.remove, mover_id)

    async def stats(self) -> list[InstanceInfo]:
        return await self._run(self.sync.stats)

    async def health(self) -> list[InstanceInfo]:
        return await self._run(self.sync.health)

    async def close(self) -> None:
        await self._run(self.sync.close)

    async def __aenter__(self) -> AsyncClient:
        return self

    async def __aexit__(self, *_: object) -> None:
        await self.close()
