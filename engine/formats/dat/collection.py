"""A client dat directory read as `acphys-scene/1` dicts.

`DatCollection` opens `client_cell_1.dat` and `client_portal.dat` side by
side and answers with exactly the dicts a scene JSON file would hold, so the
scene builder needs no dat-specific path: a landblock dict from the cell dat,
the portal objects it references (recursively: a Setup's parts), the
Region's height table, or a whole scene.

Apart from the Region (read once), nothing is cached across calls: records
are parsed on demand and each call returns fresh dicts the caller may keep
or change. Callers that load many
landblocks pass the ids they already hold as `known` to `portal_objects`.
"""

from __future__ import annotations

import os
from collections.abc import Collection, Iterable, Iterator
from typing import Any

from .cell_records import parse_cell_landblock, parse_env_cell, parse_landblock_info
from .container import ClosesOnExit, DatFile
from .environment import parse_environment
from .errors import DatError, DatFileMissing
from .gfxobj import parse_gfx_obj
from .region import REGION_ID, RegionInfo, parse_region
from .setup import parse_setup
from .shapes import dat_id_hex, landblock_hex

__all__ = [
    "DatCollection",
    "CELL_DAT_NAME",
    "PORTAL_DAT_NAME",
    "SCENE_FORMAT",
    "landblock_references",
    "is_dat_directory",
]

CELL_DAT_NAME = "client_cell_1.dat"
PORTAL_DAT_NAME = "client_portal.dat"
SCENE_FORMAT = "acphys-scene/1"

FIRST_ENV_CELL = 0x0100
LAST_ENV_CELL = 0xFFFD
_LANDBLOCK_LOW = 0xFFFF
_INFO_LOW = 0xFFFE

# Portal dat type byte -> the scene format's top-level dictionary.
_PORTAL_KINDS = {0x01: "gfx_objs", 0x02: "setups", 0x0D: "environments"}


def _find_dat(directory: str, name: str) -> str:
    """`directory/name`, matching the name case-insensitively (dats copied from Windows vary)."""
    exact = os.path.join(directory, name)
    if os.path.exists(exact):
        return exact
    try:
        for entry in os.listdir(directory):
            if entry.lower() == name.lower():
                return os.path.join(directory, entry)
    except OSError as exc:
        raise DatError(f"cannot list dat directory: {exc.strerror or exc}", path=directory) from exc
    raise DatError(f"no {name} in this directory", path=directory)


def is_dat_directory(path: str | os.PathLike[str]) -> bool:
    """Whether `path` is a directory holding both client dat files."""
    path = os.fspath(path)
    if not os.path.isdir(path):
        return False
    names = {n.lower() for n in os.listdir(path)}
    return CELL_DAT_NAME in names and PORTAL_DAT_NAME in names


def _landblock_number(lb_id: int) -> int:
    """Accept XXYY, or any cell / record id of the landblock (XXYYnnnn)."""
    if lb_id < 0 or lb_id > 0xFFFFFFFF:
        raise ValueError(f"not a landblock id: {lb_id!r}")
    return lb_id >> 16 if lb_id > 0xFFFF else lb_id


def landblock_references(landblock: dict[str, Any]) -> set[int]:
    """Portal dat ids a scene-format landblock dict refers to directly
    (EnvCell environments and static objects, building models, objects)."""
    refs: set[int] = set()
    for cell in landblock.get("env_cells", ()):
        refs.add(int(cell["environment_id"], 16))
        refs.update(int(s["id"], 16) for s in cell.get("static_objects", ()))
    refs.update(int(b["model_id"], 16) for b in landblock.get("buildings", ()))
    refs.update(int(o["id"], 16) for o in landblock.get("objects", ()))
    return refs


