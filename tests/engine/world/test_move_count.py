"""The mover's move count (Mover.seq, Mover.last, MoveResult.seq): engine.world.moves counts every move
and step that resolves, the batch rows carry the count as their "seq" column, and MoveUndo takes it back.

The count is the service's per-mover sequence number (a client orders a mover's states by it), so the
expectations are simply how many moves each mover has made, counted by hand from the calls each test
makes.
"""

from __future__ import annotations

import math
import struct

import pytest

import engine
from engine import MoverSpec, Plane, Position, SphereSpec, Vec3
from engine.errors import EngineError, NonFiniteError
from engine.world.batch import MOTION, OFFSET, BatchRows, run_batch
from engine.world.rollback import MoveUndo
from engine.world.rows import RESULT_COLUMNS

HEIGHTS = [float(i) * 0.5 for i in range(256)]
#: a person-sized sphere standing on the ground
WALKER = MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.48), 0.48)], state=["Contact", "OnWalkable", "IsPlayer"])
GROUND = Plane(Vec3(0.0, 0.0, 1.0), -50.0)


def _world() -> engine.World:
    """Two landblocks side by side (A9B4 and AAB4), flat at 50 m."""
    return engine.world_from_scene_dict({
        "format": "acphys-scene/1", "name": "count", "height_table": HEIGHTS,
        "landblocks": [{"id": "A9B4", "heights": [100] * 81}, {"id": "AAB4", "heights": [100] * 81}],
    })


def _cell(lb: int, x: float, y: float) -> int:
    return (lb << 16) | (int(x // 24) * 8 + int(y // 24) + 1)


def _add(world: engine.World, x: float, y: float, lb: int = 0xA9B4) -> int:
    cell = _cell(lb, x, y)
    return world.add_mover(WALKER, Position.at(cell, Vec3(x, y, 50.0)), GROUND, cell)


def _moved(world: engine.World, mover_id: int, dx: float, dy: float) -> Position:
    return world.mover(mover_id).position.moved(Vec3(dx, dy, 0.0))


def _row_seqs(rows: BatchRows) -> list[int]:
    seqs = rows.columns()["seq"]
    return list(struct.unpack(f"<{len(seqs) // 8}Q", seqs))


def test_the_result_columns_begin_with_the_seq_column() -> None:
    assert RESULT_COLUMNS[0] == ("seq", "u64", 1)


def test_a_new_mover_has_made_no_move_and_asking_its_state_counts_none() -> None:
    world = _world()
    m = _add(world, 20.0, 20.0)
    assert world.mover(m).seq == 0 and world.mover(m).last is None
    assert world.mover_state(m).seq == 0
    assert world.mover_state(m).seq == 0 and world.mover(m).last is None


def test_each_single_move_counts_one_and_is_kept_as_last() -> None:
    world = _world()
    m = _add(world, 20.0, 20.0)
    first = world.move(m, _moved(world, m, 0.5, 0.0))
    assert first.seq == 1 and world.mover(m).seq == 1 and world.mover(m).last is first
    # a target where the mover already stands runs no transition (NoTransition) but is still a move
    still = world.move(m, world.mover(m).position)
    assert still.transition_state == "NoTransition" and still.seq == 2
    third = world.move(m, _moved(world, m, 0.0, 0.5))
    assert third.seq == 3 and world.mover(m).last is third
    assert world.mover_state(m).seq == 3 and world.mover(m).seq == 3  # asking counts nothing


def test_each_step_counts_one_however_many_quanta_it_runs() -> None:
    world = _world()
    m = _add(world, 20.0, 20.0)
    # 0.01 s is short of the minimum quantum (1/30 s): held, no physics step ran, still one call resolved
    held = world.step(m, Vec3(0.1, 0.0, 0.0), 0.01)
    assert held.transition_state == "NoTransition" and held.seq == 1
    # 0.5 s runs as several quanta (RETAIL's max_quantum is 0.2 s): one step for the count
    long = world.step(m, Vec3(0.5, 0.0, 0.0), 0.5)
    assert long.seq == 2 and world.mover(m).seq == 2 and world.mover(m).last is long


def test_a_refused_move_or_step_counts_nothing() -> None:
    world = _world()
    m = _add(world, 20.0, 20.0)
    kept = world.move(m, _moved(world, m, 0.5, 0.0))
    with pytest.raises(NonFiniteError):
        world.move(m, Position.at(world.mover(m).position.cell_id, Vec3(math.nan, 20.0, 50.0)))
    with pytest.raises(NonFiniteError):
        world.move(m, _moved(world, m, 0.5, 0.0), Vec3(math.inf, 0.0, 0.0))
    with pytest.raises(EngineError):  # NonFiniteError or the range check: either is a refusal
        world.step(m, Vec3(0.1, 0.0, 0.0), math.nan)
    assert world.mover(m).seq == 1 and world.mover(m).last is kept
    assert world.move(m, _moved(world, m, 0.5, 0.0)).seq == 2


def test_a_restored_count_goes_on_from_where_it_was_set() -> None:
    world = _world()
    m = _add(world, 20.0, 20.0)
    world.mover(m).seq = 41  # a mover restored with 41 moves behind it
    assert world.mover_state(m).seq == 41
    assert world.move(m, _moved(world, m, 0.5, 0.0)).seq == 42
    assert world.mover(m).seq == 42


def test_changing_a_movers_shape_keeps_its_count() -> None:
    world = _world()
    m = _add(world, 20.0, 20.0)
    last = world.move(m, _moved(world, m, 0.5, 0.0))
    world.update_mover(m, MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.3), 0.3)], state=["Contact", "OnWalkable"]))
    assert world.mover(m).seq == 1 and world.mover(m).last is last
    assert world.move(m, _moved(world, m, 0.5, 0.0)).seq == 2


