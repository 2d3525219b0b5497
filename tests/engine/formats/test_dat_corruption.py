"""Damaged dat files: each fault raises DatError naming the path (and the file id), quickly.

Files are written by the test writer, then damaged at known places: block
chains that loop or end early, offsets past the end, truncated files and
records, bad headers, a B-tree that points back at itself. Every check runs
under a time limit, so a reader that hangs fails instead of stalling the run.
"""

from __future__ import annotations

import contextlib
import random
import signal
import struct
from collections.abc import Iterator
from pathlib import Path

import pytest

from engine.formats.dat import (
    DatCollection,
    DatError,
    DatFile,
    parse_cell_landblock,
    parse_env_cell,
    parse_environment,
    parse_gfx_obj,
    parse_landblock_info,
    parse_region,
    parse_setup,
)
from engine.formats.dat.container import HEADER_OFFSET
from support.dat_records import REGION_ID, scene_to_dat_files, write_scene_dats
from support.datwriter import DATA_SET_CELL, DATA_SET_PORTAL, DatLayout, write_dat
from support.shared_data import load_scene_json

TIME_LIMIT = 5.0
BIG_ID = 0x01000010


@contextlib.contextmanager
def within(seconds: float = TIME_LIMIT) -> Iterator[None]:
    """Fail (instead of hanging) if the block takes longer than `seconds`."""

    def expired(signum: int, frame: object) -> None:
        raise TimeoutError(f"dat reader took longer than {seconds} s")

    previous = signal.signal(signal.SIGALRM, expired)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def _write(tmp_path: Path, block_size: int = 256, seed: int = 3) -> tuple[DatLayout, dict[int, bytes]]:
    files = {0x01000001 + i: bytes([i]) * (37 * i + 5) for i in range(12)}
    files[BIG_ID] = bytes(range(256)) * 8  # 2048 bytes: 9 blocks of 256, 3 of 1024
    layout = write_dat(tmp_path / "bad.dat", files, block_size=block_size, data_set=DATA_SET_CELL, seed=seed)
    return layout, files


def _poke_u32(path: Path, offset: int, value: int) -> None:
    with open(path, "r+b") as f:
        f.seek(offset)
        f.write(struct.pack("<I", value))


def _patch_entry(layout: DatLayout, file_id: int, *, offset: int | None = None, size: int | None = None) -> None:
    """Rewrite one directory entry in place (the node's first 1020 bytes hold it at block size 1024)."""
    raw = bytearray(layout.path.read_bytes())
    old = struct.pack("<III", file_id, layout.file_blocks[file_id][0], layout.sizes[file_id])
    at = raw.find(old)
    assert at > 0 and raw.find(old, at + 1) == -1
    new_offset = layout.file_blocks[file_id][0] if offset is None else offset
    new_size = layout.sizes[file_id] if size is None else size
    raw[at : at + 12] = struct.pack("<III", file_id, new_offset, new_size)
    layout.path.write_bytes(bytes(raw))


def _assert_names(err: DatError, path: Path, file_id: int | None) -> None:
    assert str(path) in str(err)
    if file_id is not None:
        assert f"0x{file_id:08X}" in str(err)
        assert err.file_id == file_id


# -- block chains --------------------------------------------------------------------


@pytest.mark.parametrize("loop_to", [0, 2])
def test_looping_chain(tmp_path: Path, loop_to: int) -> None:
    layout, _ = _write(tmp_path)
    blocks = layout.file_blocks[BIG_ID]
    _poke_u32(layout.path, blocks[2], blocks[loop_to])  # block 2 links back to block 0, or to itself
    with within(), DatFile(layout.path) as dat, pytest.raises(DatError, match="loops") as info:
        dat.read(BIG_ID)
    _assert_names(info.value, layout.path, BIG_ID)


def test_next_block_past_end_of_file(tmp_path: Path) -> None:
    layout, _ = _write(tmp_path)
    _poke_u32(layout.path, layout.file_blocks[BIG_ID][3], 0x7FFF0000)
    with within(), DatFile(layout.path) as dat, pytest.raises(DatError, match="past the end") as info:
        dat.read(BIG_ID)
    _assert_names(info.value, layout.path, BIG_ID)


