"""The path query: place the walker, search the graph, and prove the route by walking it.

    1. The walker stands at the start: a MoverSpec walker is placed there as
       World.add_mover(spec, start, placement="enter_world") places a new
       mover (dropped to the ground under the point first, when the point is
       not on it); a registered mover starts where it stands. The goal is
       placed the same way. Either refused: start_invalid / goal_invalid.
    2. The direct walk is tried first: where it arrives, the path is the two
       points and no graph is needed.
    3. Otherwise A* (engine.navigation.search) runs from the graph nodes the
       start walks to, toward the nodes that walk to the goal.
    4. The route is proven with the walker's own probe, from its own start
       state, by the walk of the contract (engine.navigation.walk), and
       shortened on the way: from each waypoint reached, the farthest route
       point that a direct walk reaches becomes the next waypoint. (Every
       walk the search accepts, an edge's included, keeps within the arrival
       tolerance of its straight line: engine.navigation.walk.) A route
       point the probe cannot reach from where it actually stands (within
       the tolerance of the graph's node, not on it) refuses that edge and
       the search runs again around it, at most NavSettings.repairs times.

Every waypoint returned was reached by that walk; the walk is deterministic,
so a caller repeating it with World.move reaches each one too.
"""

from __future__ import annotations

import math
import random
from collections.abc import Sequence
from typing import TYPE_CHECKING

from .. import limits
from ..cells.landscape import Landscape
from ..errors import EngineError, LandblockNotLoadedError, OutOfRangeError, UnknownCellError
from ..geometry import Position, Vec3
from ..world.mover import Mover
from ..world.types import MoverSpec
from .graph import GraphWorkExhausted, NavGraph, global_coords, place_probe
from .results import PathResult
from .search import GOAL, astar, settle
from .settings import NavSettings
from .walk import ProbeState, stands_at, walk_toward
from .walker import Walker, probe_for_spec, probe_like

if TYPE_CHECKING:
    from ..world.world import World

__all__ = ["find_path", "find_paths", "random_point", "probe_of", "MAX_BUDGET", "MAX_PATH_DISTANCE"]

MAX_BUDGET = limits.MAX_PATH_BUDGET
MAX_PATH_DISTANCE = limits.MAX_PATH_DISTANCE
#: graph nodes near the start (and the goal) tried as the search's first (last) node
_ENDPOINT_NODES = 8


class _Walker:
    """The probe that proves a path, and its start state; puts a registered mover back when done."""

    def __init__(self, world: World, walker: Walker, avoid_movers: bool) -> None:
        self.world = world
        self.registered = not isinstance(walker, MoverSpec)
        if isinstance(walker, MoverSpec):
            self.spec: MoverSpec | None = walker
            self.probe = probe_for_spec(walker)
            self.probe.calc_acceleration(world.settings.sled_gravity)
        else:
            if isinstance(walker, bool) or not isinstance(walker, int):
                raise TypeError(f"a walker is a MoverSpec or a registered mover's id, got {type(walker).__name__}")
            self.spec = None
            self.probe = probe_like(world, walker)
        self.home = ProbeState(self.probe)  # to put a registered mover back
        self.probe.ignore_movers = not avoid_movers
        self.fresh = ProbeState(self.probe)

    def twin(self) -> Mover:
        """Another probe of the walker's shape (to stand at the goal or at a graph node)."""
        p = self.probe
        twin = Mover(-1, list(p.spheres), oi_flags=p.oi_flags, scale=p.scale, step_up_height=p.step_up_height,
                     step_down_height=p.step_down_height, gravity=p.gravity, missile=p.missile, step_down=p.step_down,
                     ethereal=p.ethereal, creature=p.creature, cyl_spheres=list(p.cyl_spheres), sledding=p.sledding)
        twin.ignore_movers = p.ignore_movers
        twin.calc_acceleration(self.world.settings.sled_gravity)
        return twin

    def done(self) -> None:
        self.home.restore()


def _stand(world: World, probe: Mover, point: Position) -> Position | None:
    """Place `probe` at `point` (sliding to a free spot nearby, as a new object is placed), first as
    given, then dropped onto the ground under it; where it was placed standing, else None."""
    fresh = ProbeState(probe)
    if place_probe(world, probe, point, True):
        return point
    try:
        under = world.ground(point)
    except EngineError:
        under = None
    if under is None:
        return None
    o = point.frame.origin
    dropped = Position(under.cell, point.frame.with_origin(Vec3(o.x, o.y, under.z)))
    fresh.restore()
    return dropped if place_probe(world, probe, dropped, True) else None


