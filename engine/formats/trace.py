"""acphys-trace/1: replay a reference case move by move.

`run_case(world, case)` does what the reference did (formats README, "How a
move is replayed") and returns, per move, a dict with exactly the keys of
that move's `expect` (every field, for a move without one).
"""

from __future__ import annotations

import gzip
import json
from pathlib import Path
from typing import Any

from ..errors import SceneFormatError
from ..geometry import Frame, Plane, Position, Quat, Vec3
from ..geometry.precision import fl_vec
from ..geometry.single import to_single
from ..world.placement import place_mover
from ..world.types import CylSphereSpec, MoveResult, MoverSpec, SphereSpec
from ..world.world import World

__all__ = [
    "EXPECT_FIELDS",
    "add_case_mover",
    "expect_keys",
    "load_trace",
    "mover_spec_from_case",
    "replay_move",
    "result_to_expect",
    "trace_cell",
    "trace_plane",
    "trace_quat",
    "trace_vec",
]

TRACE_FORMAT = "acphys-trace/1"


def load_trace(path: str | Path) -> dict[str, Any]:
    """Read a trace file, gzipped or not."""
    p = Path(path)
    opener = gzip.open if p.suffix == ".gz" else open
    with opener(p, "rt", encoding="utf-8") as f:  # type: ignore[operator]
        data = json.load(f)
    if not isinstance(data, dict) or data.get("format") != TRACE_FORMAT:
        raise SceneFormatError(f"{p}: not an {TRACE_FORMAT} file")
    return data


# The reference's numbers are single precision written as shortest decimals:
# reading them back as float32 recovers exactly what it computed with.
def trace_vec(v: Any) -> Vec3:
    return fl_vec(Vec3(float(v[0]), float(v[1]), float(v[2])), True)


def trace_quat(q: Any) -> Quat:
    return Quat(to_single(float(q[0])), to_single(float(q[1])), to_single(float(q[2])), to_single(float(q[3])))


def trace_plane(p: Any) -> Plane:
    return Plane(trace_vec(p["normal"]), to_single(float(p["d"])))


def mover_spec_from_case(obj: dict[str, Any], scene: dict[str, Any] | None = None) -> MoverSpec:
    """A trace `object` block as a MoverSpec (a scene Setup fills what it omits)."""
    setup: dict[str, Any] = {}
    if obj.get("setup") and scene is not None:
        setup = scene.get("setups", {}).get(obj["setup"].upper().zfill(8), {})
    spheres = obj.get("spheres")
    if spheres is None:
        spheres = [{"center": s["origin"], "radius": s["radius"]} for s in setup.get("spheres", [])]
    cyl = obj.get("cyl_spheres")
    if cyl is None:
        cyl = setup.get("cyl_spheres", [])
    state = list(obj.get("state", []))
    return MoverSpec(
        spheres=[SphereSpec(tuple(float(c) for c in s["center"]), float(s["radius"])) for s in spheres],  # type: ignore[arg-type]
        step_up_height=float(obj.get("step_up_height", setup.get("step_up_height", 0.0))),
        step_down_height=float(obj.get("step_down_height", setup.get("step_down_height", 0.0))),
        state=state,
        step_down=bool(obj.get("step_down", True)),
        ethereal=bool(obj.get("ethereal", False)),
        scale=float(obj.get("scale", 1.0)),
        gravity=bool(obj.get("gravity", False)),
        creature=obj.get("creature"),
        cyl_spheres=[CylSphereSpec(tuple(float(c) for c in s["origin"]), float(s["radius"]), float(s["height"])) for s in cyl],  # type: ignore[arg-type]
    )


def trace_cell(text: str) -> int:
    return int(text, 16)


#: every field a move's `expect` may hold: what a move without `expect` reports
EXPECT_FIELDS = (
    "ok", "position", "contact", "on_walkable", "contact_plane", "collision_normal", "sliding_normal",
    "contact_plane_cell", "water_contact", "frames_stationary_fall", "transient_state", "collide_objects",
    "placement_result",
)


