"""NavSettings: the navigation graph's resolution and the walk that proves a path."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

__all__ = ["NavSettings", "DEFAULT_NAV", "REASONS"]

#: why a path was not found (PathResult.reason)
REASONS: Final = ("unreachable", "budget", "not_loaded", "start_invalid", "goal_invalid", "building")


@dataclass(frozen=True, slots=True)
class NavSettings:
    """How the navigation graph is sampled and how a path is walked.

    The walk is the contract a found path keeps (engine.navigation.walk): from
    each waypoint to the next, moves of at most `stride` metres straight toward
    the next waypoint, the last one ending on it, until the walker is within
    `arrival_tolerance` of it."""

    #: metres between the samples of the walkable lattice (a setting: finer finds narrower gaps, costs more)
    resolution: float = 2.0
    #: the longest single move of the walk, metres (one World.move each): 3 m walks every lattice edge,
    #: the diagonals' 2.83 m too, in one move
    stride: float = 3.0
    #: how close (3-D, metres) the walker must come to a waypoint to have reached it
    arrival_tolerance: float = 0.25
    #: graph edges join nodes at most this many lattice spacings apart (1.5: the eight lattice neighbours)
    link_spacings: float = 1.5
    #: nodes A* may expand by default (PathResult.reason "budget" past it)
    budget: int = 10_000
    #: how many times a search may route around an edge its proof walk refused
    repairs: int = 16

    @property
    def link_radius(self) -> float:
        return self.resolution * self.link_spacings

    def check(self) -> None:
        for name in ("resolution", "stride", "arrival_tolerance", "link_spacings"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and 0.0 < value < 1e3):
                raise ValueError(f"NavSettings.{name} must be a positive number under 1000, got {value!r}")
        if not 0.25 <= self.resolution <= 24.0:
            raise ValueError(f"NavSettings.resolution must be from 0.25 to 24 m, got {self.resolution!r}")
        if self.link_spacings < 1.0:
            raise ValueError(f"NavSettings.link_spacings must be at least 1, got {self.link_spacings!r}")


DEFAULT_NAV: Final = NavSettings()
