"""A World on the client's dat files: landblocks loaded on demand, LRU-cached.

    world = open_dat_world("/games/ac")          # or $ACPHYS_DAT_DIR
    world.add_mover(spec, Position.at(0xA9B40001, Vec3(10, 10, 52)))  # loads A9B4

`open_dat_world` opens `client_cell_1.dat` and `client_portal.dat` with
`DatCollection` and gives the World a loader (`DatLandblockSource`) that
turns one landblock's scene dict into a `Landblock` with the same builder
the scene format uses. A landblock is loaded the first time the World looks
it up: the landblock a move starts or ends in, and also a neighbour a move
reaches into near a seam, so a move answers as it would with every landblock
of the dats loaded (and as the client, which holds the landblocks around the
player, does).

At most `cache_size` landblocks stay loaded: after a load, and at the World's
check before each move, the least recently used landblocks beyond that
number are unloaded, never one a registered mover stands in (so the cache
can run over while movers hold it full). `world.stats` gains
`landblock_cache_hits` (the World's before-move checks that found the
landblock loaded), `landblock_cache_misses` (landblocks read from the dats),
`landblock_cache_size` and `landblock_cache_capacity`, beside the World's own
`landblock_loads` and `landblock_unloads`.

`world.scene` is an acphys-scene/1 dict that grows as landblocks load: the
height table, the landblocks now loaded, and every portal object
(environments, gfx_objs, setups) read so far; looking up an id that is not
there yet reads it from the portal dat, so trace replay finds any Setup.

Errors: a landblock the cell dat does not have raises
LandblockNotLoadedError; a truncated or corrupt dat raises the reader's
DatError (naming the dat and the file id) unchanged.
"""

from __future__ import annotations

import importlib.util
import itertools
import os
import warnings
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from ..errors import EngineError, LandblockNotLoadedError
from ..settings import RETAIL, EngineSettings
from ..world.landblock import Landblock
from ..world.world import World
from .dat import DatCollection, DatFileMissing
from .scene import SCENE_FORMAT, build_landblock

__all__ = ["DAT_DIR_ENV", "DEFAULT_CACHE_SIZE", "DatLandblockSource", "open_dat_world", "resolve_dat_dir"]

#: Environment variable naming the client dat directory when no path is given.
DAT_DIR_ENV = "ACPHYS_DAT_DIR"
DEFAULT_CACHE_SIZE = 64

_PORTAL_KINDS = ("environments", "gfx_objs", "setups")
_PORTAL_TYPE = {"gfx_objs": 0x01, "setups": 0x02, "environments": 0x0D}
_INDOOR_KEYS = ("env_cells", "buildings", "objects")


def resolve_dat_dir(path: str | os.PathLike[str] | None) -> Path:
    """`path`, or `$ACPHYS_DAT_DIR` when `path` is None; EngineError if neither is given."""
    if path is None:
        env = os.environ.get(DAT_DIR_ENV, "").strip()
        if not env:
            raise EngineError(f"no dat directory given and ${DAT_DIR_ENV} is not set")
        path = env
    return Path(path)


def indoor_loader_available() -> bool:
    """Whether the indoor geometry builder (engine.world.indoor_loader) exists yet."""
    try:
        return importlib.util.find_spec("engine.world.indoor_loader") is not None
    except ImportError:
        return False


class _PortalObjects(dict[str, Any]):
    """One portal kind of `world.scene` (e.g. "setups"): an id missing here is
    read from the portal dat on lookup (`get`, `[]`, `in`)."""

    def __init__(self, kind: str, fetch: Callable[[int], bool]) -> None:
        super().__init__()
        self._kind = kind
        self._fetch = fetch

    def _try_fetch(self, key: object) -> bool:
        if not isinstance(key, str) or dict.__contains__(self, key):
            return False
        try:
            obj_id = int(key, 16)
        except ValueError:
            return False
        if obj_id >> 24 != _PORTAL_TYPE[self._kind] or obj_id > 0xFFFFFFFF:
            return False
        return self._fetch(obj_id) and dict.__contains__(self, key)

    def __missing__(self, key: str) -> Any:
        if self._try_fetch(key):
            return dict.__getitem__(self, key)
        raise KeyError(key)

    def get(self, key: str, default: Any = None) -> Any:  # type: ignore[override]
        if dict.__contains__(self, key) or self._try_fetch(key):
            return dict.__getitem__(self, key)
        return default

    def __contains__(self, key: object) -> bool:
        return dict.__contains__(self, key) or self._try_fetch(key)

    def __reduce__(self) -> tuple[Any, ...]:  # copies and pickles are plain dicts
        return (dict, (dict(self),))


