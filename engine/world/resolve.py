"""Resolving one move of a mover: transition, SetPositionInternal, shadows, result.

This is the part of the client's PhysicsObj.SetPosition / UpdateObjectInternal
that runs once the target frame is known: run the transition from the current
position, and on success take its result (SetPositionInternal) and move the
mover's shadows into the cells the transition found. It is compiled with the
rest of the per-move path; World.move and World.step are thin checks around it.
"""

from __future__ import annotations

from typing import Any

from ..geometry.position import Position
from ..geometry.vec3 import Vec3
from ..transition.transition import Transition, give_back
from ..cells.landscape import Landscape
from .mover import Mover
from .shadows import reshadow
from .transient import TS, transient_names
from .types import MoveResult

__all__ = ["move_mover", "move_result"]


def _block_distance(a: int, b: int) -> int:
    """How many landblocks apart two cell ids are (Chebyshev, in block units)."""
    dx = ((a >> 24) & 0xFF) - ((b >> 24) & 0xFF)
    dy = ((a >> 16) & 0xFF) - ((b >> 16) & 0xFF)
    # signs by comparison: compiled, abs() of an int is a generic call
    if dx < 0:
        dx = -dx
    if dy < 0:
        dy = -dy
    return dx if dx > dy else dy


def move_mover(landscape: Landscape, mover: Mover, target: Position, loaded: bool = False,
               cast_shadows: bool = True) -> MoveResult:
    """Move `mover` toward `target` (already checked): PhysicsObj.SetPosition through
    a transition. A target within EPSILON of where the mover stands runs no
    transition; one more than a landblock away is refused, as the client refuses it.
    `loaded`: the target's landblock is known to be loaded (its check loaded it).
    `cast_shadows` False moves an object no cell knows about (a navigation probe):
    its shadows are not cast into the cells it reaches."""
    current = mover.position
    if target.cell_id == current.cell_id and target.frame.equals_within_epsilon(current.frame):
        mover.position = Position(current.cell_id, target.frame)
        return move_result(mover, True, "NoTransition", None)
    if _block_distance(current.cell_id, target.cell_id) > 1:
        return move_result(mover, False, "NoTransition", None)
    if not loaded:
        landscape.ensure_loaded(target.cell_id)
    t = mover.transition(landscape, current, target, landscape.settings)
    if t is None or t.sphere_path.curr_cell is None:
        mover.position = Position(current.cell_id, current.frame.with_orientation(target.frame.orientation))
        return move_result(mover, False, "Invalid", t)
    mover.set_position_internal(t)
    if cast_shadows:
        reshadow(mover, t.cell_array)
    result = move_result(mover, True, "OK", t)
    give_back(t)
    return result


def _object_id(obj: Any) -> int:
    owner = getattr(obj, "owner", None)
    return int(owner.id if owner is not None else obj.id)


def move_result(mover: Mover, ok: bool, state: str, t: Transition | None) -> MoveResult:
    """What a move did. Collision normal and the stationary-fall counter are the
    transition's own; a move that ran no transition has neither. `seq` is the mover's count as it
    stands: the checked move (engine.world.moves) that counts this one sets the new count."""
    ts = mover.transient
    collision_normal: Vec3 | None = None
    frames_stationary_fall: int | None = None
    collide_objects: list[int] = []
    if t is not None:
        ci = t.collision_info
        if ci.collision_normal_valid:
            collision_normal = ci.collision_normal
        frames_stationary_fall = ci.frames_stationary_fall
        for obj in ci.collide_object:
            collide_objects.append(_object_id(obj))
    contact = bool(ts & TS.CONTACT)
    # the plane is reported whenever the object is in contact; positional
    # arguments in MoveResult's field order (a keyword call costs more here)
    return MoveResult(
        ok,
        mover.position,
        state,
        contact,
        bool(ts & TS.ON_WALKABLE),
        mover.contact_plane if contact else None,
        mover.contact_plane_cell_id if contact else None,
        collision_normal,
        mover.sliding_normal if ts & TS.SLIDING else None,
        bool(ts & TS.WATER_CONTACT),
        frames_stationary_fall,
        transient_names(ts),
        collide_objects,
        None,
        mover.seq,  # a move's count is set where it is counted (engine.world.moves)
    )