def _check_query(points: dict[str, Position | None], max_distance: float | None, budget: int | None,
                 nav: NavSettings) -> tuple[float, int]:
    for name, point in points.items():
        if point is not None:
            if not isinstance(point, Position):
                raise TypeError(f"{name} must be a Position, got {type(point).__name__}")
            limits.check_position(point, name)
    distance = MAX_PATH_DISTANCE if max_distance is None else limits.check_number(max_distance, "max_distance")
    if not 0.0 < distance <= MAX_PATH_DISTANCE:
        raise OutOfRangeError(f"max_distance must be above 0 and at most {MAX_PATH_DISTANCE:g} m, got {max_distance!r}")
    nodes = nav.budget if budget is None else budget
    if isinstance(nodes, bool) or not isinstance(nodes, int) or not 1 <= nodes <= MAX_BUDGET:
        raise OutOfRangeError(f"budget must be a whole number of nodes from 1 to {MAX_BUDGET}, got {budget!r}")
    return distance, nodes


def _loaded(world: World, point: Position, name: str) -> PathResult | None:
    """None when the point's landblock is loaded (or loaded now) and its cell exists, else the answer."""
    try:
        world.landscape.check_position(point)
    except LandblockNotLoadedError:
        return PathResult(False, reason="not_loaded", detail=f"the {name}'s landblock {point.cell_id >> 16:04X} is not loaded")
    except UnknownCellError as e:
        raise UnknownCellError(f"{name}: {e}") from None
    return None


def _check_work(work: int | None) -> int:
    """The graph building a query may start (placements and walks; -1: no limit)."""
    if work is None:
        return -1
    if isinstance(work, bool) or not isinstance(work, int) or work < 1:
        raise OutOfRangeError(f"work must be a whole number of placements and walks, at least 1, got {work!r}")
    return work


def _still_building(graph: NavGraph, e: GraphWorkExhausted) -> PathResult:
    return PathResult(False, reason="building", detail=(
        f"the walker's graph of this area is still being built: this query built what its allowance let it ({e}), "
        "which is kept; ask again"))


def find_path(world: World, walker: Walker, start: Position | None, goal: Position, *, max_distance: float | None = None,
              budget: int | None = None, avoid_movers: bool = False, work: int | None = None) -> PathResult:
    """A path the walker can walk from `start` to `goal` (World.path)."""
    nav = world.navigation.settings
    distance_cap, node_budget = _check_query({"start": start, "goal": goal}, max_distance, budget, nav)
    allowed = _check_work(work)
    w = _Walker(world, walker, avoid_movers)
    graph = world.navigation.graph_for(w.probe)
    graph.work_allowed, graph.work_done = allowed, 0
    try:
        return _find(world, w, start, goal, distance_cap, node_budget, nav)
    except GraphWorkExhausted as e:
        return _still_building(graph, e)
    finally:
        graph.work_allowed = -1
        w.done()


def find_paths(world: World, walker: Walker, pairs: Sequence[tuple[Position | None, Position]], *,
               max_distance: float | None = None, budget: int | None = None, avoid_movers: bool = False,
               work: int | None = None) -> list[PathResult]:
    """`find_path` for each (start, goal) pair, on one graph (World.paths)."""
    return [find_path(world, walker, s, g, max_distance=max_distance, budget=budget, avoid_movers=avoid_movers, work=work)
            for s, g in pairs]


def _start_state(world: World, w: _Walker, start: Position | None, nav: NavSettings) -> tuple[Position | None, PathResult | None]:
    """Stand the walker at the start: its first waypoint, or the answer when it cannot stand there."""
    probe = w.probe
    if w.registered:
        if start is not None:
            raise ValueError("a registered mover walks from where it stands: pass start=None")
        here = probe.position
        if not stands_at(probe, here, 0.0):
            return None, PathResult(False, reason="start_invalid", detail="the mover is not standing on walkable ground")
        return here, None
    if start is None:
        raise ValueError("a MoverSpec walker needs a start")
    refused = _loaded(world, start, "start")
    if refused is not None:
        return None, refused
    placed = _stand(world, probe, start)
    if placed is None:
        return None, PathResult(False, reason="start_invalid", detail=f"the walker cannot stand at the start {start!r}")
    away = _moved(start, probe.position)
    if away > nav.arrival_tolerance:
        return None, PathResult(False, reason="start_invalid",
                                detail=f"the walker cannot stand at the start {start!r}: the nearest place it can is {away:.2f} m away, {probe.position!r}")
    # where the walker stands is placed once more, as World.add_mover(spec, waypoints[0], placement=...) places it
    first = probe.position
    w.fresh.restore()
    if not place_probe(world, probe, first, True) or not stands_at(probe, first, 2.0 * nav.arrival_tolerance):
        return None, PathResult(False, reason="start_invalid", detail=f"the walker cannot stand at the start {start!r}")
    return first, None