class _LruLandblocks(dict[int, Landblock]):
    """`World.landblocks` with use order: every lookup marks a landblock used.

    The World reads its landblocks only through `in`, `get`, `[]`, item
    assignment and `pop`, so keeping the order here needs no change to World.
    """

    def __init__(self, source: DatLandblockSource) -> None:
        super().__init__()
        self._source = source
        self._clock = itertools.count()
        self.last_use: dict[int, int] = {}

    def touch(self, lb_id: int) -> None:
        self.last_use[lb_id] = next(self._clock)

    def __contains__(self, lb_id: object) -> bool:
        present = dict.__contains__(self, lb_id)
        if present and isinstance(lb_id, int):
            self.touch(lb_id)
            self._source.note_hit(lb_id)
        return present

    def get(self, lb_id: int, default: Any = None) -> Any:  # type: ignore[override]
        """The landblock, loading it from the dats when they have it (so a
        move that reaches into a neighbouring landblock sees it, as the
        client does); `default` when the dats do not."""
        if dict.__contains__(self, lb_id):
            self.touch(lb_id)
            return dict.__getitem__(self, lb_id)
        lb = self._source.autoload(lb_id) if isinstance(lb_id, int) else None
        return default if lb is None else lb

    def __getitem__(self, lb_id: int) -> Landblock:
        lb = dict.__getitem__(self, lb_id)
        self.touch(lb_id)
        return lb

    def __setitem__(self, lb_id: int, lb: Landblock) -> None:
        dict.__setitem__(self, lb_id, lb)
        self.touch(lb_id)
        self._source.note_added(lb_id, lb)

    def pop(self, lb_id: int, *default: Any) -> Any:  # type: ignore[override]
        lb = dict.pop(self, lb_id, *default)
        if self.last_use.pop(lb_id, None) is not None:
            self._source.note_removed(lb_id)
        return lb

    def __reduce__(self) -> tuple[Any, ...]:  # copies and pickles are plain dicts
        return (dict, (dict(self),))

    def least_recent_first(self) -> list[int]:
        return sorted(dict.keys(self), key=lambda i: self.last_use.get(i, -1))


