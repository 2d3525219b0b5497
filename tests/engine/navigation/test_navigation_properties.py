"""Navigation's promises on the shared scenes, over random start and goal pairs, checked against an
exhaustive flood fill that the test makes itself with the public World.move.

The flood: every point of a 1 m grid over a box of the scene where a player-sized walker can stand
(World.place without sliding, on the terrain, on what stands on it and on every indoor cell's floor),
joined to its eight grid neighbours (any level) wherever the walk of the contract
(tests/support/path_walk.py) from the one arrives at the other. Then, for pairs of its nodes:

- a path World.path finds is walked by World.move and arrives (the guarantee);
- World.path never answers "unreachable" where the flood joins the two;
- a found path is at most 1.15 times as long as the flood's shortest route.
"""

from __future__ import annotations

import heapq
import math
import random
from dataclasses import dataclass

import pytest

import engine
from engine import Position, Vec3
from benchmarks.scenes import PLAYER
from support.path_walk import walk, walk_as_spec
from support.shared_data import SCENES, needs_shared

LB = 0xA9B4
STEP = 1.0


@dataclass
class Flood:
    world: engine.World
    nodes: list[Position]
    edges: dict[int, list[tuple[int, float]]]


def _outdoor(x: float, y: float) -> int:
    return (LB << 16) | (int(x // 24) * 8 + int(y // 24) + 1)


def _stand(world: engine.World, point: Position) -> Position | None:
    placed = world.place(PLAYER, point, slide=False)
    if placed.ok and placed.contact and placed.on_walkable and placed.position is not None:
        return placed.position
    return None


def _surfaces(world: engine.World, x: float, y: float, env_boxes: dict[int, tuple[float, float, float, float]]) -> list[Position]:
    """Where the walker may stand at (x, y): on the terrain, on anything standing there, on each indoor floor."""
    out: list[Position] = []
    cell = _outdoor(x, y)
    z = world.terrain_height(cell, x, y)
    for lift in (0.02, 0.1, 0.3):  # (a slope wants the sphere lifted clear of it)
        stood = _stand(world, Position.at(cell, Vec3(x, y, z + lift)))
        if stood is not None:
            out.append(stood)
            break
    top = world.ground(Position.at(cell, Vec3(x, y, z + 20.0)))
    if top is not None and top.z > z + 0.05:
        stood = _stand(world, Position.at(cell, Vec3(x, y, top.z + 0.02)))
        if stood is not None:
            out.append(stood)
    for env_id, (ex0, ex1, ey0, ey1) in env_boxes.items():
        if not (ex0 <= x <= ex1 and ey0 <= y <= ey1):
            continue
        try:
            floor = world.ground(Position.at(env_id, Vec3(x, y, 200.0)), max_drop=400.0)
        except engine.EngineError:
            continue
        if floor is not None and floor.cell == env_id:
            stood = _stand(world, Position.at(env_id, Vec3(x, y, floor.z + 0.02)))
            if stood is not None:
                out.append(stood)
    unique: list[Position] = []
    for p in out:
        if all(p.cell_id != q.cell_id or p.get_offset(q).length() > 0.3 for q in unique):
            unique.append(p)
    return unique


def _env_boxes(world: engine.World) -> dict[int, tuple[float, float, float, float]]:
    """Each indoor cell's x and y extent in landblock coordinates, from its polygons' vertices."""
    boxes = {}
    for env_id, env in world.landblocks[LB].env_cells.items():
        points = [env.pos.frame.local_to_global(v) for p in env.cell_struct.physics_polygons.values() for v in p.vertices]
        boxes[env_id] = (min(p.x for p in points), max(p.x for p in points), min(p.y for p in points), max(p.y for p in points))
    return boxes


def flood(scene: str, box: tuple[float, float, float, float]) -> Flood:
    world = engine.load_scene(SCENES / scene)
    x0, y0, x1, y1 = box
    grid: dict[tuple[int, int], list[int]] = {}
    nodes: list[Position] = []
    env_boxes = _env_boxes(world)
    for i in range(int((x1 - x0) / STEP) + 1):
        for j in range(int((y1 - y0) / STEP) + 1):
            for p in _surfaces(world, x0 + i * STEP, y0 + j * STEP, env_boxes):
                grid.setdefault((i, j), []).append(len(nodes))
                nodes.append(p)
    edges: dict[int, list[tuple[int, float]]] = {k: [] for k in range(len(nodes))}
    for (i, j), here in grid.items():
        for a in here:
            others = [b for di in (-1, 0, 1) for dj in (-1, 0, 1) for b in grid.get((i + di, j + dj), []) if b != a]
            for b in others:
                mover = world.add_mover(PLAYER, nodes[a], placement="enter_world")
                try:
                    if walk(world, mover, [nodes[a], nodes[b]]).failed_leg is None:
                        edges[a].append((b, nodes[a].get_offset(nodes[b]).length()))
                finally:
                    world.remove_mover(mover)
    return Flood(world, nodes, edges)


def shortest(f: Flood, a: int, b: int) -> float:
    """The flood's shortest route from node a to node b (inf when it has none)."""
    best = {a: 0.0}
    heap = [(0.0, a)]
    while heap:
        d, k = heapq.heappop(heap)
        if k == b:
            return d
        if d > best.get(k, math.inf):
            continue
        for n, c in f.edges[k]:
            if d + c < best.get(n, math.inf):
                best[n] = d + c
                heapq.heappush(heap, (d + c, n))
    return math.inf


#: (scene, the box flooded, connected pairs tried): the places where walking is not just a straight line
CASES = [
    ("house.json", (100.0, 100.0, 117.0, 115.0), 5),
    ("cellar.json", (100.0, 104.0, 121.0, 112.0), 5),
    ("objects.json", (56.0, 54.0, 90.0, 68.0), 5),
    ("dungeon.json", (59.0, 58.0, 76.0, 72.0), 4),
]


@needs_shared
@pytest.mark.parametrize("scene, box, pairs", CASES, ids=[c[0] for c in CASES])
def test_paths_keep_the_guarantee_and_agree_with_a_flood_fill(scene: str, box: tuple[float, float, float, float], pairs: int) -> None:
    f = flood(scene, box)
    world = f.world
    rng = random.Random(scene)
    assert len(f.nodes) > 20
    joined = apart = 0
    for _ in range(200):
        if joined >= pairs and apart >= 1:
            break
        a, b = rng.randrange(len(f.nodes)), rng.randrange(len(f.nodes))
        if f.nodes[a].get_offset(f.nodes[b]).length() < 3.0:
            continue
        best = shortest(f, a, b)
        if math.isinf(best):
            if apart >= 2:
                continue
            # the flood is bounded by its box, the search is not: it may find a way round outside it;
            # either way it answers, with a reason when it finds none
            apart += 1
            path = world.path(PLAYER, f.nodes[a], f.nodes[b])
            assert path.found or path.reason in ("unreachable", "budget"), path
            continue
        if joined >= pairs:
            continue
        path = world.path(PLAYER, f.nodes[a], f.nodes[b])
        assert path.found, (scene, f.nodes[a], f.nodes[b], path.reason, path.detail, best)
        walked = walk_as_spec(world, PLAYER, path.waypoints)
        assert walked.failed_leg is None, walked.why
        assert path.length <= 1.15 * best + 1e-6, (path.length, best, path.waypoints)
        joined += 1
    assert joined == pairs
