"""PathResult: what a path query answers."""

from __future__ import annotations

from dataclasses import dataclass, field

from ..geometry import Position

__all__ = ["PathResult"]


@dataclass(frozen=True, slots=True)
class PathResult:
    """A path query's answer.

    `waypoints` run from where the walker starts (a MoverSpec walker: where
    it is placed at the start asked for) to the goal as the walker stands
    there; each is a Position with the cell it lies in. `length` is the sum
    of the straight 3-D distances between them, metres. `expanded` counts the
    graph nodes the search took off its open list. When not found, `reason`
    says why: "unreachable" (no walk joins them in the loaded world, within
    `max_distance` when one was given), "budget" (the search stopped at its
    node budget, or could not prove a route in its repairs), "not_loaded"
    (the start's or the goal's landblock is not loaded), "start_invalid"
    (the walker cannot stand at the start: no place to stand within the
    arrival tolerance of it, horizontally, as a new object is placed there),
    "goal_invalid" (nor at the goal), "building" (the query was given an
    allowance of graph building, `work`, and spent it before it could
    answer: what it built is kept, so asking again goes further).
    """

    found: bool
    waypoints: list[Position] = field(default_factory=list)
    length: float = 0.0
    expanded: int = 0
    reason: str | None = None
    #: what the reason means in words (which point, which landblock)
    detail: str = ""

    @property
    def end(self) -> Position | None:
        """The last waypoint (the goal as reached), None when not found."""
        return self.waypoints[-1] if self.found and self.waypoints else None
