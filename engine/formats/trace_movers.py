"""Replaying a case with several live movers moved in lockstep.

What the reference does (formats README, "Several movers in one case"):
every mover enters the world in list order at its start; then tick by tick
each mover that has a move takes it, in list order, seeing the others where
they are now. Each result adds `collide_objects`: the ids of the movers the
transition touched.
"""

from __future__ import annotations

from typing import Any

from ..transition.settings import EngineSettings
from ..world.world import World

__all__ = ["run_movers_case"]


def run_movers_case(world: World, case: dict[str, Any], settings: EngineSettings, use_offsets: bool = False) -> dict[str, list[dict[str, Any]]]:
    from .trace import _add_case_mover, _vec, expect_keys, replay_move, result_to_expect

    saved = world.settings
    world.settings = settings
    ids: dict[str, int] = {}
    names: dict[int, str] = {}
    try:
        for spec in case["movers"]:
            mid = _add_case_mover(world, spec)
            ids[spec["id"]] = mid
            names[mid] = spec["id"]
            physics = spec.get("physics")
            if physics and physics.get("velocity") is not None:
                world.mover(mid).velocity = _vec(physics["velocity"])
        results: dict[str, list[dict[str, Any]]] = {spec["id"]: [] for spec in case["movers"]}
        stopped: set[str] = set()
        ticks = max(len(spec["moves"]) for spec in case["movers"])
        for tick in range(ticks):
            for spec in case["movers"]:
                name = spec["id"]
                if tick >= len(spec["moves"]) or name in stopped:
                    continue
                move = spec["moves"][tick]
                physics = spec.get("physics")
                dt = float(physics["dt"]) if physics else 0.0
                result = replay_move(world, ids[name], move, physics is not None, dt, use_offsets)
                result.collide_objects = [names.get(i, f"{i:08X}") for i in result.collide_objects]  # type: ignore[misc]
                results[name].append(result_to_expect(result, expect_keys(move)))
                if move.get("placement") is not None and result.placement_result != "OK":
                    stopped.add(name)
        return results
    finally:
        world.settings = saved
        for mid in ids.values():
            world.remove_mover(mid)
