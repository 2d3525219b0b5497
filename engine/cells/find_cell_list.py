"""find_cell_list: which cells a set of spheres at a position touches."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..geometry import ZERO, Position, Sphere
from ..geometry.landdefs import get_block_offset
from .cell_array import CellArray
from .env_cell import EnvCell
from .land_cell import add_all_outside_cells
from .obj_cell import ObjCell

if TYPE_CHECKING:
    from ..transition.sphere_path import SpherePath

__all__ = ["find_cell_list"]


def find_cell_list(
    position: Position,
    num_sphere: int,
    spheres: list[Sphere],
    cell_array: CellArray,
    find_cell: bool,
    path: SpherePath | None,
) -> ObjCell | None:
    """Fill `cell_array` with the cells the spheres touch (ObjCell.find_cell_list).

    With `find_cell`, also return the cell that contains the first sphere's
    centre (an EnvCell wins at once); otherwise return None. Cells found by
    earlier searches of the same transition stay in the array, as in the
    client: only the outdoor-added marker is reset.
    """
    world = cell_array.world
    cell_array.reset_count()
    cell_id = position.cell_id
    visible_cell: ObjCell | None = None
    if cell_id:
        # a cell an earlier search of this transition found is the one the lookup gives (the
        # landblocks do not change during a transition): most searches start in one
        visible_cell = cell_array.cell_of(cell_id)
        if visible_cell is None:
            visible_cell = cell_array.landcell(cell_id)

    if (cell_id & 0xFFFF) >= 0x100:
        if path is not None:
            path.hits_interior_cell = True
        cell_array.add_cell(cell_id, visible_cell)
    else:
        add_all_outside_cells(world, position, num_sphere, spheres, cell_array)

    found = None
    if visible_cell is not None and num_sphere != 0:
        # Cells appended while we walk are visited too: the client indexes the
        # i-th live entry of a growing map on every turn.
        i = 0
        while i < len(cell_array):
            cell = cell_array.live_cell(i)
            if cell is not None:
                cell.find_transit_cells(position, num_sphere, spheres, cell_array, path)
            i += 1

        if find_cell:
            center = spheres[0].center
            # in iteration order, without a snapshot: nothing here adds or removes cells
            for i in range(len(cell_array)):
                cell = cell_array.live_cell(i)
                if cell is None:
                    continue
                block_offset = get_block_offset(cell_id, cell.id)
                local_point = center if block_offset is ZERO else center - block_offset
                if cell.point_in_cell(local_point):
                    found = cell
                    if (cell.id & 0xFFFF) >= 0x100:
                        if path is not None:
                            path.hits_interior_cell = True
                        return found

    if not cell_array.load_cells and (cell_id & 0xFFFF) >= 0x100 and isinstance(visible_cell, EnvCell):
        # Indoors, only cells on the current EnvCell's stab list stay.
        stab = visible_cell.visible_cell_ids
        for cell in cell_array.cells():
            if cell is None or cell.id == visible_cell.id:
                continue
            if cell.id not in stab:
                cell_array.remove_cell(cell.id)
    return found
