"""MoveUndo: a move that ended, taken back exactly (engine/world/rollback.py).

The mover's slots and its place in every cell's shadow list (other movers test shadows in list order)
must come back as they were, so that the world is as if the move had never been asked.
"""

from __future__ import annotations

from typing import Any

from engine import load_scene
from engine.geometry import Position, Vec3
from engine.world.batch import OFFSET, BatchRows, run_batch
from engine.world.rollback import MoveUndo
from support.service_harness import human, start_on_ground

DEMO = "clients/demo/demo.json"
CELL = 0xA9B40001  # x 0..24, y 0..24 of A9B4


def _shadow_lists(world: Any) -> dict[int, list[int]]:
    """Every cell's shadow list as mover ids, oldest first (cells with none left out)."""
    out: dict[int, list[int]] = {}
    for cell_id in range(CELL, CELL + 64):
        cell = world.get_landcell(cell_id)
        if cell is not None and cell.shadow_objects:
            out[cell_id] = [o.mover.id for o in cell.shadow_objects]
    return out


def _slots(mover: Any) -> tuple[Any, ...]:
    return (mover.position.cell_id, mover.position.frame.origin, mover.position.frame.orientation,
            None if mover.cell is None else mover.cell.id, mover.transient, mover.contact_plane,
            mover.contact_plane_cell_id, mover.sliding_normal, mover.velocity, mover.acceleration, mover.held_time,
            mover.held_motion, [c.id for c in mover.shadow_cells])


def _three_in_a_row(world: Any) -> list[int]:
    """Three movers 1.2 m apart on the ground, sharing their cells' shadow lists."""
    return [world.add_mover(human(contact=True), start_on_ground(world, CELL, 10.0 + 1.2 * k, 20.0))
            for k in range(3)]


#: from y 20 into the next cell north (y 24..48), in one transition
NORTH = Vec3(0.0, 6.0, 0.0)


def test_a_move_taken_back_puts_the_mover_back_in_its_place_in_every_shadow_list() -> None:
    world = load_scene(DEMO)
    ids = _three_in_a_row(world)
    middle = world.mover(ids[1])
    lists, slots = _shadow_lists(world), _slots(middle)
    assert any(len(v) == 3 for v in lists.values())  # a cell where the middle one is neither first nor last
    undo = MoveUndo(middle)
    assert world.move(ids[1], middle.position.moved(NORTH)).ok  # into the next cell
    assert _shadow_lists(world) != lists
    undo.restore()
    assert _shadow_lists(world) == lists
    assert _slots(middle) == slots


def test_movers_added_while_a_move_waits_stay_newer_than_the_one_taken_back() -> None:
    world = load_scene(DEMO)
    ids = _three_in_a_row(world)
    middle = world.mover(ids[1])
    lists = _shadow_lists(world)
    undo = MoveUndo(middle)
    assert world.move(ids[1], middle.position.moved(NORTH)).ok
    # a mover handed in meanwhile, standing where the others are: the newest shadow in their cells
    newcomer = world.add_mover(human(contact=True), start_on_ground(world, CELL, 10.6, 18.0))
    undo.restore()
    expected = {cell: ids_ + [newcomer] if cell in _shadow_lists_of(world, newcomer) else ids_
                for cell, ids_ in lists.items()}
    for cell in _shadow_lists_of(world, newcomer):
        expected.setdefault(cell, [newcomer])
    assert _shadow_lists(world) == expected


def _shadow_lists_of(world: Any, mover_id: int) -> set[int]:
    return {c.id for c in world.mover(mover_id).shadow_cells}


def test_a_batch_stopped_at_an_item_can_take_that_items_move_back() -> None:
    world = load_scene(DEMO)
    ids = _three_in_a_row(world)
    movers = [world.mover(i) for i in ids]
    lists, slots = _shadow_lists(world), [_slots(m) for m in movers]
    rows = BatchRows()
    # item 0 runs and stays; item 1 is stopped after its move (as a service stops one leaving its landblocks)
    stopped = run_batch(world.landscape, movers[:2], OFFSET, [0.0, -0.5, 0.0, 0.0, 6.0, 0.0], rows,
                        stop_if=lambda _lb: len(rows.results) == 2)
    assert stopped == 1 and rows.count == 1 and rows.undo is not None
    assert movers[1].position.frame.origin.y > slots[1][1].y + 5.0
    rows.undo.restore()
    assert _slots(movers[1]) == slots[1] and _slots(movers[2]) == slots[2]
    # the world is as if only item 0 had been asked: the same moves on a world of its own
    control = load_scene(DEMO)
    control_ids = _three_in_a_row(control)
    control.move(control_ids[0], control.mover(control_ids[0]).position.moved(Vec3(0.0, -0.5, 0.0)))
    assert _shadow_lists(world) == _shadow_lists(control) != lists
    assert [_slots(m) for m in movers] == [_slots(control.mover(i)) for i in control_ids]


def test_no_undo_is_kept_without_stop_if() -> None:
    world = load_scene(DEMO)
    ids = _three_in_a_row(world)
    rows = BatchRows()
    run_batch(world.landscape, [world.mover(i) for i in ids], OFFSET, [0.1, 0.0, 0.0] * 3, rows)
    assert rows.undo is None and rows.count == 3
    assert isinstance(world.mover(ids[0]).position, Position)
