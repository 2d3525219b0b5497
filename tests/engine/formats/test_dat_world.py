"""A World opened on a dat directory: lazy loads, the LRU cache, replay equal to the scene JSON.

The shared dats (`shared/dats/{rolling,house,objects}`) carry exactly the
reference scenes of the same names, so a World on them must answer every
move as the World loaded from the scene JSON does. Small dat pairs for the
cache and error checks are written here with the test-only writer.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

import engine
from engine import EngineError, LandblockNotLoadedError, Position, Vec3, World
from engine.formats.dat import DatError
from engine.formats.dat_world import DAT_DIR_ENV, DatLandblockSource, open_dat_world
from engine.formats.trace import mover_spec_from_case
from engine.terrain.landblock import LandblockTerrain

from benchmarks.scenes import PLAYER
from support.dat_records import scene_to_dat_files, write_scene_dats
from support.datwriter import DATA_SET_CELL, DATA_SET_PORTAL, write_dat
from support.shared_data import DATS, load_scene_json, load_trace, require_shared, scene_path

require_shared()  # every test here reads the shared dats or traces

A, B = 0xA9B4, 0xAAB4  # two landblocks side by side in x


def _trace(name: str) -> dict[str, Any]:
    return load_trace(name)


def _outcome(world: World, case: dict[str, Any]) -> Any:
    """What replaying `case` gives: its results, or the error it raised (by type and text)."""
    try:
        return engine.run_case(world, case)
    except Exception as e:  # noqa: BLE001 - the same failure on both worlds is the same answer
        return f"{type(e).__name__}: {e}"


def _two_block_scene(height: int = 100) -> dict[str, Any]:
    """A flat scene of landblocks A and B (height byte `height`, 0.5 m per byte)."""
    return {
        "format": "acphys-scene/1",
        "name": "two",
        "height_table": [b * 0.5 for b in range(256)],
        "landblocks": [{"id": f"{lb:04X}", "heights": [height] * 81} for lb in (A, B)],
    }


@pytest.fixture
def two_blocks(tmp_path: Path) -> Path:
    return write_scene_dats(tmp_path / "two", _two_block_scene(), fanout=3)


def _cell(lb: int, x: float, y: float) -> int:
    return (lb << 16) | (int(x // 24) * 8 + int(y // 24) + 1)


def _walk(world: World, mid: int, dx: float, steps: int) -> None:
    for _ in range(steps):
        p = world.mover(mid).position
        r = world.move(mid, Position(p.cell_id, p.frame.with_origin(p.frame.origin + Vec3(dx, 0.0, 0.0))))
        assert r.ok


# -- replay: the dat World answers as the JSON World -------------------------------------------

_ROLLING_CASES = _trace("rolling")["cases"]
_worlds: dict[str, World] = {}


def _rolling_worlds() -> tuple[World, World]:
    if not _worlds:
        _worlds["json"] = engine.load_scene(scene_path("rolling"))
        _worlds["dat"] = open_dat_world(DATS / "rolling")
    return _worlds["json"], _worlds["dat"]


@pytest.mark.parametrize("case", _ROLLING_CASES, ids=[c["id"] for c in _ROLLING_CASES])
def test_rolling_dat_world_replays_as_json_world(case: dict[str, Any]) -> None:
    json_world, dat_world = _rolling_worlds()
    assert engine.run_case(dat_world, case) == engine.run_case(json_world, case)


def test_rolling_replay_is_the_same_with_a_cache_of_one() -> None:
    """Viewer moves cross landblock seams: with one cached landblock they are
    loaded, dropped and loaded again, and every answer is still the same."""
    json_world = engine.load_scene(scene_path("rolling"))
    dat_world = open_dat_world(DATS / "rolling", cache_size=1)
    for case in _trace("rolling-viewer")["cases"]:
        assert _outcome(dat_world, case) == _outcome(json_world, case), case["id"]
    assert dat_world.stats["landblock_unloads"] > 0
    assert dat_world.stats["landblock_loads"] - dat_world.stats["landblock_unloads"] == len(dat_world.landblocks)
    assert len(dat_world.landblocks) == 1


def _same(a: Any, b: Any, tol: float) -> bool:
    """Equal, except that floats may differ by `tol`."""
    if isinstance(a, float) or isinstance(b, float):
        return isinstance(a, (int, float)) and isinstance(b, (int, float)) and abs(a - b) <= tol
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(_same(a[k], b[k], tol) for k in a)
    if isinstance(a, list):
        return isinstance(b, list) and len(a) == len(b) and all(_same(x, y, tol) for x, y in zip(a, b))
    return a == b


@pytest.mark.parametrize("name", ["house", "objects"])
def test_indoor_scene_replays_as_json_world(name: str) -> None:
    """The dat World replays the scene's trace exactly as the JSON World does
    (the scene loader reads frames at the single precision the dats hold)."""
    json_world = engine.load_scene(scene_path(name))
    dat_world = open_dat_world(DATS / name)
    for case in _trace(name)["cases"]:
        assert _outcome(dat_world, case) == _outcome(json_world, case), case["id"]


@pytest.mark.parametrize("name", ["rolling", "house", "objects"])
def test_dat_world_terrain_equals_scene_json(name: str) -> None:
    """Terrain alone (indoor=False), so this holds whatever state the indoor loader is in."""
    scene = load_scene_json(name)
    world = open_dat_world(DATS / name, indoor=False)
    for lb_data in scene["landblocks"]:
        lb_id = int(lb_data["id"], 16)
        expected = LandblockTerrain(lb_id, lb_data["heights"], scene["height_table"], lb_data.get("terrain"))
        got = world.load_landblock(lb_id).terrain
        for i in range(27):
            for j in range(27):
                x, y = 0.1 + i * 7.1, 0.2 + j * 7.1
                assert got.height_at(x, y) == expected.height_at(x, y), (lb_data["id"], x, y)
                assert world.terrain_height(lb_id << 16 | 1, x, y) == expected.height_at(x, y)
    assert world.loaded_landblocks() == sorted(int(lb["id"], 16) for lb in scene["landblocks"])
    assert not any(world.landblocks[int(lb["id"], 16)].has_objects for lb in scene["landblocks"])


def test_terrain_only_when_the_indoor_loader_is_missing(monkeypatch: pytest.MonkeyPatch) -> None:
    """Until engine.world.indoor_loader exists, a landblock with indoor content still loads its terrain."""
    from engine.formats import dat_world

    monkeypatch.setattr(dat_world, "indoor_loader_available", lambda: False)
    world = open_dat_world(DATS / "house")
    assert world.dat_source.indoor is False  # type: ignore[attr-defined]
    lb = world.load_landblock(A)
    assert not lb.has_objects
    assert "env_cells" in world.scene["landblocks"][0]  # the scene keeps what the dats hold


# -- world.scene: what has been read so far --------------------------------------------------------


def test_scene_accumulates_landblocks_and_portal_objects() -> None:
    scene = load_scene_json("objects")
    world = open_dat_world(DATS / "objects", indoor=False)
    assert world.scene["format"] == "acphys-scene/1"
    assert world.scene["height_table"] == scene["height_table"]
    assert world.scene["landblocks"] == []
    world.load_landblock(A)
    assert [lb["id"] for lb in world.scene["landblocks"]] == ["A9B4"]
    assert set(scene["gfx_objs"]) <= set(dict(world.scene["gfx_objs"]))
    assert set(scene["setups"]) <= set(dict(world.scene["setups"]))
    world.unload_landblock(A)
    assert world.scene["landblocks"] == []
    json.dumps(world.scene)  # still a plain acphys-scene/1 dict


def test_scene_setups_are_read_on_first_lookup() -> None:
    """Trace replay looks a mover's Setup up in world.scene before any landblock loads."""
    scene = load_scene_json("objects")
    setup_id = min(scene["setups"])
    world = open_dat_world(DATS / "objects")
    got = world.scene["setups"].get(setup_id)
    assert got is not None and {k: got[k] for k in scene["setups"][setup_id]} == scene["setups"][setup_id]
    assert world.scene["setups"].get("02FFFFFF") is None
    assert world.scene["setups"].get("01000001") is None  # not a Setup id
    spec = mover_spec_from_case({"setup": setup_id}, world.scene)
    assert spec == mover_spec_from_case({"setup": setup_id}, scene)


