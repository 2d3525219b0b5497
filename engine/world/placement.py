"""Placing a mover into the world: entering it, or teleporting within it.

The client's PhysicsObj.SetPosition: find the cell the target lies in
(AdjustPosition), run a placement transition there (CheckPositionInternal:
push out of overlaps, search for a free spot when sliding is allowed, land
with a LandingZ step-down), and apply the result (SetPositionInternal).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .. import limits
from ..cells.env_cell import EnvCell
from ..cells.obj_cell import ObjCell
from ..geometry import Position, Sphere, Vec3
from ..geometry.landdefs import adjust_to_outside
from ..transition.state import OI
from ..transition.transition import Transition
from . import shadows
from .mover import Mover
from .resolve import move_result
from .types import MoveResult, MoverSpec, ObjectState

if TYPE_CHECKING:
    from .world import World

__all__ = ["mover_from_spec", "place_mover", "run_placement", "PLACEMENT_MODES"]

PLACEMENT_MODES = ("enter_world", "teleport")


def _adjust_position(world: World, position: Position, low_point: Vec3) -> tuple[ObjCell | None, Position]:
    """The cell a placement target lies in, and the target re-homed there
    (PhysicsObj.AdjustPosition, searching the stab list)."""
    index = position.cell_id & 0xFFFF
    if not ((1 <= index <= 0x40) or (0x100 <= index <= 0xFFFD) or index == 0xFFFF):
        return None, position
    if index < 0x100:
        cell_id, origin = adjust_to_outside(position.cell_id, position.frame.origin)
        position = Position(cell_id, position.frame.with_origin(origin))
        return (world.get_landcell(cell_id) if cell_id else None), position
    visible = world.get_landcell(position.cell_id)
    if not isinstance(visible, EnvCell):  # an indoor id names an EnvCell, when its landblock is loaded
        return None, position
    point = position.frame.local_to_global(low_point)
    if visible.point_in_cell(point):
        return visible, position
    for other in visible.visible_cells.values():
        if other is not None and other.point_in_cell(point):
            return other, position.with_cell(other.id)
    if not visible.seen_outside:
        return None, position
    cell_id, origin = adjust_to_outside(position.cell_id, position.frame.origin)
    position = Position(cell_id, position.frame.with_origin(origin))
    return (world.get_landcell(cell_id) if cell_id else None), position


def run_placement(world: World, mover: Mover, target: Position, mode: str, slide: bool) -> tuple[str, Transition, Position]:
    """The placement transition for `mover` at `target` (PhysicsObj.SetPosition
    up to, not including, SetPositionInternal): "OK", "NoValidPosition" or
    "NoCell(lost)", the transition, and the target re-homed into its cell.
    Nothing is applied to the mover; `target` is already checked."""
    if mode not in PLACEMENT_MODES:
        raise ValueError(f"placement mode must be one of {PLACEMENT_MODES}, got {mode!r}")
    t = Transition(world, world.settings)
    # ObjectInfo Default: no EdgeSlide, no contact plane, no sliding normal.
    t.init_object(mover.object_info(0))
    t.init_sphere(mover.spheres, mover.scale)

    cell, position = _adjust_position(world, target, t.sphere_path.local_sphere[0].center)
    if cell is None:
        return "NoCell(lost)", t, position

    t.init_path(cell, None, position)
    if not slide:
        t.sphere_path.placement_allows_sliding = False
    ok = t.find_valid_position()
    path = t.sphere_path
    if ok and not slide:
        assert path.curr_pos is not None
        diff = path.curr_pos.frame.origin - position.frame.origin
        # the client compares the signed differences, so only a shift toward +x/+y is bounded
        ok = path.curr_pos.cell_id == cell.id and diff.x < 0.05 and diff.y < 0.05
    if ok and path.curr_cell is None:
        ok = False
    if ok and mode == "enter_world" and path.curr_pos is not None and path.curr_pos.cell_id >> 16 != position.cell_id >> 16:
        ok = False
    return ("OK" if ok else "NoValidPosition"), t, position


def place_mover(world: World, mover_id: int, target: Position, mode: str = "teleport", slide: bool = False) -> MoveResult:
    """Place a mover at `target` as the client places a new or teleported object.

    `mode` is "enter_world" (the object is new to the world: a placement that
    ends in another landblock is refused) or "teleport". With `slide` the
    placement may search around the target for a free spot; without it only a
    shift under 5 cm is accepted. The result's `placement_result` is "OK",
    "NoValidPosition" or "NoCell(lost)".
    """

    if mode not in PLACEMENT_MODES:
        raise ValueError(f"placement mode must be one of {PLACEMENT_MODES}, got {mode!r}")
    mover = world.mover(mover_id)
    world._check_position(target)

    outcome, t, position = run_placement(world, mover, target, mode, slide)
    if outcome == "NoCell(lost)":
        mover.position = position
        mover.cell = None
        result = move_result(mover, False, "Invalid", t)
        result.placement_result = "NoCell(lost)"  # type: ignore[attr-defined]
        return result
    if outcome != "OK":
        result = move_result(mover, False, "Invalid", t)
        result.placement_result = "NoValidPosition"  # type: ignore[attr-defined]
        return result
    mover.set_position_internal(t)
    shadows.reshadow(mover, t.cell_array)
    result = move_result(mover, True, "OK", t)
    result.placement_result = "OK"  # type: ignore[attr-defined]
    return result


def mover_from_spec(mover_id: int, spec: MoverSpec) -> Mover:
    """A Mover of shape `spec` (checked against engine.limits), not yet anywhere."""
    limits.check_mover_spec(spec, "spec")
    flags = ObjectState.from_names(spec.state)
    spheres = [Sphere(Vec3(*s.center), float(s.radius)) for s in spec.spheres]
    creature = spec.creature if spec.creature is not None else bool(flags & OI.IS_PLAYER)
    return Mover(
        mover_id,
        spheres,
        oi_flags=flags,
        scale=spec.scale,
        step_up_height=spec.step_up_height,
        step_down_height=spec.step_down_height,
        gravity=spec.gravity,
        missile=bool(flags & OI.PATH_CLIPPED),
        step_down=spec.step_down,
        ethereal=spec.ethereal,
        creature=creature,
        cyl_spheres=list(spec.cyl_spheres),
        sledding=spec.sledding,
    )
