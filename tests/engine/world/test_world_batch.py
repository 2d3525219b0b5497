"""engine.world.batch.run_batch: each item is the World.move / World.step call it stands for.

Every check runs the same moves twice on two identical worlds, once item by
item through World.move / World.step and once as one batch, and compares the
result columns with the MoveResults bit for bit.
"""

from __future__ import annotations

import math
import struct
from typing import Any

import engine
from engine import Mover, MoverSpec, Plane, Position, Vec3
from engine.errors import NonFiniteError, UnknownCellError
from benchmarks.scenes import PLAYER
from engine.world.batch import (
    MOTION,
    OFFSET,
    TO,
    TRANSITION_STATES,
    BatchRows,
    Status,
    run_batch,
)

#: the result columns as engine/world/rows.py documents them: name, struct code of one value, values an item
COLUMNS = (("seq", "Q", 1), ("cell", "I", 1), ("origin", "d", 3), ("orientation", "d", 4), ("flags", "I", 1),
           ("transition_state", "B", 1), ("frames_stationary_fall", "B", 1), ("contact_plane", "d", 4),
           ("contact_plane_cell", "I", 1), ("collision_normal", "d", 3), ("sliding_normal", "d", 3),
           ("collide_count", "I", 1))
REALS = ("origin", "orientation", "contact_plane", "collision_normal", "sliding_normal")

HEIGHTS = [float(i) * 0.5 for i in range(256)]
#: a creature's shape without IsPlayer: players pass through each other, not through it
CREATURE = MoverSpec(spheres=PLAYER.spheres, state=["Contact", "OnWalkable"])
GROUND = Plane(Vec3(0.0, 0.0, 1.0), -50.0)


def _world() -> engine.World:
    """Two landblocks side by side (A9B4 and AAB4), flat at 50 m."""
    return engine.world_from_scene_dict({
        "format": "acphys-scene/1", "name": "batch", "height_table": HEIGHTS,
        "landblocks": [{"id": "A9B4", "heights": [100] * 81}, {"id": "AAB4", "heights": [100] * 81}],
    })