# -- the LRU cache -------------------------------------------------------------------------------------


def test_cache_of_one_loads_and_unloads_as_a_mover_walks_across(two_blocks: Path) -> None:
    world = open_dat_world(two_blocks, cache_size=1)
    assert world.stats["landblock_cache_capacity"] == 1
    assert world.loaded_landblocks() == []
    mid = world.add_mover(PLAYER, Position.at(_cell(A, 150, 96), Vec3(150.0, 96.0, 50.0)))
    assert world.loaded_landblocks() == [A]
    assert (world.stats["landblock_loads"], world.stats["landblock_unloads"]) == (1, 0)

    _walk(world, mid, 4.0, 25)  # x 150 -> 250: into B and well away from the seam
    assert world.mover(mid).position.cell_id >> 16 == B
    assert world.loaded_landblocks() == [B]
    assert (world.stats["landblock_loads"], world.stats["landblock_unloads"]) == (2, 1)

    _walk(world, mid, -4.0, 25)  # and back into A
    assert world.mover(mid).position.cell_id >> 16 == A
    assert world.loaded_landblocks() == [A]
    assert (world.stats["landblock_loads"], world.stats["landblock_unloads"]) == (3, 2)
    s = world.stats
    assert s["landblock_loads"] - s["landblock_unloads"] == s["landblock_cache_size"] == 1
    assert s["landblock_cache_misses"] == s["landblock_loads"]
    assert s["landblock_cache_hits"] > 0
    info = world.dat_source.cache_info()  # type: ignore[attr-defined]
    assert info["loaded"] == [A] and info["loads"] == s["landblock_loads"]


