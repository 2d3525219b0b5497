"""CellArray: the cells a transition's spheres touch."""

from __future__ import annotations

from typing import TYPE_CHECKING, Final
from collections.abc import Iterator

from .landscape import Landscape, cell_of_landblock
from .obj_cell import ObjCell
from .._compat import mypyc_attr

if TYPE_CHECKING:
    from ..transition.interface import CellLookup
    from ..world.landblock import Landblock

__all__ = ["CellArray", "END"]

#: What `live_entry` returns past the last entry (a cell may itself be None).
END: Final = object()
#: the id of a removed slot (cell ids are unsigned)
_EMPTY: Final = -1


@mypyc_attr(acyclic=True)
class CellArray:
    """An ordered id -> cell map with the client's reuse-in-place order.

    The client resets only the count between cell searches, so cells found
    earlier in a transition stay in the array and are collided again. Its map
    also puts a newly added cell into the slot of the most recently removed
    one, which decides the order cells are tested in; that is reproduced here
    with an explicit slot list and free list.

    A search holds a handful of cells: the slots are two parallel lists (ids,
    cells) searched in order, which keeps the ids native ints in the compiled
    engine (a dict would box and hash every id looked up).
    """

    __slots__ = ("added_outside", "outside_searched", "load_cells", "world", "_ids", "_cells", "_free", "_lb_id", "_lb")

    def __init__(self, world: CellLookup) -> None:
        #: Where cells are looked up by id (the client's LScape).
        self.world = world
        self.added_outside = False
        #: the outdoor cells under this search's spheres are in (skip_repeat_outside)
        self.outside_searched = False
        self.load_cells = False
        #: each slot's cell id (_EMPTY once removed) and cell
        self._ids: list[int] = []
        self._cells: list[ObjCell | None] = []
        self._free: list[int] = []
        #: the landblock `landcell` looked up last (_EMPTY: none yet), kept for the rest of the transition
        self._lb_id = _EMPTY
        self._lb: Landblock | None = None

    def landcell(self, cell_id: int) -> ObjCell | None:
        """`world.get_landcell(cell_id)`. On the World's own Landscape the call is native and the landblock
        of the last lookup is remembered: a transition's searches look up a handful of cells, nearly always
        of one landblock, and no landblock is loaded or unloaded while a transition runs (the array is
        reset for each); any other CellLookup is asked by name."""
        world = self.world
        if not isinstance(world, Landscape):
            return world.get_landcell(cell_id)
        lb_id = (cell_id >> 16) & 0xFFFF
        if lb_id != self._lb_id:
            self._lb = world.landblock(lb_id)
            self._lb_id = lb_id
        lb = self._lb
        return None if lb is None else cell_of_landblock(lb, cell_id)

    def reset_count(self) -> None:
        """What the client does at the start of a search: keep the cells."""
        self.added_outside = False
        self.outside_searched = False

    def reset(self, world: CellLookup) -> None:
        """An empty array looking cells up in `world` (Transition.reset)."""
        self.world = world
        self.load_cells = False
        self.clear()

    def clear(self) -> None:
        self._ids.clear()
        self._cells.clear()
        self._free.clear()
        self.added_outside = False
        self.outside_searched = False
        self._lb_id = _EMPTY
        self._lb = None

    def _slot_of(self, cell_id: int) -> int:
        """The slot holding `cell_id`, or -1."""
        ids = self._ids
        for slot in range(len(ids)):
            if ids[slot] == cell_id:
                return slot
        return -1

    def add_cell(self, cell_id: int, cell: ObjCell | None) -> None:
        if self._slot_of(cell_id) >= 0:
            return
        if self._free:
            slot = self._free.pop()
            self._ids[slot] = cell_id
            self._cells[slot] = cell
        else:
            self._ids.append(cell_id)
            self._cells.append(cell)

    def remove_cell(self, cell_id: int) -> None:
        slot = self._slot_of(cell_id)
        if slot < 0:
            return
        self._ids[slot] = _EMPTY
        self._cells[slot] = None
        self._free.append(slot)

    def cell_of(self, cell_id: int) -> ObjCell | None:
        """The cell held under `cell_id` (None when absent, or held with no cell)."""
        slot = self._slot_of(cell_id)
        return self._cells[slot] if slot >= 0 else None

    def __contains__(self, cell_id: int) -> bool:
        return self._slot_of(cell_id) >= 0

    def __len__(self) -> int:
        return len(self._ids) - len(self._free)

    def live_entry(self, i: int) -> object:
        """The cell of the i-th live entry in iteration order, or END."""
        if i >= len(self):
            return END
        return self.live_cell(i)

    def live_cell(self, i: int) -> ObjCell | None:
        """The cell of the i-th live entry in iteration order (i < len(self))."""
        if not self._free:
            return self._cells[i]
        ids = self._ids
        for slot in range(len(ids)):
            if ids[slot] != _EMPTY:
                if i == 0:
                    return self._cells[slot]
                i -= 1
        raise IndexError(i)

    def cells(self) -> list[ObjCell | None]:
        """The cells in iteration order (a snapshot: safe to mutate while looping)."""
        if not self._free:
            return self._cells[:]
        ids = self._ids
        cells = self._cells
        return [cells[slot] for slot in range(len(ids)) if ids[slot] != _EMPTY]

    def ids(self) -> list[int]:
        return [cell_id for cell_id in self._ids if cell_id != _EMPTY]

    def __iter__(self) -> Iterator[ObjCell | None]:
        return iter(self.cells())
