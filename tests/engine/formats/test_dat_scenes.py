"""Dat directories read as whole scenes: the shared reference dats must equal their scene JSON,
and every reference scene must survive a trip through the test writer's dats."""

from __future__ import annotations

import struct
from pathlib import Path

import pytest

from engine.formats.dat import (
    SCENE_FORMAT,
    DatCollection,
    DatError,
    DatFileMissing,
    is_dat_directory,
    landblock_references,
)
from support.dat_records import write_scene_dats
from support.scene_checks import check_scene
from support.scene_compare import differences, normalize_scene
from support.shared_data import DATS, load_scene_json, require_shared, scene_names

require_shared()  # the scenes are listed while collecting

DAT_SCENES = ["house", "objects", "rolling"]
ALL_SCENES = scene_names()


@pytest.mark.parametrize("name", DAT_SCENES)
def test_shared_dats_equal_scene_json(name: str) -> None:
    with DatCollection(DATS / name) as dats:
        scene = dats.scene_dict()
    expected = load_scene_json(name)
    assert scene["format"] == SCENE_FORMAT
    assert scene["name"] == expected["name"] == name
    diffs = differences(normalize_scene(scene), normalize_scene(expected))
    assert not diffs, "\n".join(diffs)
    check_scene(scene)  # the structural checks the real-dat tests apply


@pytest.mark.parametrize("name", DAT_SCENES)
def test_shared_dats_keep_dat_values_exactly(name: str) -> None:
    """Float fields are the dat's float32 values, integers and ids are exact."""
    with DatCollection(DATS / name) as dats:
        scene = dats.scene_dict()
    for h in scene["height_table"]:
        assert struct.unpack("<f", struct.pack("<f", h))[0] == h
    for lb in scene["landblocks"]:
        assert len(lb["id"]) == 4 and lb["id"] == lb["id"].upper()
        assert len(lb["heights"]) == 81 and all(isinstance(h, int) and 0 <= h <= 255 for h in lb["heights"])
        assert len(lb["terrain"]) == 81


def test_house_landblock_dict_and_references() -> None:
    with DatCollection(DATS / "house") as dats:
        refs: set[int] = set()
        lb = dats.landblock_dict(0xA9B4, refs)
        assert lb["id"] == "A9B4"
        assert [c["id"] for c in lb["env_cells"]] == ["A9B40100"]
        assert lb["buildings"][0]["model_id"] == "01000001"
        assert "objects" not in lb
        assert refs == {0x0D000001, 0x01000001} == landblock_references(lb)
        # Any id of the landblock names it; a landblock with no LandblockInfo has only terrain.
        assert dats.landblock_dict(0xA9B4FFFF) == lb
        assert sorted(dats.landblock_dict(0xA8B3)) == ["heights", "id", "terrain"]
        objs = dats.portal_objects(refs)
        assert sorted(objs["environments"]) == ["0D000001"]
        assert sorted(objs["gfx_objs"]) == ["01000001"]
        assert objs["setups"] == {}
        assert dats.portal_objects(refs, known={0x0D000001})["environments"] == {}
        assert dats.landblock_ids() == [0xA8B3, 0xA8B4, 0xA8B5, 0xA9B3, 0xA9B4, 0xA9B5, 0xAAB3, 0xAAB4, 0xAAB5]
        assert dats.has_landblock(0xA9B4) and not dats.has_landblock(0x1234)


def test_objects_setups_bring_their_parts() -> None:
    with DatCollection(DATS / "objects") as dats:
        objs = dats.portal_objects([0x02000005])
    assert sorted(objs["setups"]) == ["02000005"]
    assert sorted(objs["gfx_objs"]) == ["01000005"]


def test_subset_of_landblocks_in_given_order() -> None:
    with DatCollection(DATS / "objects") as dats:
        scene = dats.scene_dict([0xAAB5, 0xA9B4], name="part")
        assert scene["name"] == "part"
        assert [lb["id"] for lb in scene["landblocks"]] == ["AAB5", "A9B4"]
        assert len(scene["setups"]) == 5
        only_terrain = dats.scene_dict([0xAAB5])
        assert "setups" not in only_terrain and "gfx_objs" not in only_terrain


def test_missing_landblock_is_a_keyerror_naming_it() -> None:
    with DatCollection(DATS / "rolling") as dats:
        with pytest.raises(DatFileMissing, match="0x1234FFFF") as info:
            dats.landblock_dict(0x1234)
    assert isinstance(info.value, KeyError) and isinstance(info.value, DatError)
    assert info.value.file_id == 0x1234FFFF


def test_directory_checks(tmp_path: Path) -> None:
    assert is_dat_directory(DATS / "house")
    assert not is_dat_directory(tmp_path)
    with pytest.raises(DatError, match="client_cell_1.dat"):
        DatCollection(tmp_path)
    with pytest.raises(DatError, match="not a directory"):
        DatCollection(tmp_path / "nowhere")


@pytest.mark.parametrize("name", ALL_SCENES)
def test_every_reference_scene_round_trips_through_written_dats(name: str, tmp_path: Path) -> None:
    """Scene -> dats in the real layout (3-level B-tree, scattered multi-block files) -> the same scene."""
    expected = load_scene_json(name)
    write_scene_dats(tmp_path / name, expected, fanout=2, seed=len(name))
    with DatCollection(tmp_path / name) as dats:
        scene = dats.scene_dict()
    diffs = differences(normalize_scene(scene), normalize_scene(expected))
    assert not diffs, "\n".join(diffs)


def test_round_trip_with_other_block_sizes(tmp_path: Path) -> None:
    """Nothing assumes 256/1024: swap the block sizes of the two files."""
    expected = load_scene_json("interior")
    write_scene_dats(tmp_path, expected, fanout=3, cell_block_size=1024, portal_block_size=256)
    with DatCollection(tmp_path) as dats:
        assert dats.cell.header.block_size == 1024 and dats.portal.header.block_size == 256
        scene = dats.scene_dict(name="interior")
    diffs = differences(normalize_scene(scene), normalize_scene(expected))
    assert not diffs, "\n".join(diffs)