def test_cache_never_unloads_where_a_mover_stands(two_blocks: Path) -> None:
    world = open_dat_world(two_blocks, cache_size=1)
    m1 = world.add_mover(PLAYER, Position.at(_cell(A, 96, 96), Vec3(96.0, 96.0, 50.0)))
    m2 = world.add_mover(PLAYER, Position.at(_cell(B, 96, 96), Vec3(96.0, 96.0, 50.0)))
    _walk(world, m1, 1.0, 3)
    assert world.loaded_landblocks() == [A, B]  # over capacity: both are held
    assert world.stats["landblock_unloads"] == 0
    world.remove_mover(m1)
    _walk(world, m2, 1.0, 1)  # the World's next check trims the cache
    assert world.loaded_landblocks() == [B]
    assert world.stats["landblock_unloads"] == 1


def test_least_recently_used_goes_first(tmp_path: Path) -> None:
    scene = _two_block_scene()
    scene["landblocks"].append({"id": "ABB4", "heights": [100] * 81})
    world = open_dat_world(write_scene_dats(tmp_path / "three", scene), cache_size=2)
    world.load_landblock(A)
    world.load_landblock(B)
    world.terrain_height(A << 16 | 1, 10.0, 10.0)  # A used after B
    world.load_landblock(0xABB4)
    assert world.loaded_landblocks() == [A, 0xABB4]
    assert world.stats["landblock_unloads"] == 1


def test_cache_size_must_be_positive(two_blocks: Path) -> None:
    for bad in (0, -3, 1.5, True):
        with pytest.raises(EngineError, match="cache_size"):
            open_dat_world(two_blocks, cache_size=bad)  # type: ignore[arg-type]