def test_entry_offset_past_end_of_file(tmp_path: Path) -> None:
    layout, files = _write(tmp_path, block_size=1024)
    _patch_entry(layout, 0x01000003, offset=layout.path.stat().st_size + 4096)
    with within(), DatFile(layout.path) as dat:
        with pytest.raises(DatError, match="past the end") as info:
            dat.read(0x01000003)
        assert dat.read(0x01000004) == files[0x01000004]  # the rest of the dat stays readable
    _assert_names(info.value, layout.path, 0x01000003)


def test_chain_that_ends_early(tmp_path: Path) -> None:
    layout, _ = _write(tmp_path)
    _poke_u32(layout.path, layout.file_blocks[BIG_ID][4], 0)
    with within(), DatFile(layout.path) as dat, pytest.raises(DatError, match="truncated chain") as info:
        dat.read(BIG_ID)
    _assert_names(info.value, layout.path, BIG_ID)


def test_absurd_entry_size_fails_before_allocating(tmp_path: Path) -> None:
    layout, _ = _write(tmp_path, block_size=1024)
    _patch_entry(layout, 0x01000002, size=0xFFFFFFF0)
    with within(), DatFile(layout.path) as dat, pytest.raises(DatError, match="more than the whole file") as info:
        dat.read(0x01000002)
    _assert_names(info.value, layout.path, 0x01000002)


def test_truncated_file(tmp_path: Path) -> None:
    """Cut the file after the directory: files stored beyond the cut fail, each naming itself."""
    for seed in range(50):
        layout, files = _write(tmp_path, seed=seed)
        cut = max(b for blocks in layout.node_blocks for b in blocks) + layout.block_size
        lost = [fid for fid, blocks in layout.file_blocks.items() if layout.sizes[fid] and max(blocks) >= cut]
        if lost and len(lost) < len(files):
            break
    with open(layout.path, "r+b") as f:
        f.truncate(cut)
    with within(), DatFile(layout.path) as dat:
        assert sorted(dat.iter_ids()) == sorted(files)
        for fid in files:
            if fid in lost:
                with pytest.raises(DatError, match="truncated") as info:
                    dat.read(fid)
                _assert_names(info.value, layout.path, fid)
            else:
                assert dat.read(fid) == files[fid]


# -- the directory --------------------------------------------------------------------


def test_btree_that_points_back_at_itself(tmp_path: Path) -> None:
    files = {0x01000000 + i: b"x" * i for i in range(1, 40)}
    layout = write_dat(tmp_path / "loop.dat", files, block_size=1024, data_set=DATA_SET_PORTAL, fanout=3)
    _poke_u32(layout.path, layout.root + 4, layout.root)  # root's first branch -> root
    with within(), DatFile(layout.path) as dat:
        with pytest.raises(DatError, match="loops back") as info:
            dat.read(0x01000001)
        _assert_names(info.value, layout.path, 0x01000001)
        with pytest.raises(DatError, match="twice"):
            list(dat.iter_ids())


def test_node_with_too_many_entries(tmp_path: Path) -> None:
    layout, _ = _write(tmp_path, block_size=1024)
    _poke_u32(layout.path, layout.root + 4 + 62 * 4, 5000)
    with within(), DatFile(layout.path) as dat, pytest.raises(DatError, match="5000 entries") as info:
        dat.read(0x01000001)
    _assert_names(info.value, layout.path, 0x01000001)


# -- headers ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "field_index,value,message",
    [(0, 0x1234, "magic"), (1, 0, "block size"), (1, 1023, "block size"), (8, 0x7FFFFF00, "root"), (8, 0, "root")],
)
def test_bad_header(tmp_path: Path, field_index: int, value: int, message: str) -> None:
    layout, _ = _write(tmp_path)
    _poke_u32(layout.path, HEADER_OFFSET + 4 * field_index, value)
    with within(), pytest.raises(DatError, match=message) as info:
        DatFile(layout.path)
    assert "bad header" in str(info.value)
    _assert_names(info.value, layout.path, None)


