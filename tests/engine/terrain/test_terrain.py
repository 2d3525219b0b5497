"""Terrain: the split rule, heights, normals and water, worked by hand."""

from __future__ import annotations

import math

import pytest

from engine.geometry import Vec3
from engine.terrain.landblock import LandblockTerrain
from engine.terrain.split import split_sw_to_ne
from engine.terrain.water import WaterType

TABLE = [float(i) for i in range(256)]  # height byte b -> b metres


def test_split_rule_on_hand_computed_cells() -> None:
    # gx = gy = 0: s = -1369149221 mod 2^32 = 2925818075; * 2.3283064e-10 = 0.681 >= 0.5 -> SW-NE
    assert split_sw_to_ne(0, 0) is True
    # gx = 1, gy = 0: s = -1109124029 - 1369149221 = -2478273250 mod 2^32 = 1816694046 -> 0.423 < 0.5
    assert split_sw_to_ne(1, 0) is False
    # gx = 0, gy = 1: s = 1813693831 - 1369149221 = 444544610 -> 0.1035 < 0.5
    assert split_sw_to_ne(0, 1) is False


def test_flat_landblock_height_and_normal() -> None:
    t = LandblockTerrain(0xA9B4, [50] * 81, TABLE)
    assert t.height_at(100.3, 17.9) == 50.0
    assert t.normal_at(5.0, 5.0) == Vec3(0, 0, 1)


def test_ramp_along_x_is_exact_on_either_diagonal() -> None:
    # height byte = 2 * column: z = x / 12 everywhere (a plane), whatever the split
    heights = [2 * x for x in range(9) for _y in range(9)]
    t = LandblockTerrain(0x1234, heights, TABLE)
    for x, y in [(1.0, 1.0), (30.0, 170.0), (191.0, 3.0), (100.0, 100.0)]:
        assert math.isclose(t.height_at(x, y), x / 12.0, abs_tol=1e-9)
    n = t.normal_at(40.0, 40.0)
    # z = x/12  ->  normal ∝ (-1/12, 0, 1)
    assert math.isclose(n.x / n.z, -1.0 / 12.0, rel_tol=1e-9) and n.y == 0.0


def test_split_decides_height_in_a_saddle_cell() -> None:
    # Raising only a cell's north-east corner makes the diagonal decide the height.
    heights = [0] * 81
    heights[1 * 9 + 1] = 24  # vertex (1, 1): NE corner of cell (0, 0)
    t = LandblockTerrain(0x0000, heights, TABLE)
    # cell (0,0) is cut SW-NE: (18, 6) is in (v00, v10, v11), v11 = (24, 24, 24): z = y
    assert math.isclose(t.height_at(18.0, 6.0), 6.0, abs_tol=1e-9)

    heights = [0] * 81
    heights[2 * 9 + 1] = 24  # vertex (2, 1): NE corner of cell (1, 0)
    t = LandblockTerrain(0x0000, heights, TABLE)
    # cell (1,0) (gx = 1) is cut NW-SE: (42, 6) is in (v00, v10, v01), all at 0 m
    # (a SW-NE cut would put it on (v00, v10, v11) at z = 6)
    assert t.height_at(42.0, 6.0) == 0.0


def water_word() -> int:
    return 0x11 << 2  # WaterStandingFresh


def test_water_types_and_depths() -> None:
    terrain = [0] * 81
    for x in range(2):
        for y in range(2):
            terrain[x * 9 + y] = water_word()  # cell (0,0) fully flooded
    terrain[5 * 9 + 5] = water_word()  # one corner of cells (4,4),(4,5),(5,4),(5,5)
    t = LandblockTerrain(0x0101, [10] * 81, TABLE, terrain)
    assert t.cell_water[0, 0] == WaterType.ENTIRELY_WATER
    assert t.cell_water[4, 4] == WaterType.PARTIALLY_WATER
    assert t.cell_water[3, 3] == WaterType.NOT_WATER
    assert t.water_type == WaterType.PARTIALLY_WATER
    cell_44 = (0x0101 << 16) | (4 * 8 + 4 + 1)
    # nearest corner of (100, 100) in cell (4,4) is vertex (4,4): dry -> shore depth 0.1
    assert t.calc_water_depth(cell_44, Vec3(100.0, 100.0, 0)) == pytest.approx(0.1)
    # nearest corner of (118, 118) is vertex (5,5): water -> 0.45
    assert t.calc_water_depth(cell_44, Vec3(118.0, 118.0, 0)) == pytest.approx(0.45)


def test_bad_terrain_input_is_refused() -> None:
    with pytest.raises(ValueError, match="81 height"):
        LandblockTerrain(1, [0] * 80, TABLE)
    with pytest.raises(ValueError, match="out of 0..255"):
        LandblockTerrain(1, [0] * 80 + [300], TABLE)
