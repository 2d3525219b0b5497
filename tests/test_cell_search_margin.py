"""The cell search's neighbour margin outdoors (find_cell_list with LandCell.add_all_outside_cells).

A sphere is in the outdoor cell under its centre, and in each neighbouring
cell (the eight around it, across a landblock's edge too) whose border its
centre is nearer than its radius: the client's check_add_cell_boundary.
Each test puts one sphere just inside and just outside that margin (0.1 mm
either side: less than EPSILON, so a margin widened by it is noticed) and
checks which cells the search finds, by hand: cell (x, y) of a landblock is
x * 8 + y + 1, each 24 m square.
"""

from __future__ import annotations

from typing import Any

import pytest

from engine.cells.cell_array import CellArray
from engine.cells.find_cell_list import find_cell_list
from engine.geometry import Frame, Position, Sphere, Vec3
from benchmarks.scenes import world_from_heights

BLOCKS = ((0xA9, 0xB4), (0xAA, 0xB4), (0xA9, 0xB5), (0xAA, 0xB5))  # 2 x 2 landblocks, flat at 50 m
WORLD = world_from_heights(lambda bx, by, x, y: 100, BLOCKS)
A9B4 = 0xA9B40000
Z = 50.5
NEAR = 1e-4  # how far inside or outside the margin the centre is (m)


def cell_id(block: int, x: int, y: int) -> int:
    return block | (x * 8 + y + 1)


def _search(x: float, y: float, radius: float, where: Any = None) -> tuple[set[int], Any]:
    """The cells one sphere at (x, y) of landblock A9B4 touches, and the cell holding its centre."""
    home = cell_id(A9B4, min(int(x // 24), 7), min(int(y // 24), 7))
    array = CellArray(WORLD.landscape if where is None else where)
    found = find_cell_list(Position(home, Frame(Vec3(x, y, Z - radius))), 1, [Sphere(Vec3(x, y, Z), radius)],
                           array, True, None)
    return set(array.ids()), found


# the home cell (3, 3) spans [72, 96) in x and y; (dx, dy) names the neighbour, and the centre
# sits `radius - NEAR` (inside the margin) or `radius + NEAR` (outside) from the borders it faces
DIRECTIONS = [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)]


def _near_border(d: int, gap: float) -> float:
    return {1: 96.0 - gap, -1: 72.0 + gap, 0: 84.0}[d]


@pytest.mark.parametrize("radius", [0.48, 1.5])
@pytest.mark.parametrize(("dx", "dy"), DIRECTIONS)
def test_a_neighbour_is_in_exactly_when_the_sphere_reaches_within_its_radius(dx: int, dy: int, radius: float) -> None:
    inside, found = _search(_near_border(dx, radius - NEAR), _near_border(dy, radius - NEAR), radius)
    expected = {cell_id(A9B4, 3, 3), cell_id(A9B4, 3 + dx, 3), cell_id(A9B4, 3, 3 + dy), cell_id(A9B4, 3 + dx, 3 + dy)}
    assert inside == expected  # the home cell, the one or three it reaches into
    assert found.id == cell_id(A9B4, 3, 3)
    outside, _ = _search(_near_border(dx, radius + NEAR), _near_border(dy, radius + NEAR), radius)
    assert outside == {cell_id(A9B4, 3, 3)}


def test_a_corner_neighbour_needs_both_borders_within_reach() -> None:
    # near the east border, 1 cm beyond the reach of the north one: east only, no corner
    cells, _ = _search(96.0 - 0.47, 96.0 - 0.49, 0.48)
    assert cells == {cell_id(A9B4, 3, 3), cell_id(A9B4, 4, 3)}
    cells, _ = _search(96.0 - 0.49, 96.0 - 0.47, 0.48)
    assert cells == {cell_id(A9B4, 3, 3), cell_id(A9B4, 3, 4)}


@pytest.mark.parametrize(("gap", "reaches"), [(0.47, True), (0.49, False)])
def test_the_margin_reaches_into_the_next_landblock(gap: float, reaches: bool) -> None:
    # cell (7, 3) of A9B4 ends at x = 192, where cell (0, 3) of AAB4 starts
    cells, found = _search(192.0 - gap, 84.0, 0.48)
    assert found.id == cell_id(A9B4, 7, 3)
    assert cells == {cell_id(A9B4, 7, 3)} | ({cell_id(0xAAB40000, 0, 3)} if reaches else set())


@pytest.mark.parametrize(("x", "reaches"), [(192.47, True), (192.49, False)])
def test_a_centre_past_the_landblock_edge_is_searched_from_the_next_landblock(x: float, reaches: bool) -> None:
    # the position is still A9B4's, the centre 0.47 m (0.49 m) into AAB4: its cell there, and
    # back across the edge when within the radius
    array = CellArray(WORLD.landscape)
    find_cell_list(Position(cell_id(A9B4, 7, 3), Frame(Vec3(x, 84.0, Z - 0.48))), 1,
                   [Sphere(Vec3(x, 84.0, Z), 0.48)], array, False, None)
    assert set(array.ids()) == {cell_id(0xAAB40000, 0, 3)} | ({cell_id(A9B4, 7, 3)} if reaches else set())


def test_the_world_and_its_landscape_answer_alike() -> None:
    # the search calls the World's own Landscape natively and anything else by name
    for x, y in [(96.0 - 0.47, 96.0 - 0.47), (72.0 + 0.49, 84.0), (192.0 - 0.47, 84.0)]:
        assert _search(x, y, 0.48, WORLD) == _search(x, y, 0.48)


def test_a_centre_within_epsilon_of_the_landblock_edge_counts_as_on_it() -> None:
    # 0.1 mm west of AAB4's edge, in AAB4's frame: taken as x = 0 (the client snaps coordinates
    # within EPSILON of 0), so AAB4's cell comes first and A9B4's, within the radius, after it;
    # unsnapped the centre would be A9B4's and the order the other way round
    array = CellArray(WORLD.landscape)
    aab4 = 0xAAB40000
    find_cell_list(Position(cell_id(aab4, 0, 3), Frame(Vec3(-1e-4, 84.0, Z - 0.48))), 1,
                   [Sphere(Vec3(-1e-4, 84.0, Z), 0.48)], array, False, None)
    assert array.ids() == [cell_id(aab4, 0, 3), cell_id(A9B4, 7, 3)]
