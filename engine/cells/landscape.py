"""Landscape: the loaded landblocks as a transition sees them (the client's LScape).

A transition looks cells up by id several times a move (the cell search, the
outdoor neighbours, building portals). The World keeps its landblocks here, in
a compiled object, so those lookups stay in native code; the World itself is
the interpreted facade around it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol
from collections.abc import Callable

from ..errors import LandblockNotLoadedError, NonFiniteError, UnknownCellError
from ..geometry.landdefs import cell_in_range
from ..geometry.position import Position
from ..settings import EngineSettings

if TYPE_CHECKING:
    from ..transition.transition import Transition
    from ..world.landblock import Landblock
    from .obj_cell import ObjCell

__all__ = ["Landscape", "TrackedLandblocks", "cell_of_landblock"]

#: where a landblock that is not loaded comes from (the World's loader)
LandblockLoad = Callable[[int], "Landblock | None"]


def cell_of_landblock(lb: Landblock, cell_id: int) -> ObjCell | None:
    """The cell `cell_id` of its landblock `lb`, or None: an outdoor cell by index, an EnvCell by id."""
    index = cell_id & 0xFFFF
    if 1 <= index <= 64:
        return lb.cells[index - 1]
    return lb.env_cells.get(cell_id)


class TrackedLandblocks(Protocol):
    """A landblock table that sees every use (the dat world's LRU, a dict
    subclass): reached through its own methods, never the dict's."""

    def get(self, landblock_id: int, default: None = None) -> Landblock | None: ...

    def __contains__(self, landblock_id: object) -> bool: ...


class Landscape:
    """Landblocks by id, the engine settings, and where missing landblocks come from.

    `landblocks` may be a dict subclass that tracks use (the dat world's LRU);
    lookups then go through its own methods so every use is seen.
    """

    __slots__ = ("settings", "_landblocks", "_tracked", "_load", "spare_transition")

    def __init__(
        self,
        landblocks: dict[int, Landblock],
        settings: EngineSettings,
        load: LandblockLoad | None = None,
    ) -> None:
        self.settings = settings
        self._landblocks: dict[int, Landblock] = landblocks
        # a dict subclass, reached through its own (overridden) methods
        self._tracked: TrackedLandblocks | None = None if type(landblocks) is dict else landblocks
        self._load = load
        #: a finished transition in this landscape for the next move to reuse (engine.transition.transition
        #: take_transition / give_back)
        self.spare_transition: Transition | None = None

    @property
    def landblocks(self) -> dict[int, Landblock]:
        return self._landblocks

    def set_landblocks(self, landblocks: dict[int, Landblock]) -> None:
        self._landblocks = landblocks
        self._tracked = None if type(landblocks) is dict else landblocks

    def set_loader(self, load: LandblockLoad | None) -> None:
        self._load = load

    def landblock(self, landblock_id: int) -> Landblock | None:
        """The loaded landblock with this id, or None."""
        tracked = self._tracked
        if tracked is None:
            return self._landblocks.get(landblock_id)
        return tracked.get(landblock_id)

    def get_landcell(self, cell_id: int) -> ObjCell | None:
        """The cell with this id if its landblock is loaded, else None (LScape.get_landcell)."""
        lb = self.landblock((cell_id >> 16) & 0xFFFF)
        return None if lb is None else cell_of_landblock(lb, cell_id)

    def ensure_loaded(self, cell_id: int) -> None:
        """Load the landblock of `cell_id` from the World's source if it is not loaded."""
        lb_id = (cell_id >> 16) & 0xFFFF
        tracked = self._tracked
        loaded = (lb_id in self._landblocks) if tracked is None else (lb_id in tracked)
        if loaded:
            return
        load = self._load
        if load is None:
            raise LandblockNotLoadedError(f"landblock {lb_id:04X} (cell {cell_id:08X}) is not loaded")
        load(lb_id)

    def check_position(self, position: Position) -> None:
        """A position a move may use: finite numbers, a valid cell id, its landblock
        loaded (or loadable) and, for an indoor cell, the cell present."""
        if not position.frame.is_finite():
            raise NonFiniteError(f"position {position!r} has non-finite numbers")
        cell_id = position.cell_id
        index = cell_id & 0xFFFF
        if not cell_in_range(index) or index == 0xFFFF or index == 0:
            raise UnknownCellError(f"cell id {cell_id:08X} is not a valid cell id")
        self.ensure_loaded(cell_id)
        if index >= 0x100 and self.get_landcell(cell_id) is None:
            raise UnknownCellError(f"cell {cell_id:08X} does not exist in landblock {cell_id >> 16:04X}")
