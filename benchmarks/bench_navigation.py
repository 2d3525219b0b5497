"""Navigation (World.path): graph build per landblock (time and memory), path queries (p50, p99) by kind,
the share of random pairs a straight chase reaches against the share a path reaches, and the search
itself against graph libraries on the same built graph. In this process; bounded by counts. The same
path queries over the bus, asked of a service on the same scene: bench_navigation_bus."""

from __future__ import annotations

import math
import random
import time
import tracemalloc
from typing import Any

from .bench_navigation_bus import bus_finding, bus_paths, bus_section
from .common import ORACLE, log, pct, summary

#: the player of the tests and the engine benchmark (benchmarks/scenes.py PLAYER)
_SPHERES = (((0.0, 0.0, 0.48), 0.48), ((0.0, 0.0, 1.35), 0.48))


def _player() -> Any:
    from engine import MoverSpec, SphereSpec

    return MoverSpec(spheres=[SphereSpec(c, r) for c, r in _SPHERES], step_up_height=0.4, step_down_height=0.4,
                     state=["Contact", "OnWalkable", "IsPlayer", "EdgeSlide"])


def _demo() -> Any:
    import engine
    from clients.demo.world import demo_scene_path

    return engine.load_scene(demo_scene_path())


def _shared(name: str) -> Any:
    import engine

    return engine.load_scene(ORACLE / "scenes" / name)


def _build(label: str, make_world: Any, lb_id: int) -> dict[str, Any]:
    """Build one landblock's graph from nothing: the seconds (best of three fresh worlds), the memory the
    graph holds (tracemalloc, in a fourth: it slows allocation, so never in a timed run), what it holds."""
    player = _player()
    seconds = math.inf
    for _ in range(3):
        world = make_world()
        t0 = time.perf_counter()
        world.build_navigation(player, [lb_id])
        seconds = min(seconds, time.perf_counter() - t0)
    world = make_world()
    tracemalloc.start()
    before = tracemalloc.get_traced_memory()[0]
    world.build_navigation(player, [lb_id])
    held = tracemalloc.get_traced_memory()[0] - before
    tracemalloc.stop()
    graph = next(iter(world.navigation.graphs.values()))
    stats = graph.stats(lb_id)
    row = {"label": label, "landblock": f"{lb_id:04X}", "seconds": seconds, "megabytes": held / 1e6,
           "nodes": stats.nodes, "edges": stats.edges, "walks": graph.walks, "tiles": stats.tiles}
    log(f"  build {label} {lb_id:04X}: {seconds * 1e3:.0f} ms, {held / 1e6:.1f} MB, {stats.nodes} nodes, {stats.edges} edges")
    return row


def _nodes(world: Any, lbs: set[int]) -> list[Any]:
    graph = next(iter(world.navigation.graphs.values()))
    out: list[Any] = []
    for cell_id, tile in graph.tiles.items():
        if (cell_id >> 16) in lbs:
            out.extend(graph.position((cell_id << 16) | i) for i in range(len(tile)))
    return out


def _pairs(nodes: list[Any], n: int, lo: float, hi: float, seed: int, across: bool = False,
           indoor: bool = False) -> list[tuple[Any, Any]]:
    rng = random.Random(seed)
    out: list[tuple[Any, Any]] = []
    for _ in range(200_000):
        if len(out) >= n:
            break
        a, b = rng.choice(nodes), rng.choice(nodes)
        if indoor and ((a.cell_id & 0xFFFF) < 0x100 or (b.cell_id & 0xFFFF) < 0x100):
            continue
        if across and (a.cell_id >> 16) == (b.cell_id >> 16):
            continue
        o = a.get_offset(b)
        if lo <= math.hypot(o.x, o.y) <= hi:
            out.append((a, b))
    return out


def _into(nodes: list[Any], n: int) -> list[tuple[Any, Any]]:
    """Pairs from outdoors, 5 to 40 m away, to a point inside a house."""
    rng = random.Random(3)
    inside = [p for p in nodes if (p.cell_id & 0xFFFF) >= 0x100]
    out: list[tuple[Any, Any]] = []
    for _ in range(100_000):
        if len(out) >= n or not inside:
            break
        a, b = rng.choice(nodes), rng.choice(inside)
        o = a.get_offset(b)
        if (a.cell_id & 0xFFFF) < 0x100 and 5.0 <= math.hypot(o.x, o.y) <= 40.0:
            out.append((a, b))
    return out