@pytest.mark.parametrize("length", [0, 100, HEADER_OFFSET + 10])
def test_file_too_short_for_a_header(tmp_path: Path, length: int) -> None:
    path = tmp_path / "short.dat"
    path.write_bytes(b"\0" * length)
    with within(), pytest.raises(DatError, match="bad header") as info:
        DatFile(path)
    _assert_names(info.value, path, None)


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(DatError, match="cannot open"):
        DatFile(tmp_path / "absent.dat")


# -- records ---------------------------------------------------------------------------


def test_truncated_record_through_the_collection(tmp_path: Path) -> None:
    """A directory entry shorter than its record: the parser names the record's file id."""
    scene = load_scene_json("house")
    write_scene_dats(tmp_path, scene)
    cell_files, _ = scene_to_dat_files(scene)
    # Rewrite the cell dat with 1024-byte blocks so the entry to damage sits in one block.
    layout = write_dat(tmp_path / "client_cell_1.dat", cell_files, block_size=1024, data_set=DATA_SET_CELL)
    _patch_entry(layout, 0xA9B40100, size=40)
    with within(), DatCollection(tmp_path) as dats:
        dats.landblock_dict(0xA8B3)  # untouched landblocks still load
        with pytest.raises(DatError, match="EnvCell") as info:
            dats.landblock_dict(0xA9B4)
    _assert_names(info.value, layout.path, 0xA9B40100)


PARSERS = {
    "CellLandblock": parse_cell_landblock,
    "LandblockInfo": parse_landblock_info,
    "EnvCell": parse_env_cell,
    "Environment": parse_environment,
    "GfxObj": parse_gfx_obj,
    "Setup": parse_setup,
    "Region": parse_region,
}


def _sample_records() -> list[tuple[str, int, bytes]]:
    out = []
    for name in ("interior", "dungeon", "objects"):
        cell, portal = scene_to_dat_files(load_scene_json(name))
        # GfxObj drawing data is never read, so those records are cut in their physics part only.
        _, plain = scene_to_dat_files(load_scene_json(name), drawing=False)
        portal.update({fid: data for fid, data in plain.items() if fid >> 24 == 0x01})
        for fid, data in {**cell, **portal}.items():
            low, kind = fid & 0xFFFF, fid >> 24
            if fid >> 16 == 0xFFFF:
                continue
            if fid == REGION_ID:
                out.append(("Region", fid, data))
            elif kind in (0x01, 0x02, 0x0D) and fid < 0x0E000000:
                out.append(({0x01: "GfxObj", 0x02: "Setup", 0x0D: "Environment"}[kind], fid, data))
            elif low == 0xFFFF:
                out.append(("CellLandblock", fid, data))
            elif low == 0xFFFE:
                out.append(("LandblockInfo", fid, data))
            else:
                out.append(("EnvCell", fid, data))
    return out


def test_every_truncation_of_every_record_raises_dat_error() -> None:
    """Cut each record anywhere before its last field: DatError naming the id, nothing else."""
    with within(60):
        for kind, fid, data in _sample_records():
            parser = PARSERS[kind]
            parser(data, path="x.dat", file_id=fid)  # whole: fine
            # Region stops reading after its height table; other records are read to the end
            # (the last few bytes may be alignment padding, which may be absent).
            end = 8 + 1024 + 40 if kind == "Region" else len(data) - 3
            cuts = range(end) if end < 400 else sorted(set(random.Random(fid).sample(range(end), 300)) | {end - 1})
            for cut in cuts:
                with pytest.raises(DatError) as info:
                    parser(data[:cut], path="x.dat", file_id=fid)
                assert f"0x{fid:08X}" in str(info.value) and "x.dat" in str(info.value), (kind, cut)


def test_random_damage_never_escapes_as_another_exception() -> None:
    """Flip bytes at random: the parsers either succeed or raise DatError, and always finish."""
    rng = random.Random(7)
    with within(60):
        for kind, fid, data in _sample_records():
            for _ in range(40):
                damaged = bytearray(data)
                for _ in range(rng.randint(1, 4)):
                    damaged[rng.randrange(len(damaged))] = rng.randrange(256)
                try:
                    PARSERS[kind](bytes(damaged), path="x.dat", file_id=fid)
                except DatError as err:
                    assert f"0x{fid:08X}" in str(err)
