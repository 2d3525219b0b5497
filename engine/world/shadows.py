"""Movers' shadows: how a live mover becomes an obstacle in the cells it touches.

The client lists, in every cell, the objects whose shadows reach into it;
cells test them newest first. A mover leaves its shadow in every cell of the
CellArray its last successful transition built (SetPositionInternal: remove
the old shadows, add the new ones), and on entering the world in every cell
that a cell search for its spheres at its start position finds.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..cells.cell_array import CellArray
from ..cells.find_cell_list import find_cell_list
from ..geometry import Sphere
from ..objects.obstacle import MoverObstacle, Obstacle

if TYPE_CHECKING:
    from ..cells.obj_cell import ObjCell
    from ..transition.interface import CellLookup
    from .mover import Mover

__all__ = ["enter_world", "reshadow", "remove_shadows", "obstacle_of"]


def obstacle_of(mover: Mover) -> MoverObstacle:
    """The mover as others see it (created on first use)."""
    obstacle = mover.obstacle
    if obstacle is None:
        obstacle = mover.obstacle = MoverObstacle(mover)
    return obstacle


def remove_shadows(mover: Mover) -> None:
    obstacle = mover.obstacle
    if obstacle is None:
        return
    for cell in mover.shadow_cells:
        _remove_from(cell.shadow_objects, obstacle)
    mover.shadow_cells = []


def _remove_from(objects: list[Obstacle], obstacle: Obstacle) -> None:
    """objects.remove(obstacle), if it is there, by identity: what list.remove does for obstacles
    (they compare by identity), without its rich comparison of every object before it (in a crowded
    cell, dozens of standing movers ahead of a walker's shadow)."""
    for i in range(len(objects)):
        if objects[i] is obstacle:
            del objects[i]
            return


def _add_shadows(mover: Mover, cells: list[ObjCell | None]) -> None:
    obstacle = obstacle_of(mover)
    added: list[ObjCell] = []
    for cell in cells:
        if cell is None or cell in added:
            continue
        cell.shadow_objects.append(obstacle)
        added.append(cell)
    mover.shadow_cells = added


def reshadow(mover: Mover, cell_array: CellArray) -> None:
    """After a successful transition: shadows move to that transition's cells (SetPositionInternal:
    every old shadow removed, then one added to each new cell, newest last).

    When the cells are the ones the mover already shadows, in the same order (a mover walking within
    its cells), that comes to moving its shadow to the end of each cell's list, cell by cell (the
    lists are separate): done in place, without making the cell list again."""
    cells = cell_array.cells()
    obstacle = mover.obstacle
    if obstacle is not None and _same_cells(mover.shadow_cells, cells):
        for cell in mover.shadow_cells:
            objects = cell.shadow_objects
            if objects and objects[len(objects) - 1] is obstacle:
                continue  # the newest already: removing and adding it again changes nothing
            _remove_from(objects, obstacle)
            objects.append(obstacle)
        return
    remove_shadows(mover)
    _add_shadows(mover, cells)


def _same_cells(shadow_cells: list[ObjCell], cells: list[ObjCell | None]) -> bool:
    """Are `cells`, without their Nones, `shadow_cells` in the same order?"""
    n = len(shadow_cells)
    i = 0
    for cell in cells:
        if cell is None:
            continue
        # the new list skips repeats; the old one has none, so a repeat here means a different list
        if i >= n or shadow_cells[i] is not cell:
            return False
        i += 1
    return i == n


def enter_world(world: CellLookup, mover: Mover) -> None:
    """Shadows for a mover entering the world at its current position."""
    position = mover.position
    frame = position.frame
    spheres = [Sphere(frame.local_to_global(s.center * mover.scale), s.radius * mover.scale) for s in mover.spheres[:2]]
    cells = CellArray(world)
    find_cell_list(position, len(spheres), spheres, cells, False, None)
    remove_shadows(mover)
    _add_shadows(mover, cells.cells())
