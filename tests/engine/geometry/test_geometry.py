"""Primitives against hand-worked values."""

from __future__ import annotations

import math

import pytest

from engine.constants import EPSILON, FLOOR_Z
from engine.geometry import Frame, Plane, Position, Quat, Vec3
from engine.geometry.landdefs import adjust_to_outside, get_block_offset, lcoord_to_gid
from engine.transition.object_info import is_valid_walkable


def test_plane_distance_and_side() -> None:
    # z = 2 plane: n = (0, 0, 1), d = -2
    p = Plane(Vec3(0, 0, 1), -2.0)
    assert p.distance(Vec3(5, 5, 3.5)) == 1.5
    assert p.distance(Vec3(0, 0, 2.0)) == 0.0
    assert p.side(Vec3(0, 0, 2.0 + EPSILON / 2)) == 2  # CLOSE
    assert p.side(Vec3(0, 0, 1.0)) == 1  # BEHIND


@pytest.mark.parametrize("single", [True, False])
def test_plane_from_points_is_ccw_facing_and_mean_d(single: bool) -> None:
    # a unit square at z=1, counter-clockwise seen from above: normal +z, d = -1
    p = Plane.from_points([Vec3(0, 0, 1), Vec3(1, 0, 1), Vec3(1, 1, 1), Vec3(0, 1, 1)], single)
    assert p.normal == Vec3(0, 0, 1)
    assert p.d == -1.0


@pytest.mark.parametrize(("single", "tol"), [(True, 1e-6), (False, 1e-12)])
def test_snap_to_plane_follows_slope(single: bool, tol: float) -> None:
    # plane rising 1 m per metre of x: normal (-1, 0, 1)/sqrt2; moving 1 m in x must rise 1 m
    n = Vec3(-1, 0, 1) * (1 / math.sqrt(2))
    v = Plane(n, 0.0).snap_to_plane(Vec3(1.0, 0.0, 0.0), single)
    assert math.isclose(v.z, 1.0, abs_tol=tol)
    # 100 m up (d = -100 sqrt(1/2)): the client's d / n.z terms cancel, in
    # float32 with an error of a few float32 ulps of 100 m (7.6e-6 m each)
    v = Plane(n, -100.0 * math.sqrt(0.5)).snap_to_plane(Vec3(1.0, 0.0, 0.0), single)
    assert math.isclose(v.z, 1.0, abs_tol=1e-4 if single else 1e-12)


def test_block_offsets_between_landblocks() -> None:
    a = 0xA9B40001
    assert get_block_offset(a, 0xA9B40040) == Vec3(0, 0, 0)
    assert get_block_offset(a, 0xAAB40001) == Vec3(192, 0, 0)  # one block east
    assert get_block_offset(a, 0xA9B30001) == Vec3(0, -192, 0)  # one block south
    assert get_block_offset(0xAAB50001, a) == Vec3(-192, -192, 0)


def test_lcoord_and_adjust_to_outside_cross_a_seam() -> None:
    # lcoord (0x A9 * 8 + 7, 0xB4 * 8 + 0): the last column of block A9B4, cell index 7*8+0+1 = 57
    assert lcoord_to_gid(0xA9 * 8 + 7, 0xB4 * 8) == 0xA9B40039
    # x = 193 in block A9B4 is x = 1 in block AAB4, cell (0, 0) -> index 1
    cell, origin = adjust_to_outside(0xA9B40039, Vec3(193.0, 5.0, 10.0))
    assert cell == 0xAAB40001
    assert origin == Vec3(1.0, 5.0, 10.0)
    # off the world's south-west corner
    assert adjust_to_outside(0x00000001, Vec3(-1.0, 5.0, 0.0))[0] == 0


def test_walkable_threshold() -> None:
    assert is_valid_walkable(Vec3(0, 0, 1))
    assert is_valid_walkable(Vec3(0, math.sqrt(1 - FLOOR_Z**2), FLOOR_Z))
    assert not is_valid_walkable(Vec3(0, math.sqrt(1 - 0.66**2), 0.66))


def test_frame_rotation_round_trip() -> None:
    # heading 90 (east): the object's forward +y points along world +x
    q = Quat.from_heading(90.0)
    f = Frame(Vec3(10, 20, 30), q)
    fwd = f.local_to_global_vec(Vec3(0, 1, 0))
    assert math.isclose(fwd.x, 1.0, abs_tol=1e-12) and math.isclose(fwd.y, 0.0, abs_tol=1e-12)
    p = Vec3(1.5, -2.0, 0.25)
    back = f.global_to_local(f.local_to_global(p))
    assert all(math.isclose(a, b, abs_tol=1e-12) for a, b in zip(back, p))


def test_position_offset_across_landblocks() -> None:
    a = Position.at(0xA9B40039, Vec3(190.0, 10.0, 5.0))
    b = Position.at(0xAAB40001, Vec3(2.0, 11.0, 6.0))
    assert a.get_offset(b) == Vec3(4.0, 1.0, 1.0)
