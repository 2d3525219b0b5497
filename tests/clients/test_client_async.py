"""The small asyncio front of the client."""

from __future__ import annotations

import asyncio

from clients import AsyncClient, Move, MoverState
from clients.demo.world import global_to_cell
from engine.geometry import Position, Vec3
from support.service_harness import ServiceProcess, human


def test_async_client_round_trip() -> None:
    with ServiceProcess() as svc:

        async def run() -> list[MoverState]:
            async with AsyncClient([svc.endpoint]) as c:
                await asyncio.to_thread(c.sync.wait_ready)
                cell, x, y = global_to_cell(60.0, 60.0)
                st = await c.register(human(), Position.at(cell, Vec3(x, y, 60.0)))
                # several movers' requests in flight at once
                others = await asyncio.gather(*(c.register(human(), Position.at(cell, Vec3(x + k, y, 60.0)))
                                                for k in range(1, 4)))
                moved = await asyncio.gather(*(c.step(o.id, (0.0, 0.0, 0.0), 0.2) for o in others))
                batch = await c.move_many([Move(st.id, offset=(0.1, 0.0, 0.0)) for _ in range(3)])
                (stats,) = await c.stats()
                assert stats["movers"] == 4
                for o in [st, *others]:
                    await c.remove(o.id)
                return [*moved, *batch]  # type: ignore[list-item]

        results = asyncio.run(run())
    assert all(isinstance(r, MoverState) and r.seq == 1 for r in results[:3])
    assert [r.seq for r in results[3:]] == [1, 2, 3]