def _goal_state(world: World, w: _Walker, goal: Position, nav: NavSettings) -> tuple[Position | None, PathResult | None]:
    refused = _loaded(world, goal, "goal")
    if refused is not None:
        return None, refused
    twin = w.twin()
    placed = _stand(world, twin, goal)
    if placed is None:
        return None, PathResult(False, reason="goal_invalid", detail=f"the walker cannot stand at the goal {goal!r}")
    where = twin.position
    away = _moved(goal, where)
    if away > nav.arrival_tolerance:
        return None, PathResult(False, reason="goal_invalid",
                                detail=f"the walker cannot stand at the goal {goal!r}: the nearest place it can is {away:.2f} m away, {where!r}")
    return where, None


def _moved(asked: Position, placed: Position) -> float:
    """How far (horizontally) a placement moved the walker from the point asked."""
    ax, ay, _ = global_coords(asked)
    px, py, _ = global_coords(placed)
    return math.hypot(px - ax, py - ay)


def _find(world: World, w: _Walker, start: Position | None, goal: Position, distance_cap: float, budget: int,
          nav: NavSettings) -> PathResult:
    first, answer = _start_state(world, w, start, nav)
    if answer is not None:
        return answer
    assert first is not None
    target, answer = _goal_state(world, w, goal, nav)
    if answer is not None:
        return answer
    assert target is not None
    start_state = ProbeState(w.probe)
    return _route(world, w, first, start_state, target, distance_cap, budget, nav)


def _length(points: list[Position]) -> float:
    return sum(points[i].get_offset(points[i + 1]).length() for i in range(len(points) - 1))


def _route(world: World, w: _Walker, first: Position, start_state: ProbeState, target: Position, distance_cap: float,
           budget: int, nav: NavSettings) -> PathResult:
    probe = w.probe
    landscape = world.landscape
    straight = first.get_offset(target).length()
    if straight > distance_cap:
        return PathResult(False, reason="unreachable", detail=f"the goal is {straight:.1f} m away, beyond max_distance")
    if walk_toward(landscape, probe, target, nav):
        return PathResult(True, [first, target], straight, 0)
    graph = world.navigation.graph_for(probe)
    sources = _sources(world, graph, start_state, probe, nav)
    goals = _goals(world, graph, w, target, nav)
    if not sources or not goals:
        end = "start" if not sources else "goal"
        return PathResult(False, reason="unreachable", detail=f"no graph node near the {end} is joined to it by a walk")
    refused: set[tuple[int, int]] = set()
    expanded = 0
    for _ in range(nav.repairs + 1):
        route = astar(graph, sources, goals, global_coords(target), budget - expanded, distance_cap, refused)
        expanded += route.expanded
        if route.reason is not None:
            return PathResult(False, expanded=expanded, reason=route.reason,
                              detail="the search's node budget ran out" if route.reason == "budget" else "no walk joins the start to the goal in the loaded world")
        keys = route.keys
        points = [graph.position(k) for k in keys[:-1]] + [target]
        start_state.restore()
        proven, failed_at = _prove(landscape, probe, points, nav)
        if proven is not None:
            waypoints = [first, *proven]
            return PathResult(True, waypoints, _length(waypoints), expanded)
        if failed_at == 0:
            sources.pop(keys[0], None)
            if not sources:
                break
        else:
            a, b = keys[failed_at - 1], keys[failed_at]
            refused.add((a, b))
            if b == GOAL:
                goals.pop(a, None)
    return PathResult(False, expanded=expanded, reason="budget", detail="no route the search found could be proven by walking it")


def _sources(world: World, graph: NavGraph, start_state: ProbeState, probe: Mover, nav: NavSettings) -> dict[int, float]:
    """The graph nodes near the start that the walker, from its start, walks to, with their distances."""
    start_state.restore()
    gx, gy, gz = global_coords(probe.position)
    out: dict[int, float] = {}
    radius = nav.link_radius
    for _, key in graph.nodes_near(gx, gy, gz, radius, 2.0 * radius)[:_ENDPOINT_NODES]:
        start_state.restore()
        node = graph.position(key)
        if walk_toward(world.landscape, probe, node, nav):
            out[key] = start_state.snapshot.position.get_offset(node).length()
    start_state.restore()
    return out