def _edge_walk_us(world: Any) -> float:
    """What one edge walk costs: the graph's probe walking one lattice step (2 m) on the demo hills,
    put back each time; microseconds, best of five rounds of 2,000."""
    from engine.navigation.walk import ProbeState, walk_toward
    from engine.navigation.graph import place_probe

    graph = next(iter(world.navigation.graphs.values()))
    tile = graph.tile(0xA9B40013)
    start, goal = graph.position((0xA9B40013 << 16) | 30), graph.position((0xA9B40013 << 16) | 31)
    probe = graph.probe
    assert tile is not None and place_probe(world, probe, start, False)
    here = ProbeState(probe)
    best = math.inf
    for _ in range(5):
        t0 = time.perf_counter()
        for _ in range(2000):
            here.restore()
            walk_toward(world.landscape, probe, goal, world.navigation.settings)
        best = min(best, (time.perf_counter() - t0) / 2000)
    return best * 1e6


def _time_paths(world: Any, pairs: list[tuple[Any, Any]]) -> dict[str, Any]:
    player = _player()
    times, found, lengths, walking = [], 0, [], []
    for a, b in pairs:
        t0 = time.perf_counter()
        r = world.path(player, a, b)
        times.append(time.perf_counter() - t0)
        found += r.found
        if r.found:
            lengths.append(r.length)
            t0 = time.perf_counter()
            _walks(world, r)
            walking.append(time.perf_counter() - t0)
    t0 = time.perf_counter()
    world.paths(player, pairs)
    batched = (time.perf_counter() - t0) / max(1, len(pairs))
    out: dict[str, Any] = dict(summary(times, 1e3))
    # times_ms: each pair's, in order, for the bus part's paired difference (bench_navigation_bus)
    out.update(p90=pct(times, 90) * 1e3, times_ms=[t * 1e3 for t in times], found=found, pairs=len(pairs),
               batched_mean_ms=batched * 1e3,
               mean_length=sum(lengths) / len(lengths) if lengths else math.nan,
               walk_once_median_ms=summary(walking, 1e3)["median"])
    return out


def _chase(world: Any, start: Any, goal: Any) -> bool:
    """A straight chase: the walk of a path's leg straight at the goal, sliding as the transition does."""
    mover = world.add_mover(_player(), start, placement="enter_world")
    try:
        return bool(world.follow(mover, [start, goal]) == 1)
    finally:
        world.remove_mover(mover)


def _walks(world: Any, path: Any) -> bool:
    """A found path walked by a mover registered where it starts (World.follow)."""
    mover = world.add_mover(_player(), path.waypoints[0], placement="enter_world")
    try:
        return bool(world.follow(mover, path.waypoints) == len(path.waypoints) - 1)
    finally:
        world.remove_mover(mover)


def _chase_rows(n: int) -> list[dict[str, Any]]:
    rows = []
    for scene, box, indoor in (("house.json", (96.0, 96.0, 120.0, 120.0), False), ("dungeon.json", (58.0, 57.0, 78.0, 73.0), True),
                               ("objects.json", (52.0, 52.0, 120.0, 92.0), False)):
        world = _shared(scene)
        world.build_navigation(_player(), [0xA9B4])
        x0, y0, x1, y1 = box
        nodes = [p for p in _nodes(world, {0xA9B4}) if x0 <= p.frame.origin.x <= x1 and y0 <= p.frame.origin.y <= y1
                 and (not indoor or (p.cell_id & 0xFFFF) >= 0x100)]
        pairs = _pairs(nodes, n, 4.0, 40.0, seed=30)
        chased = pathed = 0
        for a, b in pairs:
            chased += _chase(world, a, b)
            r = world.path(_player(), a, b)
            pathed += bool(r.found and _walks(world, r))
        rows.append({"scene": scene, "pairs": len(pairs), "chase": chased, "path": pathed})
        log(f"  chase vs path on {scene}: {chased} / {pathed} of {len(pairs)}")
    return rows


