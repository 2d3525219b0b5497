"""Replaying an acphys-trace/1 case: one mover, or several live movers in lockstep.

`run_case` replays a case's moves on a World with the reference port's
settings (the per-move reading and reporting is in trace.py).


What the reference does (formats README, "Several movers in one case"):
every mover enters the world in list order at its start; then tick by tick
each mover that has a move takes it, in list order, seeing the others where
they are now. Each result adds `collide_objects`: the ids of the movers the
transition touched.
"""

from __future__ import annotations

from typing import Any

from ..settings import ACE_COMPAT, EngineSettings
from ..world.world import World
from .trace import add_case_mover, expect_keys, replay_move, result_to_expect, trace_vec

__all__ = ["run_case", "run_movers_case"]


def run_case(world: World, case: dict[str, Any], settings: EngineSettings = ACE_COMPAT, use_offsets: bool = False) -> Any:
    """Replay one acphys-trace/1 case on `world`.

    Returns a list of per-move dicts (the keys of each move's `expect`), or for
    a case with `movers`, a dict from mover id to such a list. Replay runs with
    the reference port's settings unless told otherwise. With `use_offsets`, a
    physics case is driven from its offsets through the physics step instead
    of from the targets the reference computed.
    """
    if "movers" in case:
        return run_movers_case(world, case, settings, use_offsets)
    saved = world.settings
    world.settings = settings
    mover_id = None
    try:
        mover_id = add_case_mover(world, case)
        physics = case.get("physics")
        dt = float(physics["dt"]) if physics else 0.0
        if physics and physics.get("velocity") is not None:
            world.mover(mover_id).velocity = trace_vec(physics["velocity"])
        results: list[dict[str, Any]] = []
        for move in case["moves"]:
            result = replay_move(world, mover_id, move, physics is not None, dt, use_offsets)
            results.append(result_to_expect(result, expect_keys(move)))
            if move.get("placement") is not None and result.placement_result != "OK":  # type: ignore[attr-defined]
                break
        return results
    finally:
        world.settings = saved
        if mover_id is not None:
            world.remove_mover(mover_id)


def run_movers_case(world: World, case: dict[str, Any], settings: EngineSettings, use_offsets: bool = False) -> dict[str, list[dict[str, Any]]]:
    saved = world.settings
    world.settings = settings
    ids: dict[str, int] = {}
    names: dict[int, str] = {}
    try:
        for spec in case["movers"]:
            mid = add_case_mover(world, spec)
            ids[spec["id"]] = mid
            names[mid] = spec["id"]
            physics = spec.get("physics")
            if physics and physics.get("velocity") is not None:
                world.mover(mid).velocity = trace_vec(physics["velocity"])
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
