"""Terrain for the live map: height grids of landblocks, from the view's own copy of the world.

The service has no terrain query: `acphys view` opens the same world the
service serves (the same --scene or --dat-dir, the demo world by default)
and samples its terrain here. A landblock the view's world lacks has no grid
(the page draws it as a blank square).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

__all__ = ["LANDBLOCK_M", "PerLandblock", "TerrainGrid", "TerrainSource"]

T = TypeVar("T")

LANDBLOCK_M = 192.0  # a landblock's side: 8 cells of 24 m
CELL_M = 24.0


@dataclass(frozen=True, slots=True)
class TerrainGrid:
    """Heights of one landblock sampled every `step_m` at sample centres; row 0 is the south edge."""

    landblock: int
    size: int
    step_m: float
    heights: list[float]  # size * size, row-major (x fastest)

    def to_json(self) -> dict[str, Any]:
        return {"id": f"{self.landblock:04X}", "x0": (self.landblock >> 8) * LANDBLOCK_M,
                "y0": (self.landblock & 0xFF) * LANDBLOCK_M, "size": self.size, "step": self.step_m,
                "heights": [round(h, 2) for h in self.heights],
                "min": min(self.heights), "max": max(self.heights)}


class PerLandblock(Generic[T]):
    """What the view works out from its world for a landblock (`work_out`, None where the world lacks it),
    once each; thread-safe, as the web server asks from its threads."""

    def __init__(self, work_out: Callable[[int], T | None], lock: threading.Lock | None = None) -> None:
        self._work_out = work_out
        self._done: dict[int, T | None] = {}
        self._lock = lock or threading.Lock()  # shared with whatever else reads the same world

    def get(self, landblock: int) -> T | None:
        with self._lock:
            if landblock not in self._done:
                self._done[landblock] = self._work_out(landblock)
            return self._done[landblock]


class TerrainSource:
    """Samples a World's terrain per landblock, once each."""

    def __init__(self, world: Any, step_m: float = 4.0, lock: threading.Lock | None = None) -> None:
        self.world = world
        self.step_m = step_m
        self._grids = PerLandblock(self._sample, lock)

    def grid(self, landblock: int) -> TerrainGrid | None:
        """The landblock's height grid, or None when the view's world has no such landblock."""
        return self._grids.get(landblock)

    def _sample(self, landblock: int) -> TerrainGrid | None:
        n = int(LANDBLOCK_M / self.step_m)
        heights: list[float] = []
        try:
            for j in range(n):
                y = (j + 0.5) * self.step_m
                for i in range(n):
                    x = (i + 0.5) * self.step_m
                    cell = (landblock << 16) | (int(x // CELL_M) * 8 + int(y // CELL_M) + 1)
                    heights.append(float(self.world.terrain_height(cell, x, y)))
        except Exception:  # not in this world (a scene without it, a dat without it)
            return None
        return TerrainGrid(landblock, n, self.step_m, heights)