def _csr(graph: Any) -> tuple[dict[int, int], list[int], list[int], list[float]]:
    """The built graph as compressed rows: key -> index, row starts, targets, costs."""
    keys = sorted((c << 16) | i for c, t in graph.tiles.items() for i in t.edges)
    index = {k: j for j, k in enumerate(keys)}
    starts, targets, costs = [0], [], []
    for k in keys:
        ts, cs = graph.tiles[k >> 16].edges[k & 0xFFFF]
        for t, c in zip(ts, cs):
            if t in index:
                targets.append(index[t])
                costs.append(c)
        starts.append(len(targets))
    return index, starts, targets, costs


def _search_rows(world: Any, pairs: list[tuple[int, int]]) -> list[dict[str, Any]]:
    """The same node-to-node searches on the same built graph: this project's A*, scipy's Dijkstra,
    rustworkx's A* and Dijkstra (each where installed)."""
    from engine.navigation.search import astar

    graph = next(iter(world.navigation.graphs.values()))
    index, starts, targets, costs = _csr(graph)
    keys = list(index)
    rows = []
    times = []
    for a, b in pairs:
        t0 = time.perf_counter()
        astar(graph, {a: 0.0}, {b: 0.0}, graph.coords(b), 10**7, math.inf, set())
        times.append(time.perf_counter() - t0)
    rows.append(dict(summary(times, 1e3), name="engine.navigation.search.astar (heapq, hand-written)"))
    try:
        import numpy as np
        from scipy.sparse import csr_matrix
        from scipy.sparse.csgraph import dijkstra

        m = csr_matrix((np.array(costs), np.array(targets), np.array(starts)), shape=(len(keys), len(keys)))
        times = []
        for a, _ in pairs:
            t0 = time.perf_counter()
            dijkstra(m, indices=index[a], return_predecessors=True, min_only=True)
            times.append(time.perf_counter() - t0)
        rows.append(dict(summary(times, 1e3), name="scipy.sparse.csgraph.dijkstra (one source, all targets)"))
    except ImportError as e:
        rows.append({"name": "scipy.sparse.csgraph.dijkstra", "unavailable": str(e)})
    try:
        import rustworkx as rx

        g = rx.PyDiGraph()
        g.add_nodes_from(range(len(keys)))
        g.add_edges_from([(i, targets[j], costs[j]) for i in range(len(keys)) for j in range(starts[i], starts[i + 1])])
        coords = [graph.coords(k) for k in keys]
        times = []
        for a, b in pairs:
            ib = index[b]
            goal_xyz = coords[ib]
            t0 = time.perf_counter()
            rx.digraph_astar_shortest_path(g, index[a], lambda n, ib=ib: n == ib, lambda e: e,  # type: ignore[misc]
                                           lambda n, goal_xyz=goal_xyz: math.dist(coords[n], goal_xyz))  # type: ignore[misc]
            times.append(time.perf_counter() - t0)
        rows.append(dict(summary(times, 1e3), name="rustworkx.digraph_astar_shortest_path (Python callbacks)"))
        times = []
        for a, b in pairs:
            t0 = time.perf_counter()
            rx.digraph_dijkstra_shortest_paths(g, index[a], target=index[b], weight_fn=float)
            times.append(time.perf_counter() - t0)
        rows.append(dict(summary(times, 1e3), name="rustworkx.digraph_dijkstra_shortest_paths (to one target)"))
    except ImportError as e:
        rows.append({"name": "rustworkx", "unavailable": str(e)})
    return rows


