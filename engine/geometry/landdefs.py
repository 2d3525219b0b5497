"""LandDefs: the world grid of landblocks and cells and their id arithmetic.

A cell id is `(XXYY << 16) | index`. Outdoor cells have index 1..64
(`cx * 8 + cy + 1`); EnvCells 0x0100..0xFFFD. "lcoords" count 24 m cells from
the world's south-west corner (0..2039 on each axis).
"""

from __future__ import annotations

import math

from ..constants import (
    BLOCK_CELL_ID,
    BLOCK_LENGTH,
    CELL_LENGTH,
    EPSILON,
    FIRST_ENV_CELL,
    FIRST_LAND_CELL,
    LAND_LENGTH,
    LAST_ENV_CELL,
    LAST_LAND_CELL,
)
from .vec3 import ZERO, Vec3

__all__ = [
    "landblock_of",
    "is_outdoor_cell",
    "is_env_cell",
    "cell_in_range",
    "blockid_to_lcoord",
    "lcoord_to_gid",
    "get_block_offset",
    "outdoor_cell_id",
    "adjust_to_outside",
]


def landblock_of(cell_id: int) -> int:
    """The 16-bit landblock id XXYY of a cell id."""
    return (cell_id >> 16) & 0xFFFF


def is_outdoor_cell(cell_id: int) -> bool:
    return (cell_id & 0xFFFF) < FIRST_ENV_CELL


def is_env_cell(cell_id: int) -> bool:
    return (cell_id & 0xFFFF) >= FIRST_ENV_CELL


def cell_in_range(index: int) -> bool:
    """LandDefs.cell_in_range: a valid low word (landblock, land or env cell)."""
    return (
        index == BLOCK_CELL_ID
        or FIRST_LAND_CELL <= index <= LAST_LAND_CELL
        or FIRST_ENV_CELL <= index <= LAST_ENV_CELL
    )


def blockid_to_lcoord(cell_id: int) -> tuple[int, int]:
    """The lcoord of the landblock's south-west cell."""
    return ((cell_id >> 24) & 0xFF) << 3, ((cell_id >> 16) & 0xFF) << 3


def lcoord_to_gid(x: int, y: int) -> int:
    """The outdoor cell id at lcoord (x, y), or 0 outside the world."""
    if x < 0 or y < 0 or x >= LAND_LENGTH or y >= LAND_LENGTH:
        return 0
    block = ((x >> 3) << 8) | (y >> 3)
    cell = FIRST_LAND_CELL + ((x & 7) << 3) + (y & 7)
    return (block << 16) | cell


_block_offset_cache: dict[tuple[int, int], Vec3] = {}


def get_block_offset(cell_from: int, cell_to: int) -> Vec3:
    """Offset from cell_from's landblock origin to cell_to's (GetBlockOffset).

    Coordinates of a point in cell_to's landblock plus this offset are the
    same point in cell_from's landblock.
    """
    lb_from = cell_from >> 16
    lb_to = cell_to >> 16
    if lb_from == lb_to:
        return ZERO
    key = (lb_from, lb_to)
    off = _block_offset_cache.get(key)
    if off is None:
        dx = ((lb_to >> 8) & 0xFF) - ((lb_from >> 8) & 0xFF)
        dy = (lb_to & 0xFF) - (lb_from & 0xFF)
        off = Vec3(dx * BLOCK_LENGTH, dy * BLOCK_LENGTH, 0.0)
        if len(_block_offset_cache) < 65536:
            _block_offset_cache[key] = off
    return off


def outdoor_cell_id(landblock: int, x: float, y: float) -> int:
    """Outdoor cell id of the landblock-local point (x, y), clamped into 0..7.

    Position.GetOutdoorCell without the resolution across landblocks (that is
    adjust_to_outside's job).
    """
    cx = min(max(int(x // CELL_LENGTH), 0), 7)
    cy = min(max(int(y // CELL_LENGTH), 0), 7)
    return (landblock << 16) | (cx * 8 + cy + 1)


def adjust_to_outside(cell_id: int, origin: Vec3) -> tuple[int, Vec3]:
    """LandDefs.AdjustToOutside: re-home a point into the outdoor cell under it.

    Returns the new cell id (0 when the point leaves the world) and the origin
    re-expressed in that cell's landblock.
    """
    if not cell_in_range(cell_id & 0xFFFF):
        return 0, origin
    x, y = origin.x, origin.y
    if abs(x) < EPSILON:
        x = 0.0
    if abs(y) < EPSILON:
        y = 0.0
    bx, by = blockid_to_lcoord(cell_id)
    lx = bx + math.floor(x / CELL_LENGTH)
    ly = by + math.floor(y / CELL_LENGTH)
    if lx < 0 or ly < 0 or lx >= LAND_LENGTH or ly >= LAND_LENGTH:
        return 0, origin
    new_id = lcoord_to_gid(int(lx), int(ly))
    x -= math.floor(x / BLOCK_LENGTH) * BLOCK_LENGTH
    y -= math.floor(y / BLOCK_LENGTH) * BLOCK_LENGTH
    return new_id, Vec3(x, y, origin.z)