def _cell(lb: int, x: float, y: float) -> int:
    return (lb << 16) | (int(x // 24) * 8 + int(y // 24) + 1)


def _movers(world: engine.World) -> list[int]:
    spots = [(0xA9B4, 20.0, 20.0), (0xA9B4, 100.0, 60.0), (0xA9B4, 190.0, 100.0), (0xA9B4, 22.0, 20.0)]
    return [world.add_mover(PLAYER if k < 3 else CREATURE, Position.at(_cell(lb, x, y), Vec3(x, y, 50.0)), GROUND,
                            _cell(lb, x, y)) for k, (lb, x, y) in enumerate(spots)]


def _bits(x: float) -> bytes:
    return struct.pack("<d", x)


def _expected_row(r: Any) -> tuple[list[float], list[int]]:
    """A MoveResult as the values the batch documents (an independent reading of the layout): the reals in
    column order, then the integers in column order."""
    o, q = r.position.frame.origin, r.position.frame.orientation
    nan3 = [math.nan] * 3
    plane = [math.nan] * 4 if r.contact_plane is None else [*r.contact_plane.normal.as_tuple(), r.contact_plane.d]
    cn = nan3 if r.collision_normal is None else list(r.collision_normal.as_tuple())
    sn = nan3 if r.sliding_normal is None else list(r.sliding_normal.as_tuple())
    status = Status.RESOLVED
    for flag, on in ((Status.OK, r.ok), (Status.CONTACT, r.contact), (Status.ON_WALKABLE, r.on_walkable),
                     (Status.WATER_CONTACT, r.water_contact),
                     (Status.HAS_CONTACT_PLANE, r.contact_plane is not None),
                     (Status.HAS_CONTACT_PLANE_CELL, r.contact_plane_cell is not None),
                     (Status.HAS_COLLISION_NORMAL, r.collision_normal is not None),
                     (Status.HAS_SLIDING_NORMAL, r.sliding_normal is not None),
                     (Status.HAS_FRAMES_STATIONARY_FALL, r.frames_stationary_fall is not None)):
        if on:
            status |= flag
    bits = {"Contact": 1, "OnWalkable": 2, "Sliding": 4, "WaterContact": 8, "StationaryFall": 16,
            "StationaryStop": 32, "StationaryStuck": 64}
    transient = sum(bits[name] for name in r.transient_state)
    fsf = 255 if r.frames_stationary_fall is None else r.frames_stationary_fall
    ints = [r.seq, r.position.cell_id, status | (transient << 16), TRANSITION_STATES.index(r.transition_state), fsf,
            r.contact_plane_cell or 0, len(r.collide_objects)]
    return [o.x, o.y, o.z, q.w, q.x, q.y, q.z, *plane, *cn, *sn], ints


def _item_values(rows: BatchRows, k: int) -> tuple[list[float], list[int]]:
    """Item k's values read back from the column buffers: its reals, then its integers, in column order."""
    columns = rows.columns()
    assert list(columns) == [name for name, _code, _width in COLUMNS]
    reals: list[float] = []
    ints: list[int] = []
    for name, code, width in COLUMNS:
        data = columns[name]
        size = struct.calcsize("<" + code) * width
        assert len(data) == size * rows.count, name
        values = struct.unpack(f"<{width}{code}", data[k * size:(k + 1) * size])
        (reals if name in REALS else ints).extend(values)
    return reals, ints


def _assert_rows_equal(rows: BatchRows, expected: list[Any]) -> None:
    assert rows.count == len(expected)
    for k, r in enumerate(expected):
        reals, ints = _item_values(rows, k)
        if r is None:
            # NaN reals; seq, cell and flags 0; both u8 codes 255; the plane's cell and the count 0
            assert all(math.isnan(x) for x in reals) and ints == [0, 0, 0, 255, 255, 0, 0], k
            continue
        want_reals, want_ints = _expected_row(r)
        assert [_bits(x) for x in reals] == [_bits(x) for x in want_reals], k
        assert ints == want_ints, k


def _walk() -> list[tuple[int, tuple[float, float, float]]]:
    """(mover index, offset): mover 0 twice in a row, mover 1 down into the ground, mover 2 across into AAB4,
    mover 0 at last into mover 3, which stands 2 m east of where it started."""
    return [(0, (0.5, 0.0, 0.0)), (0, (0.5, 0.3, 0.0)), (1, (1.0, 0.0, -0.5)), (2, (3.0, 0.0, 0.0)),
            (1, (0.0, 0.4, 0.0)), (0, (-0.2, -0.2, 0.0)), (2, (0.5, 0.1, 0.0)),
            (0, (1.0, -0.1, 0.0))]


def test_offset_items_equal_world_move_bit_for_bit() -> None:
    one, batch = _world(), _world()
    ids_one, ids_batch = _movers(one), _movers(batch)
    walk = _walk()
    expected = [one.move(ids_one[k], one.mover(ids_one[k]).position.moved(Vec3(*off))) for k, off in walk]
    rows = BatchRows()
    movers = [batch.mover(ids_batch[k]) for k, _ in walk]
    vectors = [c for _, off in walk for c in off]
    assert run_batch(batch.landscape, movers, OFFSET, vectors, rows) == len(walk)
    assert rows.errors == []
    _assert_rows_equal(rows, expected)
    assert [repr(r) for r in rows.results] == [repr(r) for r in expected]
    # the movers end where the item-by-item world left them
    for a, b in zip(ids_one, ids_batch):
        assert repr(one.mover_state(a)) == repr(batch.mover_state(b))
    assert expected[-1].collide_objects == [ids_one[3]]  # the last move ran into mover 3


def test_to_items_with_and_without_cell_and_orientation() -> None:
    one, batch = _world(), _world()
    ids_one, ids_batch = _movers(one), _movers(batch)
    turn = engine.Quat(math.cos(0.3), 0.0, 0.0, math.sin(0.3))
    targets = [(0, 0, (21.0, 20.0, 50.0), None), (1, _cell(0xA9B4, 101.0, 61.0), (101.0, 61.0, 50.0), turn)]
    expected = []
    for k, cell, origin, quat in targets:
        pos = one.mover(ids_one[k]).position
        target = Position.at(cell or pos.cell_id, Vec3(*origin), quat or pos.frame.orientation)
        expected.append(one.move(ids_one[k], target))
    rows = BatchRows()
    run_batch(batch.landscape, [batch.mover(ids_batch[k]) for k, *_ in targets], TO,
              [c for *_, origin, _q in targets for c in origin], rows,
              cells=[cell for _, cell, _o, _q in targets],
              orientations=[c for *_, q in targets for c in ((0.0, 0.0, 0.0, 0.0) if q is None else q.as_tuple())])
    _assert_rows_equal(rows, expected)


def test_motion_items_equal_world_step_and_velocities_last_one_move() -> None:
    one, batch = _world(), _world()
    ids_one, ids_batch = _movers(one), _movers(batch)
    steps = [(0, (0.1, 0.0, 0.0), 1 / 30), (1, (0.0, 0.2, 0.0), 0.5), (0, (0.1, 0.0, 0.0), 0.01)]
    expected = [one.step(ids_one[k], Vec3(*m), dt) for k, m, dt in steps]
    rows = BatchRows()
    run_batch(batch.landscape, [batch.mover(ids_batch[k]) for k, *_ in steps], MOTION,
              [c for _, m, _dt in steps for c in m], rows, dts=[dt for *_, dt in steps])
    _assert_rows_equal(rows, expected)
    # a velocity given with an offset item is that move's only, as with World.move
    rows = BatchRows()
    mover = batch.mover(ids_batch[2])
    run_batch(batch.landscape, [mover], OFFSET, [0.5, 0.0, 0.0], rows, velocities=[0.0, 30.0, 40.0])
    assert mover.velocity == Vec3(0.0, 0.0, 0.0)


def test_refused_and_absent_items_get_empty_rows_and_change_nothing() -> None:
    world = _world()
    ids = _movers(world)
    before = [repr(world.mover_state(m)) for m in ids]
    rows = BatchRows()
    movers = [world.mover(ids[0]), None, world.mover(ids[1]), world.mover(ids[2])]
    vectors = [math.nan, 0.0, 0.0, 1.0, 0.0, 0.0, 0.5, 0.0, 0.0, 1e30, 0.0, 0.0]
    assert run_batch(world.landscape, movers, OFFSET, vectors, rows) == 4
    assert [i for i, _ in rows.errors] == [0, 3]
    assert isinstance(rows.errors[0][1], NonFiniteError)
    assert rows.results[0] is None and rows.results[1] is None and rows.results[3] is None
    assert rows.results[2] is not None and rows.results[2].ok
    _assert_rows_equal(rows, [None, None, rows.results[2], None])
    assert repr(world.mover_state(ids[0])) == before[0] and repr(world.mover_state(ids[2])) == before[2]
    # an unknown cell in a TO item: refused, the mover where it was
    rows = BatchRows()
    run_batch(world.landscape, [world.mover(ids[0])], TO, [20.0, 20.0, 50.0], rows, cells=[0xA9B40FFF])
    assert isinstance(rows.errors[0][1], UnknownCellError)
    assert repr(world.mover_state(ids[0])) == before[0]


def test_stop_if_stops_after_the_item_that_leaves_and_goes_on_from_the_next() -> None:
    world = _world()
    ids = _movers(world)
    walk = _walk()
    movers = [world.mover(ids[k]) for k, _ in walk]
    vectors = [c for _, off in walk for c in off]
    rows = BatchRows()
    leaves = lambda lb: lb != 0xA9B4  # noqa: E731
    stopped = run_batch(world.landscape, movers, OFFSET, vectors, rows, stop_if=leaves)
    assert stopped == 3  # mover 2 walks from x = 190 to 193 m: into AAB4
    result = rows.results[3]
    assert result is not None and result.position.cell_id >> 16 == 0xAAB4
    assert rows.count == 3 and len(rows.columns()["seq"]) == 8 * 3  # the leaving item: a result, no row yet
    assert run_batch(world.landscape, movers, OFFSET, vectors, rows, start=4, stop_if=leaves) == 6
    assert len(rows.results) == 7
    assert run_batch(world.landscape, movers, OFFSET, vectors, rows, start=7, stop_if=leaves) == 8


def test_an_empty_batch_runs_nothing() -> None:
    world = _world()
    rows = BatchRows()
    assert run_batch(world.landscape, [], OFFSET, [], rows) == 0
    assert set(rows.columns().values()) == {b""} and rows.count == 0 and rows.results == []


def _le(values: list[float]) -> bytes:
    return struct.pack(f"<{len(values)}d", *values)


def test_reals_as_little_endian_bytes_run_as_the_same_lists() -> None:
    """Every real argument may be given as its little-endian float64 bytes (a column's wire bytes): the
    rows are the lists' bit for bit, for each kind, with a velocity and a given orientation."""
    turn = (math.cos(0.3), 0.0, 0.0, math.sin(0.3))
    cases: list[tuple[int, list[int], dict[str, list[float]]]] = [
        (OFFSET, [0, 1, 0], {"vectors": [0.5, 0.0, 0.0, 1.0, 0.0, -0.5, -0.2, 0.3, 0.0],
                             "velocities": [0.0, 3.0, 4.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0]}),
        (TO, [0, 1], {"vectors": [21.0, 20.0, 50.0, 101.0, 61.0, 50.0],
                      "orientations": [0.0, 0.0, 0.0, 0.0, *turn]}),
        (MOTION, [1, 0], {"vectors": [0.1, 0.0, 0.0, 0.0, 0.2, 0.0], "dts": [1 / 30, 0.5]}),
    ]
    for kind, picks, reals in cases:
        one, other = _world(), _world()
        ids_one, ids_other = _movers(one), _movers(other)
        by_list, by_bytes = BatchRows(), BatchRows()
        movers_one: list[Mover | None] = [one.mover(ids_one[k]) for k in picks]
        movers_other: list[Mover | None] = [other.mover(ids_other[k]) for k in picks]
        got = {name: reals.get(name) for name in ("orientations", "velocities", "dts")}
        run_batch(one.landscape, movers_one, kind, reals["vectors"], by_list, orientations=got["orientations"],
                  velocities=got["velocities"], dts=got["dts"])
        le = {name: None if values is None else _le(values) for name, values in got.items()}
        run_batch(other.landscape, movers_other, kind, _le(reals["vectors"]), by_bytes,
                  orientations=le["orientations"], velocities=le["velocities"], dts=le["dts"])
        assert by_list.errors == [] and by_bytes.errors == []
        assert by_list.count == len(picks) and by_bytes.count == len(picks)
        assert by_bytes.columns() == by_list.columns()
        if kind == TO:  # the given orientation read from the bytes is the second item's own
            assert struct.unpack("<8d", by_bytes.columns()["orientation"])[4:] == turn
    # a value that is not finite fails its item as in a list, and the bytes stop where they end
    world = _world()
    ids = _movers(world)
    rows = BatchRows()
    run_batch(world.landscape, [world.mover(ids[0]), world.mover(ids[1])], OFFSET,
              _le([math.nan, 0.0, 0.0, 0.5]), rows)
    assert [i for i, _ in rows.errors] == [0, 1] and isinstance(rows.errors[0][1], NonFiniteError)
    assert rows.results == [None, None]