def run(quick: bool, bus: bool = True) -> dict[str, Any]:
    """The whole navigation benchmark; `bus`: also the demo world's path queries over the bus."""
    n = 10 if quick else 60
    log("navigation: graph builds")
    build = [
        _build("terrain (demo hills)", _demo, 0xA9B4),
        _build("village (demo pad: house, pillar, boulder, platform)", _demo, 0xA9B5),
        _build("mesa and ramp (demo)", _demo, 0xAAB4),
        _build("dungeon (shared dungeon.json)", lambda: _shared("dungeon.json"), 0xA9B4),
    ]
    log("navigation: path queries on the demo world, every landblock built")
    demo = _demo()
    demo.build_navigation(_player())
    edge_us = _edge_walk_us(demo)
    log(f"  one edge walk: {edge_us:.1f} us")
    nodes = _nodes(demo, {0xA9B4, 0xA9B5, 0xAAB4, 0xAAB5})
    demo_sets = {
        "50 m": _pairs(nodes, n, 45.0, 55.0, seed=50),
        "150 m": _pairs(nodes, n, 140.0, 160.0, seed=150),
        "across landblocks": _pairs(nodes, n, 30.0, 150.0, seed=2, across=True),
        "indoor (into the demo house, from up to 40 m out)": _into(nodes, n),
    }
    queries = {k: _time_paths(demo, pairs) for k, pairs in demo_sets.items()}
    dungeon = _shared("dungeon.json")
    dungeon.build_navigation(_player(), [0xA9B4])
    queries["indoor (dungeon corridors)"] = _time_paths(dungeon, _pairs(_nodes(dungeon, {0xA9B4}), n, 3.0, 25.0, seed=4, indoor=True))
    for k, v in queries.items():
        log(f"  {k}: p50 {v['median']:.2f} ms, p99 {v['p99']:.2f} ms, {v['found']}/{v['pairs']} found")
    log("navigation: chase against path")
    chase = _chase_rows(8 if quick else 40)
    log("navigation: the search against graph libraries")
    graph = next(iter(demo.navigation.graphs.values()))
    keyed = {(p.cell_id, p.frame.origin.x, p.frame.origin.y, p.frame.origin.z): k for k in
             [(c << 16) | i for c, t in graph.tiles.items() for i in range(len(t))] for p in [graph.position(k)]}
    pairs = [(keyed[(a.cell_id, a.frame.origin.x, a.frame.origin.y, a.frame.origin.z)],
              keyed[(b.cell_id, b.frame.origin.x, b.frame.origin.y, b.frame.origin.z)])
             for a, b in _pairs(nodes, n, 140.0, 160.0, seed=150)]
    search = _search_rows(demo, pairs)
    over_bus: dict[str, Any] | None = None
    if bus:
        log("navigation: the demo world's path queries over the bus")
        from clients.demo.world import demo_scene_path

        try:
            over_bus = bus_paths(demo_scene_path(), _player(), demo_sets, queries)
        except Exception as e:  # noqa: BLE001 - the doc says why instead; the library's figures stand
            log(f"  over the bus failed: {type(e).__name__}: {e}")
            over_bus = {"failed": f"{type(e).__name__}: {e}"}
    return {"build": build, "queries": queries, "chase": chase, "search": search, "edge_walk_us": edge_us,
            "bus": over_bus}


def section(data: dict[str, Any], meta: str) -> list[str]:
    """docs/performance.md's navigation section."""
    out = ["## 7. Navigation", "", meta, ""]
    if "failed" in data:
        return out + [f"Not measured: {data['failed']}", ""]
    edge_us = data.get("edge_walk_us")
    out += ["Graph build of one landblock from nothing, for the test player (`World.build_navigation`: every "
            "node sampled, every edge walked by the transition; the best of three; memory is what the graph holds, "
            "by tracemalloc in a fourth build). "
            "Targets: at most 1 s and 8 MB per outdoor landblock.", "",
            "The walks alone bound a build: each is at least one move of the transition "
            + (f"({edge_us:.1f} µs for one lattice edge in this run)" if edge_us else "")
            + ", in the column 'walks alone'.", "",
            "| landblock | ms | walks alone, ms | MB | nodes | edges | walks |", "|---|---:|---:|---:|---:|---:|---:|"]
    for r in data["build"]:
        floor = f"{r['walks'] * edge_us / 1e3:.0f}" if edge_us else "-"
        out.append(f"| {r['label']}, {r['landblock']} | {r['seconds'] * 1e3:.0f} | {floor} | {r['megabytes']:.1f} | "
                   f"{r['nodes']} | {r['edges']} | {r['walks']} |")
    out += ["", "Path queries on a built graph (`World.path`, the proof walk included; `World.paths` for the batched "
            "column, per path). Target: a 150 m path in a built landblock in at most 2 ms median; over the bus, "
            "below.", "",
            "The column 'walking it' is one walk of the answer with `World.move` (median): the least a proven "
            "path costs, since the search walked it to prove it.", "",
            "| paths | p50 ms | p99 ms | batched, mean ms | walking it, ms | found | mean length m |",
            "|---|---:|---:|---:|---:|---:|---:|"]
    for k, v in data["queries"].items():
        walk = v.get("walk_once_median_ms")
        out.append(f"| {k} | {v['median']:.2f} | {v['p99']:.2f} | {v['batched_mean_ms']:.2f} | "
                   f"{'-' if walk is None else f'{walk:.2f}'} | {v['found']}/{v['pairs']} | {v['mean_length']:.1f} |")
    out += ["", *bus_section(data.get("bus"))]
    out += ["The point of it: random pairs of graph nodes (points where the player stands) 4 to 40 m apart in "
            "three shared scenes (the dungeon's among its corridors only; some pairs have no way between them at "
            "all: a roof, an object's top, the cell behind the low doorway). A straight "
            "chase walks at the goal and slides as the transition does (`World.follow` of the start and the goal); "
            "a path is asked for and walked (`World.follow` of its waypoints).", "",
            "| scene | pairs | chase reaches | path reaches |", "|---|---:|---:|---:|"]
    for r in data["chase"]:
        out.append(f"| {r['scene']} | {r['pairs']} | {r['chase']} | {r['path']} |")
    out += ["", "The search alone on the same built graph (150 m pairs on the demo world), node to node:", "",
            "| search | p50 ms | p99 ms |", "|---|---:|---:|"]
    for r in data["search"]:
        if "unavailable" in r:
            out.append(f"| {r['name']} | not installed | |")
        else:
            out.append(f"| {r['name']} | {r['median']:.2f} | {r['p99']:.2f} |")
    return out + ["", *_findings(data), ""]


