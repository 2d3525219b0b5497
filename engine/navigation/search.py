"""A* over a NavGraph whose edges are walked as the search reaches them.

Sources and goals are sets: the start reaches the graph at every node near
it that a walk from the start arrives at, and the goal is reached from every
node near it that walks to it, each with its own cost. The heuristic is the
straight 3-D distance to the goal, weighted (HEURISTIC_WEIGHT): a route
found is at most that much costlier than the cheapest one the graph holds.

Among routes of equal estimate the one gone farthest is taken first (the
open list is ordered by f, then by g descending): on a lattice many routes
tie, and breadth among them is what made the search expand ten times the
nodes it needed.

Hand-written with heapq: the edges do not exist until the search expands
their node, which a graph library's A* would have to call back into Python
for, once per edge (docs/performance.md, "Navigation", has the comparison).
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

from .graph import NavGraph

__all__ = ["Route", "astar", "settle", "GOAL"]

#: the key of the virtual goal node (no tile has cell id 0)
GOAL = -1
#: the straight distance to the goal, times this, is the estimate of the rest of a route. On the
#: lattice a route goes by its four neighbours (the diagonals are left out where the corners span
#: them, engine.navigation.graph), so its cost runs up to 1.41 times the straight distance, and an
#: estimate of 1.0 times it has the search widen over every node that close to it (2,000 nodes for
#: 150 m across the demo hills). The route found is at most this much costlier than the graph's
#: cheapest, and the proof walk straightens it afterwards wherever straight lines walk.
HEURISTIC_WEIGHT = 1.4
#: nodes the backward flood from the goal may find before it gives up telling closed places apart
BACKWARD_FLOOD_LIMIT = 100
#: forward expansions before the backward flood starts: a path found sooner never pays for it (each
#: backward step looks for its node's predecessors along eight rays; at 200 it was most of a 150 m search)
BACKWARD_AFTER = 1500


@dataclass(slots=True)
class Route:
    """A search's outcome: the node keys from a source to the goal (GOAL last), or why there is none."""

    keys: list[int]
    cost: float
    expanded: int
    reason: str | None


def astar(graph: NavGraph, sources: dict[int, float], goals: dict[int, float], goal_xyz: tuple[float, float, float],
          budget: int, max_distance: float, refused: set[tuple[int, int]]) -> Route:
    """The cheapest route from any source (with its starting cost) to GOAL through any goal node (with
    its cost to the goal). `refused` edges (a, b) are left out; no route cost beyond `max_distance`."""
    gx, gy, gz = goal_xyz
    coords = graph.coords
    get_edges = graph.edges

    def h(key: int) -> float:
        x, y, z = coords(key)
        return HEURISTIC_WEIGHT * math.sqrt((x - gx) ** 2 + (y - gy) ** 2 + (z - gz) ** 2)

    best: dict[int, float] = {}
    parent: dict[int, int] = {}
    heap: list[tuple[float, float, int]] = []
    for key, g in sources.items():
        if g < best.get(key, math.inf):
            best[key] = g
            parent[key] = GOAL  # (no parent: a source)
            heapq.heappush(heap, (g + h(key), -g, key))
    closed: set[int] = set()
    expanded = 0
    # the nodes that walk to the goal, flooded backward a node per forward one once the search has run
    # a while: a goal in a small closed place (a room with no door) is known unreachable once they are
    # all found and no source is among them, without the forward search flooding everything the start
    # reaches
    behind: set[int] = set(goals)
    backlog = sorted(goals)
    flooding = not any(k in behind for k in sources)
    while heap:
        if flooding and expanded >= BACKWARD_AFTER:
            if not backlog:
                return Route([], math.inf, expanded, "unreachable")
            for pred in graph.predecessors(backlog.pop()):
                if pred not in behind:
                    if pred in sources:
                        flooding = False
                        break
                    behind.add(pred)
                    backlog.append(pred)
            if len(behind) > BACKWARD_FLOOD_LIMIT:
                flooding = False  # not a small closed place: the forward search alone decides
        f, neg_g, key = heapq.heappop(heap)
        g = -neg_g
        if key in closed or g > best.get(key, math.inf):
            continue
        if key == GOAL:
            keys = [GOAL]
            node = parent[GOAL]
            while node != GOAL:
                keys.append(node)
                node = parent[node]
            keys.reverse()
            return Route(keys, g, expanded, None)
        if f > max_distance:
            break
        closed.add(key)
        expanded += 1
        if expanded > budget:
            return Route([], math.inf, expanded - 1, "budget")
        finish = goals.get(key)
        if finish is not None and g + finish < best.get(GOAL, math.inf):
            best[GOAL] = g + finish
            parent[GOAL] = key
            heapq.heappush(heap, (g + finish, -(g + finish), GOAL))
        targets, costs = get_edges(key)
        for j in range(len(targets)):
            nxt = targets[j]
            if nxt in closed or (key, nxt) in refused:
                continue
            ng = g + costs[j]
            if ng < best.get(nxt, math.inf):
                best[nxt] = ng
                parent[nxt] = key
                heapq.heappush(heap, (ng + h(nxt), -ng, nxt))
    return Route([], math.inf, expanded, "unreachable")


def settle(graph: NavGraph, sources: dict[int, float], max_cost: float, budget: int) -> dict[int, float]:
    """Dijkstra from the sources: every node a route of at most `max_cost` reaches, with its cost
    (at most `budget` nodes settled)."""
    best: dict[int, float] = {}
    heap = [(g, key) for key, g in sources.items()]
    heapq.heapify(heap)
    settled: dict[int, float] = {}
    while heap and len(settled) < budget:
        g, key = heapq.heappop(heap)
        if key in settled:
            continue
        settled[key] = g
        targets, costs = graph.edges(key)
        for j in range(len(targets)):
            ng = g + costs[j]
            nxt = targets[j]
            if ng <= max_cost and nxt not in settled and ng < best.get(nxt, math.inf):
                best[nxt] = ng
                heapq.heappush(heap, (ng, nxt))
    return settled
