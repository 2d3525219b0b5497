"""NavGraph: one walker class's graph of walkable nodes, joined by walks the transition made.

Nodes are sampled per cell (a tile: engine.navigation.sampling), the first
time the search or a build reaches the cell. A node's edges are walked the
first time the search expands it: from the node, with the class's
representative probe placed there, toward every node within the link radius
and, in each lattice direction with no near neighbour, toward the first node
farther out along it (a drop off a ledge or down a slope too steep to stand
on, which no near node spans). An edge exists where that walk arrives
(engine.navigation.walk): the graph is directed, so a ledge walked down need
not be walkable up.

Node keys are ints, the tile's cell id shifted left 16 bits plus the node's
index in its tile. Coordinates are kept global (metres from landblock 0000's
south-west corner) so that distances across landblocks are plain
differences.

A landblock's tiles are dropped, with its eight neighbours' (whose edges may
lead into it), when it is unloaded, loaded again, or newly loaded beside
them (refresh, run before every query), and the whole graph goes when the
World's settings change.
"""

from __future__ import annotations

import math
from array import array
from dataclasses import dataclass
from typing import TYPE_CHECKING, Final

from ..constants import CELL_LENGTH
from ..geometry import Position, Vec3
from ..cells.env_cell import EnvCell
from ..cells.land_cell import LandCell
from ..world.placement import run_placement
from ..world.mover import Mover
from ..world.transient import TS
from .sampling import block_xy, env_cell_box, indoor_candidates, outdoor_candidates
from .settings import NavSettings
from .walk import ProbeState, walk_toward
from .walker import WalkerClass

if TYPE_CHECKING:
    from ..world.landblock import Landblock
    from ..world.world import World

__all__ = [
    "GraphWorkExhausted", "NavGraph", "Tile", "GraphStats", "place_probe", "global_coords", "LONG_LINK_SPAN"]

#: how far a long link (a drop, a steep slope) may reach, metres: one steep 24 m cell and a lattice step
LONG_LINK_SPAN: Final = 36.0
#: two candidates of one tile closer than this many lattice spacings are one node
_MERGE_SPACINGS: Final = 0.3
#: eight lattice directions
_DIRECTIONS: Final = tuple((math.cos(a * math.pi / 4.0), math.sin(a * math.pi / 4.0)) for a in range(8))


def place_probe(world: World, probe: Mover, position: Position, slide: bool) -> bool:
    """Place the probe at `position` as a new object is placed (enter_world); True when it stands
    there on walkable ground. The probe is in no cell's shadow list before or after."""
    outcome, t, _ = run_placement(world, probe, position, "enter_world", slide)
    if outcome != "OK":
        return False
    probe.set_position_internal(t)
    return bool(probe.transient & TS.CONTACT) and bool(probe.transient & TS.ON_WALKABLE)


class Tile:
    """The nodes of one cell: global x, y, absolute z."""

    __slots__ = ("cell_id", "gx", "gy", "z", "edges")

    def __init__(self, cell_id: int) -> None:
        self.cell_id = cell_id
        self.gx = array("d")
        self.gy = array("d")
        self.z = array("d")
        #: node index -> (target keys, costs), once walked
        self.edges: dict[int, tuple[array[int], array[float]]] = {}

    def __len__(self) -> int:
        return len(self.gx)


@dataclass(frozen=True, slots=True)
class GraphStats:
    """What a graph holds: tiles, nodes, nodes whose edges were walked, edges."""

    tiles: int
    nodes: int
    expanded_nodes: int
    edges: int


class GraphWorkExhausted(Exception):
    """A query's allowance of graph building ran out before it could answer (NavGraph.work_allowed)."""