def _findings(data: dict[str, Any]) -> list[str]:
    """The choice of search, and each target against what bounds it, from this run's figures."""
    mine = next((r for r in data["search"] if r["name"].startswith("engine.")), None)
    others = [r for r in data["search"] if not r["name"].startswith("engine.") and "median" in r]
    out = []
    if mine is not None and others:
        best = min(others, key=lambda r: r["median"])
        out.append(f"**The search.** On a graph built whole, the hand-written A* took {mine['median']:.2f} ms at the "
                   f"median against {best['median']:.2f} ms for the best library ({best['name'].split(' ')[0]}); its "
                   f"p99 ({mine['p99']:.0f} ms) is the pairs with no way between them, which it floods to its budget where "
                   "a library's Dijkstra stops at the graph's end. It stays, and neither library is a dependency: it is "
                   "also the only one of them that runs on a graph whose edges are walked as the search reaches them, "
                   "which is how a graph is built unless `build_navigation` is asked.")
    builds = [r for r in data["build"] if "dungeon" not in r["label"]]
    edge_us = data.get("edge_walk_us")
    if builds and edge_us:
        worst = max(builds, key=lambda r: r["seconds"])
        over = worst["seconds"] > 1.0
        out += ["", f"**Build, at most 1 s and 8 MB per outdoor landblock:** memory "
                f"{'met' if max(r['megabytes'] for r in builds) <= 8.0 else 'missed'} "
                f"(at most {max(r['megabytes'] for r in builds):.1f} MB); time {'missed' if over else 'met'} "
                f"(at most {worst['seconds'] * 1e3:.0f} ms in this run, with the machine's load average at "
                f"{data['meta']['machine'].get('loadavg_at_start', [0])[0]:.1f} on its two cores). The walks alone take "
                f"{worst['walks'] * edge_us / 1e3:.0f} ms of it ({worst['walks']} walks of {edge_us:.1f} µs): every edge "
                "is a transition's walk by design, the floor at this resolution. The other "
                f"{worst['seconds'] * 1e3 - worst['walks'] * edge_us / 1e3:.0f} ms are the graph's own work (a placement "
                "for every candidate point, finding each node's neighbours, the direction bins), which is what misses "
                "the target here and where the next cut is. A 3 m lattice (`NavSettings(resolution=3.0)`) has 44 % of "
                "the nodes and edges."]
    q = data["queries"].get("150 m")
    if q is not None:
        met = q["median"] <= 2.0
        out += ["", f"**A 150 m path in at most 2 ms (median):** {'met' if met else 'missed'}: {q['median']:.2f} ms. "
                f"Walking the answer once with `World.move` takes {q.get('walk_once_median_ms', float('nan')):.2f} ms at "
                "the median, and the search proves its answer by walking it, the straight tries of the shortening "
                "included; where the straight walk fails the A* adds its own (the table above) and the walks to and "
                "from the graph at both ends. Paths that need no search (the straight walk arrives) cost about one "
                "walk: the 50 m row."]
    return out + bus_finding(data.get("bus"), data.get("meta", {}).get("machine", {}).get("cpus") or 2)
