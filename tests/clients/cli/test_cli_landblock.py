"""`acphys inspect` and `acphys load-region` on the shared dats, called through argparse."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import pytest

import engine
from clients.cli.landblock import add_landblock_commands, parse_landblock, region_ids
from support.dat_records import scene_to_dat_files
from support.datwriter import DATA_SET_CELL, DATA_SET_PORTAL, write_dat
from support.scene_compare import differences, normalize_scene
from support.shared_data import DATS, load_scene_json, require_shared

require_shared()  # every test here reads the shared dats


def _run(*argv: str) -> int:
    parser = argparse.ArgumentParser(prog="acphys")
    sub = parser.add_subparsers(dest="command", required=True)
    add_landblock_commands(sub)
    args = parser.parse_args(list(argv))
    return int(args.func(args))


def _z_range(scene: dict[str, Any], lb_id: str) -> tuple[float, float]:
    lb = next(lb for lb in scene["landblocks"] if lb["id"] == lb_id)
    zs = [scene["height_table"][h] for h in lb["heights"]]
    return min(zs), max(zs)


def test_parse_landblock() -> None:
    assert parse_landblock("A9B4") == parse_landblock("0xa9b4") == parse_landblock("A9B40001") == 0xA9B4
    for bad in ("xyz", "1A9B40001", "-1"):
        with pytest.raises(argparse.ArgumentTypeError):
            parse_landblock(bad)


def test_inspect_house_counts(capsys: pytest.CaptureFixture[str]) -> None:
    scene = load_scene_json("house")
    lb = next(lb for lb in scene["landblocks"] if lb["id"] == "A9B4")
    assert _run("inspect", str(DATS / "house"), "A9B4") == 0
    out = capsys.readouterr().out
    lo, hi = _z_range(scene, "A9B4")
    assert f"z {lo:.2f} .. {hi:.2f} m" in out
    n_env = len(lb["env_cells"])
    assert f"cells      {64 + n_env}: 64 outdoor + {n_env} EnvCells" in out
    assert f"EnvCells   {n_env}" in out
    assert f"buildings  {len(lb['buildings'])}" in out
    env_objects = sum(len(c.get("static_objects", [])) for c in lb["env_cells"])
    assert f"objects    {env_objects}: 0 on the landblock + {env_objects} in EnvCells" in out


def test_inspect_objects_and_plain_terrain(capsys: pytest.CaptureFixture[str]) -> None:
    scene = load_scene_json("objects")
    lb = next(lb for lb in scene["landblocks"] if lb["id"] == "A9B4")
    assert _run("inspect", str(DATS / "objects"), "A9B40001") == 0
    out = capsys.readouterr().out
    assert f"{len(lb['objects'])} on the landblock" in out
    assert "buildings  0" in out

    rolling = load_scene_json("rolling")
    assert _run("inspect", str(DATS / "rolling"), "A8B3") == 0
    out = capsys.readouterr().out
    lo, hi = _z_range(rolling, "A8B3")
    assert f"z {lo:.2f} .. {hi:.2f} m" in out
    assert "cells      64: 64 outdoor + 0 EnvCells" in out


@pytest.mark.parametrize("name", ["house", "objects", "rolling"])
def test_export_is_the_scene_of_that_landblock(name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out_file = tmp_path / f"{name}.json"
    assert _run("inspect", str(DATS / name), "A9B4", "--export", str(out_file), "--name", name) == 0
    assert str(out_file) in capsys.readouterr().out
    exported = json.loads(out_file.read_text(encoding="utf-8"))
    expected = load_scene_json(name)
    expected["landblocks"] = [lb for lb in expected["landblocks"] if lb["id"] == "A9B4"]
    diffs = differences(normalize_scene(exported), normalize_scene(expected))
    assert not diffs, "\n".join(diffs)


def test_export_loads_as_a_scene(tmp_path: Path) -> None:
    out_file = tmp_path / "a8b3.json"
    assert _run("inspect", str(DATS / "rolling"), "A8B3", "--export", str(out_file)) == 0
    world = engine.load_scene(out_file)
    assert world.loaded_landblocks() == [0xA8B3]
    assert world.scene["name"] == "rolling-A8B3"  # type: ignore[attr-defined]


def test_inspect_missing_landblock(capsys: pytest.CaptureFixture[str]) -> None:
    assert _run("inspect", str(DATS / "rolling"), "0101") == 1
    assert "0101 is not in the dats" in capsys.readouterr().err


def test_inspect_not_a_dat_directory(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert _run("inspect", str(tmp_path), "A9B4") == 1
    assert "client_cell_1.dat" in capsys.readouterr().err


def test_region_ids() -> None:
    assert region_ids(0xAAB5, 0xA8B3) == region_ids(0xA8B3, 0xAAB5)
    assert region_ids(0xA8B3, 0xA9B4) == [0xA8B3, 0xA8B4, 0xA9B3, 0xA9B4]


def test_load_region_loads_the_rectangle(capsys: pytest.CaptureFixture[str]) -> None:
    assert _run("load-region", str(DATS / "rolling"), "A7B2", "AAB5") == 0
    captured = capsys.readouterr()
    assert "16 landblocks, 9 loaded, 7 not in the dats, 0 failed" in captured.out
    assert "9 held of 16; loads 9, unloads 0" in captured.out
    assert "loading landblocks" in captured.err  # the progress bar


def test_load_region_with_a_small_cache(capsys: pytest.CaptureFixture[str]) -> None:
    assert _run("load-region", str(DATS / "rolling"), "A8B3", "AAB5", "--cache-size", "2", "--no-progress") == 0
    captured = capsys.readouterr()
    assert "9 landblocks, 9 loaded, 0 not in the dats" in captured.out
    assert "2 held of 2; loads 9, unloads 7" in captured.out
    assert "loading" not in captured.err


def test_load_region_reports_a_corrupt_landblock(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene = load_scene_json("rolling")
    scene["landblocks"] = scene["landblocks"][:2]
    cell, portal = scene_to_dat_files(scene)
    bad_id = (int(scene["landblocks"][1]["id"], 16) << 16) | 0xFFFF
    cell[bad_id] = cell[bad_id][:30]
    write_dat(tmp_path / "client_cell_1.dat", cell, block_size=256, data_set=DATA_SET_CELL, subset=1)
    write_dat(tmp_path / "client_portal.dat", portal, block_size=1024, data_set=DATA_SET_PORTAL)
    assert _run("load-region", str(tmp_path), "A8B3", "A8B4", "--no-progress") == 1
    out = capsys.readouterr().out
    assert "1 loaded, 0 not in the dats, 1 failed" in out
    assert f"0x{bad_id:08X}" in out