def test_batch_rows_carry_each_results_seq_and_zero_for_missing_rows() -> None:
    world = _world()
    a, b = _add(world, 20.0, 20.0), _add(world, 100.0, 60.0)
    world.move(a, _moved(world, a, 0.2, 0.0))  # a has one move behind it before the batch
    ma, mb = world.mover(a), world.mover(b)
    # items: a, nothing, b, a (refused: NaN offset), a, b
    movers = [ma, None, mb, ma, ma, mb]
    vectors = [0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0, math.nan, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.5, 0.0]
    rows = BatchRows()
    assert run_batch(world.landscape, movers, OFFSET, vectors, rows) == 6
    assert [i for i, _ in rows.errors] == [3]
    # a: 1 before, then 2 and (item 4) 3; b: 1 and 2; the absent and the refused item: 0
    assert _row_seqs(rows) == [2, 0, 1, 0, 3, 2]
    assert [r.seq if r is not None else 0 for r in rows.results] == [2, 0, 1, 0, 3, 2]
    assert ma.seq == 3 and mb.seq == 2 and ma.last is rows.results[4] and mb.last is rows.results[5]


def test_batch_steps_count_as_world_steps_do() -> None:
    world = _world()
    m = _add(world, 20.0, 20.0)
    mover = world.mover(m)
    rows = BatchRows()
    run_batch(world.landscape, [mover, mover, mover], MOTION, [0.1, 0.0, 0.0] * 3, rows, dts=[0.01, 0.05, 0.5])
    assert _row_seqs(rows) == [1, 2, 3] and mover.seq == 3
    assert world.step(m, Vec3(0.1, 0.0, 0.0), 0.05).seq == 4


def test_move_undo_puts_the_count_and_last_result_back() -> None:
    world = _world()
    m = _add(world, 20.0, 20.0)
    before = world.move(m, _moved(world, m, 0.5, 0.0))
    mover = world.mover(m)
    undo = MoveUndo(mover)
    assert world.move(m, _moved(world, m, 0.5, 0.0)).seq == 2
    undo.restore()
    assert mover.seq == 1 and mover.last is before
    assert world.move(m, _moved(world, m, 0.5, 0.0)).seq == 2  # the refused move was never counted


def test_a_batch_stopped_at_a_hand_over_has_counted_it_and_its_undo_takes_the_count_back() -> None:
    world = _world()
    near, edge = _add(world, 20.0, 20.0), _add(world, 190.0, 100.0)
    mn, me = world.mover(near), world.mover(edge)
    rows = BatchRows()
    # near steps once; edge walks 3 m east from x = 190 m, across 192 m into AAB4: the batch stops there
    stopped = run_batch(world.landscape, [mn, me, mn], OFFSET, [0.5, 0.0, 0.0, 3.0, 0.0, 0.0, 0.5, 0.0, 0.0], rows,
                        stop_if=lambda lb: lb != 0xA9B4)
    assert stopped == 1
    leaving = rows.results[1]
    assert leaving is not None and leaving.position.cell_id >> 16 == 0xAAB4
    assert leaving.seq == 1 and me.seq == 1 and me.last is leaving  # the hand-over carries the new count
    assert _row_seqs(rows) == [1]  # no row for the stopped item yet
    assert rows.undo is not None
    rows.undo.restore()  # nobody took the mover: the move is refused
    assert me.seq == 0 and me.last is None
    assert mn.seq == 1  # the item before keeps its count