def expect_keys(move: dict[str, Any]) -> Any:
    """The fields to report for a trace move: its `expect`'s, or every field when it has none."""
    expect = move.get("expect")
    return EXPECT_FIELDS if expect is None else expect.keys()


def result_to_expect(result: MoveResult, keys: Any = EXPECT_FIELDS) -> dict[str, Any]:
    """A MoveResult in the trace's `expect` vocabulary, restricted to `keys`."""
    pos = result.position
    full: dict[str, Any] = {
        "ok": result.ok,
        "position": {"cell": f"{pos.cell_id:08X}", "origin": list(pos.frame.origin.as_tuple())},
        "contact": result.contact,
        "on_walkable": result.on_walkable,
        "contact_plane": None
        if result.contact_plane is None
        else {"normal": list(result.contact_plane.normal.as_tuple()), "d": result.contact_plane.d},
        "collision_normal": None if result.collision_normal is None else list(result.collision_normal.as_tuple()),
        "sliding_normal": None if result.sliding_normal is None else list(result.sliding_normal.as_tuple()),
        "contact_plane_cell": None if result.contact_plane_cell is None else f"{result.contact_plane_cell:08X}",
        "water_contact": result.water_contact,
        "frames_stationary_fall": result.frames_stationary_fall,
        "transient_state": list(result.transient_state),
        "collide_objects": list(result.collide_objects),
        "placement_result": getattr(result, "placement_result", None),
    }
    return {k: full.get(k) for k in keys}


def _target(world: World, mover_id: int, move: dict[str, Any], physics: bool) -> tuple[Position | None, Vec3 | None]:
    mover = world.mover(mover_id)
    cur = mover.position
    to = move.get("to")
    if to is not None:
        cell_text = to.get("cell", "current")
        cell_id = cur.cell_id if cell_text == "current" else trace_cell(cell_text)
        orientation = trace_quat(to["orientation"]) if "orientation" in to else cur.frame.orientation
        return Position(cell_id, Frame(trace_vec(to["origin"]), orientation)), None
    offset = trace_vec(move["offset"])
    if physics:
        return None, offset
    return Position(cur.cell_id, cur.frame.with_origin(cur.frame.origin + offset)), None


def add_case_mover(world: World, case: dict[str, Any]) -> int:
    scene = getattr(world, "scene", None)
    spec = mover_spec_from_case(case["object"], scene)
    start = case["start"]
    position = Position(trace_cell(start["cell"]), Frame(trace_vec(start["origin"]), trace_quat(start.get("orientation", [1, 0, 0, 0]))))
    plane = case.get("start_contact_plane")
    plane_cell = case.get("start_contact_plane_cell")
    sliding = case.get("start_sliding_normal")
    return world.add_mover(
        spec,
        position,
        trace_plane(plane) if plane else None,
        trace_cell(plane_cell) if plane_cell else None,
        sliding_normal=trace_vec(sliding) if sliding else None,
        water_contact=bool(case.get("start_water_contact", False)),
    )


def replay_move(world: World, mover_id: int, move: dict[str, Any], physics: bool, dt: float, use_offsets: bool) -> MoveResult:
    """One trace move: velocity, then placement, physics step or transition."""
    mover = world.mover(mover_id)
    velocity = move.get("velocity")
    placement = move.get("placement")
    if placement is not None:
        to = move["to"]
        target = Position(
            trace_cell(to["cell"]) if to.get("cell", "current") != "current" else mover.position.cell_id,
            Frame(trace_vec(to["origin"]), trace_quat(to["orientation"]) if "orientation" in to else mover.position.frame.orientation),
        )
        return place_mover(world, mover_id, target, placement.get("mode", "teleport"), bool(placement.get("slide", False)))
    if physics and (use_offsets or "to" not in move) and "offset" in move:
        return world.step(mover_id, trace_vec(move["offset"]), dt)
    mover.velocity = trace_vec(velocity) if velocity is not None else Vec3(0.0, 0.0, 0.0)
    target_pos, _ = _target(world, mover_id, move, physics)
    assert target_pos is not None
    return world.move(mover_id, target_pos)
