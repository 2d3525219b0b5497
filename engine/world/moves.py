"""One checked move or physics step of a mover: what World.move and World.step run.

The checks at the door (engine.limits), the snapshot that undoes a move
that raises (rollback), the move itself (resolve.move_mover) or the
client's update_object time ladder (quantum.split_elapsed), and the
mover's move count: every move or step that resolves here (a MoveResult,
NoTransition included) adds one to Mover.seq, keeps its result as
Mover.last and carries the new count in MoveResult.seq; one that raises
counts nothing. Both World.move/step and the batch pass here, so the count
is the same whichever way a mover is moved. Compiled with
the rest of the per-move path, so World.move, World.step and the batch
entry point (engine.world.batch) pay no interpreted glue per move.
"""

from __future__ import annotations

from .. import limits
from ..cells.landscape import Landscape
from ..geometry import ZERO, Position, Vec3
from ..settings import EngineSettings
from .mover import Mover
from .quantum import split_elapsed
from .resolve import move_mover, move_result
from .rollback import MoverSnapshot
from .types import MoveResult

__all__ = ["move_checked", "step_checked"]


def move_checked(landscape: Landscape, mover: Mover, target: Position, velocity: Vec3 | None) -> MoveResult:
    """Move `mover` toward `target` (PhysicsObj.SetPosition through a transition) after checking the
    target (and `velocity`, the mover's velocity for this move only; None keeps its own). A move that
    raises leaves the mover as it was (its seq and last too); one that resolves is counted."""
    limits.check_position(target, "target")
    landscape.check_position(target)
    if velocity is not None:
        limits.check_velocity(velocity, "velocity")
    snapshot = MoverSnapshot(mover)
    if velocity is not None:
        mover.velocity = velocity
    try:
        result = move_mover(landscape, mover, target, True)  # (check_position loaded its landblock)
    except BaseException:
        snapshot.restore()
        raise
    if velocity is not None:
        mover.velocity = snapshot.velocity  # the given velocity was this move's only
    # counted once it can no longer raise (written out: a call per move costs more than these lines)
    seq = mover.seq + 1
    mover.seq = seq
    result.seq = seq
    mover.last = result
    return result


def step_checked(landscape: Landscape, mover: Mover, motion: Vec3, dt: float) -> MoveResult:
    """`dt` seconds of `mover`'s time with its own motion `motion` (PhysicsObj.update_object), after
    checking both. A step that raises leaves the mover as it was. However many physics steps `dt`
    runs (none, one or several quanta), the step counts as one move."""
    limits.check_motion(motion, "motion")
    limits.check_dt(dt, "dt")
    snapshot = MoverSnapshot(mover)
    try:
        result = _spend(landscape, mover, motion, dt)
    except BaseException:
        snapshot.restore()
        raise
    seq = mover.seq + 1  # (as in move_checked)
    mover.seq = seq
    result.seq = seq
    mover.last = result
    return result


def _spend(landscape: Landscape, mover: Mover, motion: Vec3, dt: float) -> MoveResult:
    """`dt` seconds as physics steps: the quantum ladder (update_object), or one step without it."""
    settings = landscape.settings
    if not settings.quantum_ladder:
        return _physics_step(landscape, settings, mover, motion, dt)
    elapsed = mover.held_time + dt
    pending_motion = motion if mover.held_motion == ZERO else mover.held_motion + motion
    if elapsed == 0.0:
        # no time at all: the motion waits for some
        mover.held_motion = pending_motion
        return move_result(mover, True, "NoTransition", None)
    split = split_elapsed(elapsed, settings.max_quantum)
    mover.held_time = split.held
    mover.held_motion = pending_motion * (split.held / elapsed) if split.held > 0.0 else ZERO
    if not split.quanta:
        return move_result(mover, True, "NoTransition", None)
    result: MoveResult | None = None
    hit: list[int] = []
    for quantum in split.quanta:
        # a whole `elapsed` run in one step keeps the caller's motion exactly
        share = pending_motion if quantum == elapsed else pending_motion * (quantum / elapsed)
        result = _physics_step(landscape, settings, mover, share, quantum)
        for obj_id in result.collide_objects:
            if obj_id not in hit:
                hit.append(obj_id)
    assert result is not None
    if len(split.quanta) > 1:
        result.collide_objects = hit
    return result


def _physics_step(landscape: Landscape, settings: EngineSettings, mover: Mover, motion: Vec3,
                  quantum: float) -> MoveResult:
    """One physics step of `quantum` seconds (UpdateObjectInternal)."""
    frame = mover.integrate(motion, quantum, settings)
    return move_mover(landscape, mover, Position(mover.position.cell_id, frame))