class DatLandblockSource:
    """The loader a dat World calls for a landblock it does not hold.

    Reads the landblock and the portal objects it needs, builds it with
    `build_landblock`, and keeps the World's landblocks within `cache_size`
    (least recently used first, never one a mover stands in). Bind it to its
    World with `attach` before the first load.
    """

    def __init__(self, dats: DatCollection, cache_size: int = DEFAULT_CACHE_SIZE, indoor: bool | None = None) -> None:
        if not isinstance(cache_size, int) or isinstance(cache_size, bool) or cache_size < 1:
            raise EngineError(f"cache_size must be a positive integer, got {cache_size!r}")
        self.dats = dats
        self.cache_size = cache_size
        self.world: World | None = None
        #: whether landblocks are built with their indoor content (see `build`)
        self.indoor = indoor_loader_available() if indoor is None else bool(indoor)
        self.scene: dict[str, Any] = {
            "format": SCENE_FORMAT,
            "name": os.path.basename(os.path.normpath(dats.directory)),
            "height_table": dats.height_table(),
            "landblocks": [],
        }
        for kind in _PORTAL_KINDS:
            self.scene[kind] = _PortalObjects(kind, self._fetch_portal_object)
        self._known: set[int] = set()
        self._lb_dicts: dict[int, dict[str, Any]] = {}
        self._evicting = False
        self._present: set[int] = set()
        self._absent: set[int] = set()

    # -- binding ------------------------------------------------------------------
    def attach(self, world: World) -> None:
        """Make `world` use this source: its landblock table, stats and scene."""
        if world.landblocks:
            raise EngineError("a dat source must be attached to a World before it holds landblocks")
        self.world = world
        world.landblocks = _LruLandblocks(self)
        world.stats.update(
            landblock_cache_hits=0,
            landblock_cache_misses=0,
            landblock_cache_size=0,
            landblock_cache_capacity=self.cache_size,
        )
        world.scene = self.scene  # type: ignore[attr-defined]

    def _table(self) -> _LruLandblocks:
        if self.world is None or not isinstance(self.world.landblocks, _LruLandblocks):
            raise EngineError("this dat source is not attached to a World")
        return self.world.landblocks

    # -- the loader -------------------------------------------------------------------
    def __call__(self, lb_id: int) -> Landblock:
        """The World's loader: landblock `lb_id` (XXYY) read and built, not yet added."""
        return self.load(lb_id)

    def load(self, lb_id: int) -> Landblock:
        """Read and build landblock `lb_id`; LandblockNotLoadedError if the dats lack it."""
        if not self.has_landblock(lb_id):
            raise LandblockNotLoadedError(
                f"landblock {lb_id:04X} is not in the dat files in {self.dats.directory} "
                f"(client_cell_1.dat has no CellLandblock 0x{lb_id:04X}FFFF)"
                if isinstance(lb_id, int) and 0 <= lb_id <= 0xFFFF
                else f"{lb_id!r} is not a landblock id (XXYY)"
            )
        if self.world is not None:
            self.world.stats["landblock_cache_misses"] += 1
        lb_dict = self.landblock_dict(lb_id)
        landblock = self.build(lb_dict)
        self._lb_dicts[lb_id] = lb_dict
        return landblock

    def has_landblock(self, lb_id: int) -> bool:
        """Whether the cell dat holds landblock `lb_id` (answers remembered: dats do not change)."""
        if not isinstance(lb_id, int) or not 0 <= lb_id <= 0xFFFF:
            return False
        if lb_id in self._present:
            return True
        if lb_id in self._absent:
            return False
        found = self.dats.has_landblock(lb_id)
        (self._present if found else self._absent).add(lb_id)
        return found

    def autoload(self, lb_id: int) -> Landblock | None:
        """Load `lb_id` into the World if the dats have it (None if not), then
        unload least recently used landblocks beyond `cache_size`."""
        world = self.world
        if world is None or not self.has_landblock(lb_id):
            return None
        landblock = self.load(lb_id)
        world.add_landblock(landblock)
        self.evict(keep=(lb_id,))
        return landblock

    def landblock_dict(self, lb_id: int) -> dict[str, Any]:
        """Landblock `lb_id` as a scene dict, its portal objects merged into `scene`."""
        refs: set[int] = set()
        try:
            lb_dict = self.dats.landblock_dict(lb_id, refs)
        except DatFileMissing as e:
            if e.file_id == (lb_id << 16) | 0xFFFF:
                raise LandblockNotLoadedError(f"landblock {lb_id:04X} is not in the dat files: {e}") from None
            raise
        self._merge(self.dats.portal_objects(refs, self._known))
        return lb_dict

    def build(self, lb_dict: dict[str, Any]) -> Landblock:
        """A Landblock from a landblock dict, with its EnvCells, buildings and
        objects when the engine's indoor loader exists; until then (or while a
        module it needs is still missing) terrain only, with a warning once."""
        if self.indoor and any(k in lb_dict for k in _INDOOR_KEYS):
            try:
                return build_landblock(lb_dict, self.scene["height_table"], self.scene, name=self.dats.directory)
            except ModuleNotFoundError as e:
                if not (e.name or "").startswith("engine."):
                    raise
                self.indoor = False
                warnings.warn(
                    f"indoor geometry cannot be built yet ({e}); dat landblocks load their terrain only",
                    RuntimeWarning,
                    stacklevel=2,
                )
        data = {k: v for k, v in lb_dict.items() if k not in _INDOOR_KEYS}
        return build_landblock(data, self.scene["height_table"], self.scene, name=self.dats.directory)

    def _merge(self, found: dict[str, dict[str, Any]]) -> None:
        for kind, objs in found.items():
            target = self.scene[kind]
            for key, obj in objs.items():
                dict.__setitem__(target, key, obj)
                self._known.add(int(key, 16))

    def _fetch_portal_object(self, obj_id: int) -> bool:
        """Read one portal object (and its parts) into the scene; False if the dat lacks it."""
        if obj_id in self._known:
            return False
        try:
            self._merge(self.dats.portal_objects([obj_id], self._known))
        except DatFileMissing:
            return False
        return True

    # -- cache bookkeeping (called by the landblock table) ------------------------------
    def note_hit(self, lb_id: int) -> None:
        if self.world is not None:
            self.world.stats["landblock_cache_hits"] += 1
            if len(self._table()) > self.cache_size and not self._evicting:
                # an earlier load went over because movers held every other landblock
                self.evict(keep=(lb_id,))

    def note_added(self, lb_id: int, lb: Landblock) -> None:
        if self.world is not None:
            self.world.stats["landblock_cache_size"] = len(self._table())
            lb_dict = self._lb_dicts.pop(lb_id, None)
            if lb_dict is None:
                lb_dict = lb.source if isinstance(lb.source, dict) else {"id": f"{lb_id:04X}"}
            landblocks = self.scene["landblocks"]
            landblocks[:] = [d for d in landblocks if d.get("id", "").upper() != f"{lb_id:04X}"]
            landblocks.append(lb_dict)

    def note_removed(self, lb_id: int) -> None:
        if self.world is not None:
            self.world.stats["landblock_cache_size"] = len(self._table())
            name = f"{lb_id:04X}"
            landblocks = self.scene["landblocks"]
            landblocks[:] = [d for d in landblocks if d.get("id", "").upper() != name]

    def occupied(self) -> set[int]:
        """Landblocks a registered mover stands in."""
        if self.world is None:
            return set()
        return {(m.position.cell_id >> 16) & 0xFFFF for m in self.world.movers.values()}

    def evict(self, keep: Iterable[int] = ()) -> list[int]:
        """Unload least recently used landblocks until at most `cache_size`
        remain, skipping those in `keep` and those a mover stands in. Returns
        the ids unloaded (fewer than needed when movers hold the rest; the
        next check of the World's goes on from there)."""
        world = self.world
        if world is None:
            return []
        table = self._table()
        excess = len(table) - self.cache_size
        if excess <= 0:
            return []
        protected = self.occupied() | set(keep)
        unloaded: list[int] = []
        self._evicting = True
        try:
            for lb_id in table.least_recent_first():
                if len(unloaded) >= excess:
                    break
                if lb_id in protected:
                    continue
                world.unload_landblock(lb_id)
                unloaded.append(lb_id)
        finally:
            self._evicting = False
        return unloaded

    def cache_info(self) -> dict[str, Any]:
        """The cache's state: capacity, loaded ids in use order, and the counters."""
        table = self._table()
        stats = self.world.stats if self.world is not None else {}
        return {
            "capacity": self.cache_size,
            "loaded": table.least_recent_first(),
            "loads": stats.get("landblock_loads", 0),
            "unloads": stats.get("landblock_unloads", 0),
            "hits": stats.get("landblock_cache_hits", 0),
            "misses": stats.get("landblock_cache_misses", 0),
        }

    def close(self) -> None:
        """Close the dat files (the World can load nothing more afterwards)."""
        self.dats.close()


def open_dat_world(
    path: str | os.PathLike[str] | None = None,
    settings: EngineSettings = RETAIL,
    cache_size: int = DEFAULT_CACHE_SIZE,
    *,
    indoor: bool | None = None,
) -> World:
    """A World on the dat directory `path` (None: `$ACPHYS_DAT_DIR`), loading
    landblocks when a move or query first needs them and keeping at most
    `cache_size` of them (see the module docstring). `indoor` False builds
    terrain only (EnvCells, buildings and objects left out); None, the
    default, builds them whenever the engine's indoor loader exists. The
    source is `world.dat_source` (a `DatLandblockSource`)."""
    directory = resolve_dat_dir(path)
    dats = DatCollection(directory)
    try:
        source = DatLandblockSource(dats, cache_size, indoor)
    except BaseException:
        dats.close()
        raise
    world = World(settings=settings, loader=source)
    source.attach(world)
    world.dat_source = source
    return world
