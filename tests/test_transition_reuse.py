"""State a move keeps for the next one, or for the rest of its transition, must never go stale.

- A mover keeps its spheres as its transitions move them (ScaledSpheres, the scaling half of
  SpherePath.InitSphere) from move to move: a new sphere list, scale or precision must make new ones.
- A transition's CellArray remembers the landblock of its last outdoor-cell lookup: every lookup
  must still give what the landscape gives, and a reset array must see landblocks loaded since.
"""

from __future__ import annotations

import dataclasses
import struct

from engine.cells.cell_array import CellArray
from engine.geometry import Position, Sphere, Vec3
from benchmarks.scenes import PLAYER, world_from_heights


def cell(lb: int, x: float, y: float) -> int:
    """The outdoor cell id of landblock-local (x, y): 24 m cells, numbered from 1 along y first."""
    return (lb << 16) | (int(x // 24) * 8 + int(y // 24) + 1)


def at(lb: int, x: float, y: float, z: float) -> Position:
    return Position.at(cell(lb, x, y), Vec3(x, y, z))


def f32(x: float) -> float:
    """x rounded to float32 through struct, independently of the engine's rounding."""
    return float(struct.unpack("<f", struct.pack("<f", x))[0])


def _local(world, mover, single: bool = True) -> list[tuple[float, float, float, float]]:
    settings = dataclasses.replace(world.settings, single_precision=single)
    t = mover.make_transition(world.landscape, settings)
    path = t.sphere_path
    assert path.num_sphere == len(path.local_sphere)
    return [(s.center.x, s.center.y, s.center.z, s.radius) for s in path.local_sphere]


def test_scaled_spheres_follow_the_movers_sphere_list_scale_and_precision() -> None:
    world = world_from_heights(lambda bx, by, x, y: 100)
    mover = world.mover(world.add_mover(PLAYER, at(0xA9B4, 12.0, 12.0, 50.0)))
    # PLAYER: foot sphere at z 0.48, head at 1.35, both of radius 0.48; scale 1
    assert _local(world, mover) == [(0.0, 0.0, f32(0.48), f32(0.48)), (0.0, 0.0, f32(1.35), f32(0.48))]
    first = mover.scaled_spheres
    _local(world, mover)
    assert mover.scaled_spheres is first  # nothing changed: the same spheres serve the next move

    mover.scale = 2.0  # doubling a float32 is exact
    assert _local(world, mover) == [(0.0, 0.0, 2 * f32(0.48), 2 * f32(0.48)), (0.0, 0.0, 2 * f32(1.35), 2 * f32(0.48))]

    mover.spheres = [Sphere(Vec3(0.0, 0.0, 0.3), 0.3)]
    assert _local(world, mover) == [(0.0, 0.0, 2 * f32(0.3), 2 * f32(0.3))]

    # double precision: no float32 rounding at all (0.3 * 2 is 0.6 in binary64)
    assert _local(world, mover, single=False) == [(0.0, 0.0, 0.3 * 2.0, 0.3 * 2.0)]
    assert f32(0.3) * 2 != 0.3 * 2.0  # (so the line above could tell the precisions apart)
    assert _local(world, mover) == [(0.0, 0.0, 2 * f32(0.3), 2 * f32(0.3))]


def test_cell_array_landcell_gives_what_the_landscape_gives() -> None:
    world = world_from_heights(lambda bx, by, x, y: 100, blocks=((0xA9, 0xB4), (0xA9, 0xB5)))
    landscape = world.landscape
    cells = CellArray(landscape)
    ids = [cell(0xA9B4, 12.0, 12.0), cell(0xA9B5, 180.0, 3.0), cell(0xA9B4, 100.0, 190.0), cell(0xAAB4, 5.0, 5.0),
           cell(0xA9B5, 12.0, 12.0), 0xA9B40100, cell(0xAAB4, 30.0, 30.0), cell(0xA9B4, 50.0, 50.0)]
    for cell_id in ids:
        got = cells.landcell(cell_id)
        assert got is landscape.get_landcell(cell_id), f"{cell_id:08X}"
        if (cell_id >> 16) != 0xAAB4 and (cell_id & 0xFFFF) < 0x100:
            assert got is not None and got.id == cell_id

    # a landblock loaded after a transition: the next transition's (reset) array finds its cells
    other = world_from_heights(lambda bx, by, x, y: 90, blocks=((0xAA, 0xB4),))
    world.add_landblock(other.landblocks[0xAAB4])
    cells.reset(landscape)
    found = cells.landcell(cell(0xAAB4, 5.0, 5.0))
    assert found is not None and found is landscape.get_landcell(cell(0xAAB4, 5.0, 5.0))