# -- where the dats come from --------------------------------------------------------------------------


def test_environment_variable_names_the_dat_directory(two_blocks: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(DAT_DIR_ENV, str(two_blocks))
    for world in (open_dat_world(), engine.open_dat_world()):
        assert isinstance(world.dat_source, DatLandblockSource)  # type: ignore[attr-defined]
        assert world.load_landblock(B).id == B
    monkeypatch.delenv(DAT_DIR_ENV)
    with pytest.raises(EngineError, match=DAT_DIR_ENV):
        open_dat_world()
    assert open_dat_world(two_blocks).load_landblock(A).id == A  # an argument needs no variable


def test_load_scene_accepts_a_dat_directory(two_blocks: Path) -> None:
    world = engine.load_scene(two_blocks)
    assert world.loaded_landblocks() == []
    assert world.terrain_height(B << 16 | 1, 5.0, 5.0) == pytest.approx(50.0)


# -- errors ------------------------------------------------------------------------------------------------


def test_missing_landblock_is_landblock_not_loaded(two_blocks: Path) -> None:
    world = open_dat_world(two_blocks)
    with pytest.raises(LandblockNotLoadedError, match=r"0101.*not in the dat files"):
        world.load_landblock(0x0101)
    with pytest.raises(LandblockNotLoadedError, match="A9B5"):
        world.add_mover(PLAYER, Position.at(0xA9B50001, Vec3(10.0, 10.0, 50.0)))
    assert world.loaded_landblocks() == []
    # a move that reaches past the dats' edge sees no landblock there, as a scene World does
    mid = world.add_mover(PLAYER, Position.at(_cell(A, 2, 96), Vec3(2.0, 96.0, 50.0)))
    world.move(mid, Position.at(_cell(A, 2, 96), Vec3(1.0, 96.0, 50.0)))
    assert world.loaded_landblocks() == [A]


def test_corrupt_landblock_raises_dat_error_naming_it(tmp_path: Path) -> None:
    cell, portal = scene_to_dat_files(_two_block_scene())
    bad_id = (B << 16) | 0xFFFF
    cell[bad_id] = cell[bad_id][:40]  # shorter than its fields
    directory = tmp_path / "bad"
    directory.mkdir()
    write_dat(directory / "client_cell_1.dat", cell, block_size=256, data_set=DATA_SET_CELL, subset=1)
    write_dat(directory / "client_portal.dat", portal, block_size=1024, data_set=DATA_SET_PORTAL)
    world = open_dat_world(directory)
    assert world.load_landblock(A).id == A
    with pytest.raises(DatError, match="0xAAB4FFFF") as info:
        world.load_landblock(B)
    assert info.value.file_id == bad_id
    assert world.loaded_landblocks() == [A]
    assert world.stats["landblock_loads"] == 1


def test_not_a_dat_directory(tmp_path: Path) -> None:
    with pytest.raises(DatError):
        open_dat_world(tmp_path / "nowhere")
    with pytest.raises(DatError, match="client_cell_1.dat"):
        open_dat_world(tmp_path)


def test_missing_indoor_module_falls_back_to_terrain_with_a_warning(monkeypatch: pytest.MonkeyPatch) -> None:
    from engine.formats import dat_world

    real = dat_world.build_landblock

    def build(lb_data: dict[str, Any], *args: Any, **kwargs: Any) -> Any:
        if "env_cells" in lb_data:
            raise ModuleNotFoundError("No module named 'engine.objects.later'", name="engine.objects.later")
        return real(lb_data, *args, **kwargs)

    monkeypatch.setattr(dat_world, "build_landblock", build)
    world = open_dat_world(DATS / "house", indoor=True)
    with pytest.warns(RuntimeWarning, match="terrain only"):
        lb = world.load_landblock(A)
    assert not lb.has_objects and world.dat_source.indoor is False  # type: ignore[attr-defined]