class NavGraph:
    """The graph of one walker class in one World (engine.navigation.cache keeps them)."""

    def __init__(self, world: World, walker: WalkerClass, nav: NavSettings) -> None:
        self.world = world
        self.walker = walker
        self.nav = nav
        self.probe = walker.representative()
        self.probe.calc_acceleration(world.settings.sled_gravity)
        #: the probe as new, put back before every placement so that a node's state never depends on
        #: what the probe did before
        self._fresh = ProbeState(self.probe)
        self.settings = world.settings
        self.tiles: dict[int, Tile] = {}
        #: landblock id -> the Landblock object (or None) the tiles were built against
        self._seen: dict[int, Landblock | None] = {}
        #: landblock id -> [(env cell id, x0, x1, y0, y1, z0, z1)] in global coordinates
        self._env_boxes: dict[int, list[tuple[int, float, float, float, float, float, float]]] = {}
        #: walks made building edges (a measure of the work done)
        self.walks = 0
        #: the graph building (placements and walks) the current query may still start: a tile or a
        #: node's edges is begun only while `work_done < work_allowed`, and finished once begun, so what
        #: is built is whole and kept; negative: no limit (engine.navigation.path sets both per query)
        self.work_allowed = -1
        self.work_done = 0
        #: (global x, y) // resolution -> the keys of the nodes there: the spatial index of nodes_near
        self._grid: dict[tuple[int, int], list[int]] = {}

    # -- keeping up with the world --------------------------------------------------
    def refresh(self) -> None:
        """Drop what a change of the loaded landblocks made stale."""
        landblocks = self.world.landblocks
        stale = [lb for lb, seen in self._seen.items() if landblocks.get(lb) is not seen]
        for lb in stale:
            self._drop_around(lb)

    def _drop_around(self, lb_id: int) -> None:
        x, y = lb_id >> 8, lb_id & 0xFF
        around = {((x + dx) << 8) | (y + dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1)
                  if 0 <= x + dx <= 0xFF and 0 <= y + dy <= 0xFF}
        for cell_id in [c for c in self.tiles if (c >> 16) in around]:
            tile = self.tiles.pop(cell_id)
            for i in range(len(tile)):
                bucket = self._grid.get(self._bucket(tile.gx[i], tile.gy[i]))
                if bucket is not None:
                    bucket.remove((cell_id << 16) | i)
        for lb in around:
            self._seen.pop(lb, None)
            self._env_boxes.pop(lb, None)

    def _note_landblock(self, lb_id: int) -> None:
        """Remember the state of a landblock and its neighbours that this landblock's tiles rest on."""
        landblocks = self.world.landblocks
        x, y = lb_id >> 8, lb_id & 0xFF
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                if 0 <= x + dx <= 0xFF and 0 <= y + dy <= 0xFF:
                    other = ((x + dx) << 8) | (y + dy)
                    if other not in self._seen:
                        self._seen[other] = landblocks.get(other)

    # -- nodes ------------------------------------------------------------------------
    def tile(self, cell_id: int) -> Tile | None:
        """The tile of a cell, sampled now if it was not; None when the cell is not loaded."""
        tile = self.tiles.get(cell_id)
        if tile is not None:
            return tile
        landblock = self.world.landblocks.get(cell_id >> 16)
        if landblock is None:
            return None
        cell = landblock.get_cell(cell_id)
        if cell is None:
            return None
        self._begin_work()
        self._note_landblock(cell_id >> 16)
        tile = Tile(cell_id)
        radius = self.walker.radius
        spacing = self.nav.resolution
        if isinstance(cell, LandCell):
            candidates = outdoor_candidates(self.world, landblock, cell, spacing, radius)
        elif isinstance(cell, EnvCell):
            candidates = indoor_candidates(cell, spacing, radius)
        else:
            candidates = []
        bx, by = block_xy(cell_id)
        merge = (_MERGE_SPACINGS * spacing) ** 2
        #: bucket -> indices of this tile's nodes in and around it (the merge test's neighbours)
        taken: dict[tuple[int, int], list[int]] = {}
        probe = self.probe
        self.work_done += len(candidates)
        for _, x, y, z in candidates:
            self._fresh.restore()
            if not place_probe(self.world, probe, Position.at(cell_id, Vec3(x, y, z)), False):
                continue
            where = probe.position
            if where.cell_id != cell_id:
                continue  # the node belongs to another cell's tile, which samples it itself
            o = where.frame.origin
            gx, gy = bx + o.x, by + o.y
            if any((gx - tile.gx[i]) ** 2 + (gy - tile.gy[i]) ** 2 + (o.z - tile.z[i]) ** 2 < merge
                   for i in taken.get(self._bucket(gx, gy), ())):
                continue
            for near in self._around(gx, gy):
                taken.setdefault(near, []).append(len(tile))
            tile.gx.append(gx)
            tile.gy.append(gy)
            tile.z.append(o.z)
        for i in range(len(tile)):
            self._grid.setdefault(self._bucket(tile.gx[i], tile.gy[i]), []).append((cell_id << 16) | i)
        self.tiles[cell_id] = tile
        return tile

    def _begin_work(self) -> None:
        if 0 <= self.work_allowed <= self.work_done:
            raise GraphWorkExhausted(f"{self.work_done:,} placements and walks")

    def _bucket(self, gx: float, gy: float) -> tuple[int, int]:
        s = self.nav.resolution
        return math.floor(gx / s), math.floor(gy / s)

    def _around(self, gx: float, gy: float) -> list[tuple[int, int]]:
        bx, by = self._bucket(gx, gy)
        return [(bx + dx, by + dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1)]

    def position(self, key: int) -> Position:
        """A node's Position."""
        cell_id = key >> 16
        tile = self.tiles[cell_id]
        i = key & 0xFFFF
        bx, by = block_xy(cell_id)
        return Position.at(cell_id, Vec3(tile.gx[i] - bx, tile.gy[i] - by, tile.z[i]))

    def coords(self, key: int) -> tuple[float, float, float]:
        tile = self.tiles[key >> 16]
        i = key & 0xFFFF
        return tile.gx[i], tile.gy[i], tile.z[i]

    def _env_cells_of(self, lb_id: int) -> list[tuple[int, float, float, float, float, float, float]]:
        boxes = self._env_boxes.get(lb_id)
        if boxes is None:
            landblock = self.world.landblocks.get(lb_id)
            boxes = [] if landblock is None else [(c.id, *env_cell_box(c)) for c in landblock.env_cells.values()]
            self._env_boxes[lb_id] = boxes
        return boxes

    def tiles_near(self, gx: float, gy: float, radius: float) -> list[Tile]:
        """Every loaded cell's tile that may hold a node within `radius` of global (gx, gy)."""
        out: list[Tile] = []
        c0 = math.floor((gx - radius) / CELL_LENGTH)
        c1 = math.floor((gx + radius) / CELL_LENGTH)
        r0 = math.floor((gy - radius) / CELL_LENGTH)
        r1 = math.floor((gy + radius) / CELL_LENGTH)
        blocks: set[int] = set()
        for cx in range(c0, c1 + 1):
            for cy in range(r0, r1 + 1):
                if not (0 <= cx < 256 * 8 and 0 <= cy < 256 * 8):
                    continue
                lb_id = ((cx // 8) << 8) | (cy // 8)
                blocks.add(lb_id)
                tile = self.tile((lb_id << 16) | ((cx % 8) * 8 + (cy % 8) + 1))
                if tile is not None:
                    out.append(tile)
        for lb_id in blocks:
            for env_id, x0, x1, y0, y1, _, _ in self._env_cells_of(lb_id):
                if x0 - radius <= gx <= x1 + radius and y0 - radius <= gy <= y1 + radius:
                    tile = self.tile(env_id)
                    if tile is not None:
                        out.append(tile)
        return out

    def nodes_near(self, gx: float, gy: float, z: float, radius: float, max_dz: float) -> list[tuple[float, int]]:
        """(horizontal distance, key) of the nodes within `radius` horizontally and `max_dz` vertically, nearest first."""
        found: list[tuple[float, int]] = []
        r2 = radius * radius
        self.tiles_near(gx, gy, radius)  # (sampled now where they were not)
        s = self.nav.resolution
        grid = self._grid
        tiles = self.tiles
        for bx in range(math.floor((gx - radius) / s), math.floor((gx + radius) / s) + 1):
            for by in range(math.floor((gy - radius) / s), math.floor((gy + radius) / s) + 1):
                for key in grid.get((bx, by), ()):
                    tile = tiles[key >> 16]
                    i = key & 0xFFFF
                    d2 = (tile.gx[i] - gx) ** 2 + (tile.gy[i] - gy) ** 2
                    if d2 <= r2 and abs(tile.z[i] - z) <= max_dz:
                        found.append((math.sqrt(d2), key))
        found.sort()
        return found

    # -- edges ------------------------------------------------------------------------
    def edges(self, key: int) -> tuple[array[int], array[float]]:
        """The node's out-edges (target keys, costs), walked now if they were not: to every node within
        the link radius, then, in each lattice direction no such edge went, to the first node farther
        out that way (a long link: a slope too steep to stand on, a drop, a doorway wider apart)."""
        tile = self.tiles[key >> 16]
        i = key & 0xFFFF
        known = tile.edges.get(i)
        if known is not None:
            return known
        self._begin_work()
        self.work_done += 1
        targets: array[int] = array("q")
        costs: array[float] = array("d")
        probe = self.probe
        world = self.world
        self._fresh.restore()
        if place_probe(world, probe, self.position(key), False):
            start = ProbeState(probe)
            gx, gy, z = tile.gx[i], tile.gy[i], tile.z[i]

            def attempt(target: int) -> None:
                start.restore()
                self.walks += 1
                self.work_done += 1
                if walk_toward(world.landscape, probe, self.position(target), self.nav):
                    tx, ty, tz = self.coords(target)
                    targets.append(target)
                    costs.append(math.sqrt((tx - gx) ** 2 + (ty - gy) ** 2 + (tz - z) ** 2))

            spanned: array[int] = array("q")
            for target in self._near(key, gx, gy, z):
                if self._spanned(targets, target, gx, gy, z):
                    spanned.append(target)  # (its direction is gone that way too: no long link there)
                else:
                    attempt(target)
            gone = self._directions(targets + spanned, gx, gy)
            for d, (ux, uy) in enumerate(_DIRECTIONS):
                if not gone[d]:
                    far = self._first_along(key, gx, gy, z, ux, uy)
                    if far is not None and far not in targets:
                        attempt(far)
        tile.edges[i] = (targets, costs)
        return targets, costs

    def _near(self, key: int, gx: float, gy: float, z: float) -> list[int]:
        radius = self.nav.link_radius
        return [k for _, k in self.nodes_near(gx, gy, z, radius, 2.0 * radius + self.walker.step_up_height) if k != key]

    def _spanned(self, targets: array[int], target: int, gx: float, gy: float, z: float) -> bool:
        """Whether two nodes already linked from (gx, gy, z), each one lattice step from it and from
        `target` and all four on one surface (no steeper between them than a walkable slope), span the
        way to `target`: on open
        ground the diagonal of a lattice square. Its walk is then left out: the route through either
        neighbour is there, and the proof walk shortens a route to the straight line wherever that walks,
        so the diagonal changes no answer but costs a quarter of a graph's walks."""
        step = 1.05 * self.nav.resolution
        rise = 1.15 * step  # (FloorZ's slope, 48.6 degrees, rises 1.13 m a metre)
        tx, ty, tz = self.coords(target)
        if abs(tz - z) > rise:
            return False
        corners = 0
        for k in targets:
            mx, my, mz = self.coords(k)
            if (abs(mz - z) <= rise and abs(mz - tz) <= rise and math.hypot(mx - gx, my - gy) <= step
                    and math.hypot(tx - mx, ty - my) <= step):
                corners += 1
                if corners == 2:
                    return True
        return False

    def _directions(self, targets: array[int], gx: float, gy: float) -> list[bool]:
        """For each lattice direction, whether one of `targets` lies that way (within 23 degrees) from (gx, gy)."""
        gone = [False] * 8
        for k in targets:
            nx, ny, _ = self.coords(k)
            dx, dy = nx - gx, ny - gy
            d = math.hypot(dx, dy)
            if d > 0.0:
                for j, (ux, uy) in enumerate(_DIRECTIONS):
                    if (dx * ux + dy * uy) / d > 0.92:
                        gone[j] = True
        return gone

    def _first_along(self, key: int, gx: float, gy: float, z: float, ux: float, uy: float) -> int | None:
        """The first node beyond the link radius along direction (ux, uy), up to LONG_LINK_SPAN."""
        spacing = self.nav.resolution
        reach = self.nav.link_radius + spacing
        while reach <= LONG_LINK_SPAN:
            for _, k in self.nodes_near(gx + ux * reach, gy + uy * reach, z, 0.75 * spacing, LONG_LINK_SPAN * 2.0):
                if k != key:
                    return k
            reach += spacing
        return None

    def predecessors(self, key: int) -> list[int]:
        """The nodes with an edge into `key` among its near nodes and the first node back along each
        lattice direction (where a long link into it would come from)."""
        gx, gy, z = self.coords(key)
        candidates = set(self._near(key, gx, gy, z))
        for ux, uy in _DIRECTIONS:
            back = self._first_along(key, gx, gy, z, -ux, -uy)
            if back is not None:
                candidates.add(back)
        return [k for k in sorted(candidates) if key in self.edges(k)[0]]

    def build_landblock(self, lb_id: int) -> None:
        """Sample every cell of a loaded landblock and walk every node's edges (the eager build)."""
        landblock = self.world.landblocks.get(lb_id)
        if landblock is None:
            return
        cells = [c.id for c in landblock.cells] + sorted(landblock.env_cells)
        for cell_id in cells:
            self.tile(cell_id)
        for cell_id in cells:
            tile = self.tiles.get(cell_id)
            if tile is None:
                continue
            for i in range(len(tile)):
                self.edges((cell_id << 16) | i)

    def stats(self, lb_id: int | None = None) -> GraphStats:
        tiles = [t for c, t in self.tiles.items() if lb_id is None or (c >> 16) == lb_id]
        return GraphStats(len(tiles), sum(len(t) for t in tiles), sum(len(t.edges) for t in tiles),
                          sum(len(e[0]) for t in tiles for e in t.edges.values()))


def global_coords(position: Position) -> tuple[float, float, float]:
    """A Position's global x, y and absolute z."""
    bx, by = block_xy(position.cell_id)
    o = position.frame.origin
    return bx + o.x, by + o.y, o.z

