"""CellArray: the cells a transition's spheres touch."""

from __future__ import annotations

from typing import TYPE_CHECKING, Final
from collections.abc import Iterator

from .obj_cell import ObjCell
from .._compat import mypyc_attr

if TYPE_CHECKING:
    from ..transition.interface import CellLookup

__all__ = ["CellArray", "END"]

#: What `live_entry` returns past the last entry (a cell may itself be None).
END: Final = object()


@mypyc_attr(acyclic=True)
class CellArray:
    """An ordered id -> cell map with the client's reuse-in-place order.

    The client resets only the count between cell searches, so cells found
    earlier in a transition stay in the array and are collided again. Its map
    also puts a newly added cell into the slot of the most recently removed
    one, which decides the order cells are tested in; that is reproduced here
    with an explicit slot list and free list.
    """

    __slots__ = ("added_outside", "outside_searched", "load_cells", "world", "_slots", "_index", "_free")

    def __init__(self, world: CellLookup) -> None:
        #: Where cells are looked up by id (the client's LScape).
        self.world = world
        self.added_outside = False
        #: the outdoor cells under this search's spheres are in (skip_repeat_outside)
        self.outside_searched = False
        self.load_cells = False
        self._slots: list[tuple[int, ObjCell | None] | None] = []
        self._index: dict[int, int] = {}
        self._free: list[int] = []

    def reset_count(self) -> None:
        """What the client does at the start of a search: keep the cells."""
        self.added_outside = False
        self.outside_searched = False

    def clear(self) -> None:
        self._slots.clear()
        self._index.clear()
        self._free.clear()
        self.added_outside = False
        self.outside_searched = False

    def add_cell(self, cell_id: int, cell: ObjCell | None) -> None:
        if cell_id in self._index:
            return
        if self._free:
            slot = self._free.pop()
            self._slots[slot] = (cell_id, cell)
        else:
            slot = len(self._slots)
            self._slots.append((cell_id, cell))
        self._index[cell_id] = slot

    def remove_cell(self, cell_id: int) -> None:
        slot = self._index.pop(cell_id, None)
        if slot is None:
            return
        self._slots[slot] = None
        self._free.append(slot)

    def __contains__(self, cell_id: int) -> bool:
        return cell_id in self._index

    def __len__(self) -> int:
        return len(self._index)

    def live_entry(self, i: int) -> object:
        """The cell of the i-th live entry in iteration order, or END."""
        if i >= len(self._index):
            return END
        return self.live_cell(i)

    def live_cell(self, i: int) -> ObjCell | None:
        """The cell of the i-th live entry in iteration order (i < len(self))."""
        slots = self._slots
        if not self._free:
            entry = slots[i]
            assert entry is not None
            return entry[1]
        for e in slots:
            if e is not None:
                if i == 0:
                    return e[1]
                i -= 1
        raise IndexError(i)

    def cells(self) -> list[ObjCell | None]:
        """The cells in iteration order (a snapshot: safe to mutate while looping)."""
        return [e[1] for e in self._slots if e is not None]

    def ids(self) -> list[int]:
        return [e[0] for e in self._slots if e is not None]

    def __iter__(self) -> Iterator[ObjCell | None]:
        return iter(self.cells())
