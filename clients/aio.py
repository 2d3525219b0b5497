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

from clients.batch import BatchResults
from clients.client import Client
from clients.errors import AcphysError
from clients.types import InstanceInfo, Move, MoverState

__all__ = ["AsyncClient"]

T = TypeVar("T")


class AsyncClient:
    """The client for asyncio code: the calls of `Client` that a program drives movers with, as coroutines.

        async with AsyncClient(["tcp/127.0.0.1:7447"]) as c:
            st = await c.step(mover_id, (0.0, 0.8, 0.0), 0.2)

    Each call runs the `Client` call of the same name on a thread (`asyncio.to_thread`) and takes the same
    arguments, in the same units (landblock-local metres, hex cell ids, seconds), returns the same values
    and raises the same errors (`ServiceError`, `BusyError`, `NoServiceError`, `RequestTimeout`). Calls
    awaited together run at the same time over the one Zenoh session. For anything else (the spatial
    queries, subscriptions, `push`, landblocks) use the synchronous client underneath, `sync`.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        """Same arguments as `Client` (endpoints, `prefix`, `timeout`, `user`, `password`, ...); the
        `Client` it opens is `self.sync`. Raises as `Client()` does."""
        self.sync = Client(*args, **kwargs)

    async def _run(self, fn: Callable[..., T], *args: Any, **kwargs: Any) -> T:
        return await asyncio.to_thread(functools.partial(fn, *args, **kwargs))

    async def register(self, *args: Any, **kwargs: Any) -> MoverState:
        """`Client.register(spec, position, ...)`, awaited: add a mover; its first State."""
        return await self._run(self.sync.register, *args, **kwargs)

    async def move(self, *args: Any, **kwargs: Any) -> MoverState:
        """`Client.move(mover_id, to=None, *, offset=..., velocity=..., tag=..., timeout=...)`, awaited: one
        transition; the mover's State after it."""
        return await self._run(self.sync.move, *args, **kwargs)

    async def step(self, *args: Any, **kwargs: Any) -> MoverState:
        """`Client.step(mover_id, motion, dt, *, tag=..., timeout=...)`, awaited: one physics step (`motion`
        metres in the mover's frame over `dt` seconds); the mover's State after it."""
        return await self._run(self.sync.step, *args, **kwargs)

    async def move_many(self, moves: Sequence[Move], timeout: float | None = None,
                        publish: str | None = None) -> list[MoverState | AcphysError]:
        """`Client.move_many`, awaited: one entry per move, in order, its State or its error (nothing
        raised for a failed move)."""
        return await self._run(self.sync.move_many, moves, timeout, publish)

    async def move_many_maps(self, moves: Sequence[Move], timeout: float | None = None,
                             publish: str | None = None) -> list[dict[str, Any] | AcphysError]:
        """`Client.move_many_maps`, awaited: each move's entry as the service sent it (a State map or an
        error map), or an AcphysError when its request failed."""
        return await self._run(self.sync.move_many_maps, moves, timeout, publish)

    async def move_batch(self, *args: Any, **kwargs: Any) -> BatchResults:
        """`Client.move_batch(ids, offsets=..., targets=..., motions=..., dt=..., ...)`, awaited: a column
        batch, numpy arrays in, a `BatchResults` out (failed moves in its `errors`). ValueError for
        arguments of the wrong shape or combination."""
        return await self._run(self.sync.move_batch, *args, **kwargs)

    async def remove(self, mover_id: int) -> None:
        """`Client.remove`, awaited: remove the mover (ServiceError `unknown_mover` when none has the id)."""
        await self._run(self.sync.remove, mover_id)

    async def stats(self) -> list[InstanceInfo]:
        """`Client.stats`, awaited: every instance's Stats (an empty list when none answered)."""
        return await self._run(self.sync.stats)

    async def health(self) -> list[InstanceInfo]:
        """`Client.health`, awaited: every instance's Health (an empty list when none answered)."""
        return await self._run(self.sync.health)

    async def close(self) -> None:
        """`Client.close`, awaited: close the session (also at the end of an `async with` block)."""
        await self._run(self.sync.close)

    async def __aenter__(self) -> AsyncClient:
        return self

    async def __aexit__(self, *_: object) -> None:
        await self.close()
