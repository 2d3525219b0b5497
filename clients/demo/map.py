"""What the demo's picture is drawn from: the walk's points and the terrain's heights.

`clients.demo.picture` draws them (matplotlib); this module has no drawing
dependency, so the walk can be run and checked without matplotlib.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["FLOOR_Z", "PathPoint", "height_grid"]

FLOOR_Z = 0.66417414618662751  # the client's walkable limit (engine.constants.FLOOR_Z)


@dataclass(slots=True)
class PathPoint:
    """One resolved position of the walk, in global map metres (z: the mover's height)."""

    x: float
    y: float
    contact: bool
    on_walkable: bool
    collided: bool
    z: float = 0.0


def height_grid(height_at: Callable[[float, float], float], size_m: int, step_m: float = 1.0) -> np.ndarray:
    """Heights sampled at cell centres; row 0 is the south edge."""
    n = int(size_m / step_m)
    grid = np.empty((n, n), dtype=np.float64)
    for j in range(n):
        y = (j + 0.5) * step_m
        for i in range(n):
            grid[j, i] = height_at((i + 0.5) * step_m, y)
    return grid