class DatCollection(ClosesOnExit):
    """The client's cell and portal dats in one directory, read as scene dicts."""

    def __init__(self, directory: str | os.PathLike[str]) -> None:
        self.directory = os.fspath(directory)
        if not os.path.isdir(self.directory):
            raise DatError("not a directory", path=self.directory)
        self.cell = DatFile(_find_dat(self.directory, CELL_DAT_NAME))
        try:
            self.portal = DatFile(_find_dat(self.directory, PORTAL_DAT_NAME))
        except BaseException:
            self.cell.close()
            raise
        self._region: RegionInfo | None = None

    # -- world constants ----------------------------------------------------------

    @property
    def region(self) -> RegionInfo:
        """The Region record (0x13000000), read once."""
        if self._region is None:
            self._region = parse_region(self.portal.read(REGION_ID), path=self.portal.path, file_id=REGION_ID)
        return self._region

    def height_table(self) -> list[float]:
        """The LandHeightTable: metres for each of the 256 height bytes."""
        return list(self.region.height_table)

    # -- landblocks ---------------------------------------------------------------

    def iter_landblock_ids(self) -> Iterator[int]:
        """Every landblock (XXYY) with a CellLandblock record, ascending (walks the cell dat's B-tree)."""
        for file_id in self.cell.iter_ids():
            if file_id & 0xFFFF == _LANDBLOCK_LOW and file_id >> 16 != 0xFFFF:  # 0xFFFF.... is the iteration record
                yield file_id >> 16

    def landblock_ids(self) -> list[int]:
        """`iter_landblock_ids` as a list."""
        return list(self.iter_landblock_ids())

    def has_landblock(self, lb_id: int) -> bool:
        """Whether the cell dat has landblock `lb_id` (XXYY or any XXYYnnnn id)."""
        return ((_landblock_number(lb_id) << 16) | _LANDBLOCK_LOW) in self.cell

    def landblock_dict(self, lb_id: int, references: set[int] | None = None) -> dict[str, Any]:
        """The scene-format landblock `lb_id` (XXYY, or any XXYYnnnn id of it).

        Keys: `id`, `heights`, `terrain`, and, when the LandblockInfo lists any,
        `env_cells`, `buildings`, `objects`. Portal ids the landblock refers to
        are added to `references` when given (see `portal_objects`).
        Raises DatFileMissing if the cell dat has no such landblock.
        """
        lb = _landblock_number(lb_id)
        cell_path = self.cell.path
        land_id = (lb << 16) | _LANDBLOCK_LOW
        land = parse_cell_landblock(self.cell.read(land_id), path=cell_path, file_id=land_id)
        out: dict[str, Any] = {"id": landblock_hex(lb), "heights": land.heights, "terrain": land.terrain}
        info_id = (lb << 16) | _INFO_LOW
        if self.cell.find(info_id) is not None:
            info = parse_landblock_info(self.cell.read(info_id), path=cell_path, file_id=info_id)
            cells = self._env_cells(lb, info.num_cells, info_id)
            if cells:
                out["env_cells"] = cells
            if info.buildings:
                out["buildings"] = info.buildings
            if info.objects:
                out["objects"] = info.objects
        if references is not None:
            references |= landblock_references(out)
        return out

    def _env_cells(self, lb: int, count: int, info_id: int) -> list[dict[str, Any]]:
        if count > LAST_ENV_CELL - FIRST_ENV_CELL + 1:
            raise DatError(f"LandblockInfo claims {count} EnvCells", path=self.cell.path, file_id=info_id)
        cells = []
        for index in range(FIRST_ENV_CELL, FIRST_ENV_CELL + count):
            cell_id = (lb << 16) | index
            try:
                data = self.cell.read(cell_id)
            except DatFileMissing:
                raise DatError(
                    f"EnvCell missing: the landblock's LandblockInfo (0x{info_id:08X}) lists {count} cells",
                    path=self.cell.path, file_id=cell_id,
                ) from None  # fmt: skip
            cells.append(parse_env_cell(data, path=self.cell.path, file_id=cell_id))
        return cells

    # -- portal objects -----------------------------------------------------------

    def portal_object(self, obj_id: int) -> tuple[str, dict[str, Any]]:
        """One portal object as (scene dictionary name, scene dict): an
        Environment, GfxObj or Setup. Raises DatFileMissing if absent."""
        kind = _PORTAL_KINDS.get(obj_id >> 24)
        if kind is None:
            raise DatError(
                "referenced as a model, but only GfxObj (0x01), Setup (0x02) and Environment (0x0D) ids are",
                path=self.portal.path, file_id=obj_id,
            )  # fmt: skip
        data = self.portal.read(obj_id)
        parser = {"gfx_objs": parse_gfx_obj, "setups": parse_setup, "environments": parse_environment}[kind]
        return kind, parser(data, path=self.portal.path, file_id=obj_id)

    def portal_objects(self, ids: Iterable[int], known: Collection[int] = ()) -> dict[str, dict[str, Any]]:
        """Every portal object reachable from `ids` (a Setup brings its parts),
        as `{"environments": {...}, "gfx_objs": {...}, "setups": {...}}` keyed by
        8-digit hex ids in ascending order. Ids in `known` are neither read nor
        followed."""
        found: dict[str, dict[int, dict[str, Any]]] = {k: {} for k in ("environments", "gfx_objs", "setups")}
        seen: set[int] = set()
        pending = [i for i in ids if i not in known]
        while pending:
            obj_id = pending.pop()
            if obj_id in seen:
                continue
            seen.add(obj_id)
            kind, obj = self.portal_object(obj_id)
            found[kind][obj_id] = obj
            if kind == "setups":
                pending.extend(p for p in (int(h, 16) for h in obj["parts"]) if p not in known and p not in seen)
        return {kind: {dat_id_hex(i): objs[i] for i in sorted(objs)} for kind, objs in found.items()}

    # -- whole scenes ---------------------------------------------------------------

    def scene_dict(self, landblock_ids: Iterable[int] | None = None, *, name: str | None = None) -> dict[str, Any]:
        """A whole `acphys-scene/1` dict: the height table, the landblocks (all
        of the cell dat's when `landblock_ids` is None, else those, in that
        order) and every portal object they reference. Empty object
        dictionaries are left out, as a scene file would. `name` defaults to
        the directory's name.
        """
        ids = self.landblock_ids() if landblock_ids is None else list(landblock_ids)
        refs: set[int] = set()
        landblocks = [self.landblock_dict(lb, refs) for lb in ids]
        scene: dict[str, Any] = {
            "format": SCENE_FORMAT,
            "name": name if name is not None else os.path.basename(os.path.normpath(self.directory)),
            "height_table": self.height_table(),
            "landblocks": landblocks,
        }
        for kind, objs in self.portal_objects(refs).items():
            if objs:
                scene[kind] = objs
        return scene

    # -- lifetime -------------------------------------------------------------------

    def close(self) -> None:
        """Close both dat files."""
        self.cell.close()
        self.portal.close()

    def __repr__(self) -> str:
        return f"DatCollection({self.directory!r})"