def _goals(world: World, graph: NavGraph, w: _Walker, target: Position, nav: NavSettings) -> dict[int, float]:
    """The graph nodes near the goal from which the walker walks to it, with their distances."""
    gx, gy, gz = global_coords(target)
    twin = w.twin()
    fresh = ProbeState(twin)
    out: dict[int, float] = {}
    radius = nav.link_radius
    for _, key in graph.nodes_near(gx, gy, gz, radius, 2.0 * radius)[:_ENDPOINT_NODES]:
        fresh.restore()
        node = graph.position(key)
        if place_probe(world, twin, node, False) and walk_toward(world.landscape, twin, target, nav):
            out[key] = node.get_offset(target).length()
    return out


def _prove(landscape: Landscape, probe: Mover, points: list[Position], nav: NavSettings) -> tuple[list[Position] | None, int]:
    """Walk the route's points from the probe's state (the query's start, whence the goal's direct walk
    has failed), shortening: the waypoints reached, or None and the index of the first point the probe
    could not reach from the one before."""
    waypoints: list[Position] = []
    i = -1  # the point the probe stands at (-1: the start)
    last = len(points) - 1
    while i < last:
        here = ProbeState(probe)
        # the farthest point a direct walk reaches: the goal first (from the start the query has tried it
        # already), else a bisection over the route
        if i >= 0 and i + 1 < last and walk_toward(landscape, probe, points[last], nav):
            waypoints.append(points[last])
            return waypoints, -1
        here.restore()
        if not walk_toward(landscape, probe, points[i + 1], nav):
            return None, i + 1
        reached = i + 1
        best = ProbeState(probe)
        lo, hi = i + 1, last
        while hi - lo > 1:
            mid = (lo + hi) // 2
            here.restore()
            if walk_toward(landscape, probe, points[mid], nav):
                lo, reached, best = mid, mid, ProbeState(probe)
            else:
                hi = mid
        best.restore()
        waypoints.append(points[reached])
        i = reached
    return waypoints, -1


def random_point(world: World, walker: Walker, near: Position | None, radius: float, *, seed: int | None = None,
                 budget: int | None = None, avoid_movers: bool = False, work: int | None = None) -> PathResult:
    """A random point the walker can reach from `near` (World.random_point): a path to it."""
    nav = world.navigation.settings
    _, node_budget = _check_query({"near": near}, None, budget, nav)
    r = limits.check_number(radius, "radius")
    if not 0.0 < r <= limits.MAX_WANDER_RADIUS:
        raise OutOfRangeError(f"radius must be above 0 and at most {limits.MAX_WANDER_RADIUS:g} m, got {radius!r}")
    allowed = _check_work(work)
    w = _Walker(world, walker, avoid_movers)
    graph = world.navigation.graph_for(w.probe)
    graph.work_allowed, graph.work_done = allowed, 0
    try:
        return _random_point(world, w, near, r, seed, node_budget, nav)
    except GraphWorkExhausted as e:
        return _still_building(graph, e)
    finally:
        graph.work_allowed = -1
        w.done()


def _random_point(world: World, w: _Walker, near: Position | None, r: float, seed: int | None, node_budget: int,
                  nav: NavSettings) -> PathResult:
    """random_point's search, its graph's allowance set."""
    first, answer = _start_state(world, w, near, nav)
    if answer is not None:
        return answer
    assert first is not None
    start_state = ProbeState(w.probe)
    graph = world.navigation.graph_for(w.probe)
    sources = _sources(world, graph, start_state, w.probe, nav)
    if not sources:
        return PathResult(False, reason="unreachable", detail="no graph node near the start is joined to it by a walk")
    settled = settle(graph, sources, 3.0 * r, node_budget)
    cx, cy, _ = global_coords(first)
    inside = sorted(k for k in settled if math.hypot(graph.coords(k)[0] - cx, graph.coords(k)[1] - cy) <= r)
    rng = random.Random(seed)
    rng.shuffle(inside)
    for key in inside[:8]:
        start_state.restore()
        found = _route(world, w, first, start_state, graph.position(key), MAX_PATH_DISTANCE, node_budget, nav)
        if found.found:
            return found
    return PathResult(False, expanded=len(settled), reason="unreachable", detail=f"no reachable point within {r:g} m")


def probe_of(world: World, walker: Walker) -> Mover:
    """A probe of the walker's shape (its class names its graph)."""
    w = _Walker(world, walker, False)
    w.done()
    return w.probe
