"""The dat container: header, B-tree directory and block chains, on files the test writer builds."""

from __future__ import annotations

import random
import struct
from pathlib import Path

import pytest

from engine.formats.dat import DatError, DatFile, DatFileMissing
from engine.formats.dat.container import HEADER_OFFSET, NODE_SIZE
from support.datwriter import DATA_SET_CELL, DATA_SET_PORTAL, build_tree, write_dat
from support.shared_data import DATS


def _payload(file_id: int, size: int) -> bytes:
    """Distinct, position-dependent bytes, so a mis-stitched chain cannot go unnoticed."""
    rng = random.Random(file_id)
    return bytes(rng.randrange(256) for _ in range(size))


def _files(count: int, block_size: int) -> dict[int, bytes]:
    payload = block_size - 4
    sizes = [0, 1, 3, payload - 1, payload, payload + 1, 2 * payload, 5 * payload + 7, 3000]
    ids = [0x01000001 + 7 * i for i in range(count)]
    return {fid: _payload(fid, sizes[i % len(sizes)]) for i, fid in enumerate(ids)}


@pytest.mark.parametrize("block_size,data_set", [(256, DATA_SET_CELL), (1024, DATA_SET_PORTAL)])
@pytest.mark.parametrize("fanout", [2, 3, 61])
def test_read_back_every_file(tmp_path: Path, block_size: int, data_set: int, fanout: int) -> None:
    files = _files(200, block_size)
    layout = write_dat(tmp_path / "t.dat", files, block_size=block_size, data_set=data_set, fanout=fanout)
    if fanout < 61:
        assert layout.depth >= 4  # several levels of inner nodes
    assert any(len(b) > 3 for b in layout.file_blocks.values())  # files spanning several blocks
    with DatFile(layout.path) as dat:
        assert dat.header.block_size == block_size
        assert dat.header.data_set == data_set
        assert dat.header.btree_root == layout.root
        assert list(dat.iter_ids()) == sorted(files)
        for fid, data in files.items():
            assert fid in dat
            assert dat.read(fid) == data
            entry = dat.entry(fid)
            assert (entry.file_id, entry.size, entry.offset) == (fid, len(data), layout.file_blocks[fid][0])
            assert entry.version == 2 and entry.flags == 0
        for absent in (0, 0x01000000, 0x01000002, max(files) + 1, 0xFFFFFFFF):
            assert absent not in dat
            assert dat.find(absent) is None


def test_header_fields(tmp_path: Path) -> None:
    layout = write_dat(tmp_path / "h.dat", {0x0D000001: b"abc"}, block_size=256, data_set=DATA_SET_CELL,
                       subset=1, free_blocks=3)  # fmt: skip
    with DatFile(layout.path) as dat:
        h = dat.header
        assert (h.magic, h.block_size, h.data_set, h.data_subset) == (0x5442, 256, 2, 1)
        assert h.file_size == layout.path.stat().st_size
        assert (h.free_head, h.free_tail, h.free_count) == (layout.free_blocks[0], layout.free_blocks[-1], 3)
        assert (h.engine_pack_version, h.version_minor, h.use_lru) == (22, 1, False)


def test_header_of_the_shared_dats() -> None:
    """The independent writer's files: cell dats use 256-byte blocks, portal dats 1024."""
    for scene in ("house", "objects", "rolling"):
        with DatFile(DATS / scene / "client_cell_1.dat") as cell:
            assert (cell.header.block_size, cell.header.data_set) == (256, 2)
            assert all(fid & 0xFFFF in (0xFFFF, 0xFFFE) or fid >> 16 == 0xFFFF or fid & 0xFFFF >= 0x100
                       for fid in cell.iter_ids())  # fmt: skip
        with DatFile(DATS / scene / "client_portal.dat") as portal:
            assert (portal.header.block_size, portal.header.data_set) == (1024, 1)
            assert 0x13000000 in portal


def test_missing_id_raises_keyerror_naming_it(tmp_path: Path) -> None:
    layout = write_dat(tmp_path / "m.dat", _files(10, 256), block_size=256, data_set=DATA_SET_CELL, fanout=2)
    with DatFile(layout.path) as dat:
        with pytest.raises(DatFileMissing) as info:
            dat.read(0x0BADF00D)
    err = info.value
    assert isinstance(err, KeyError) and isinstance(err, DatError) and isinstance(err, ValueError)
    assert "0x0BADF00D" in str(err) and str(layout.path) in str(err)
    assert err.file_id == 0x0BADF00D


def test_close_and_context_manager(tmp_path: Path) -> None:
    layout = write_dat(tmp_path / "c.dat", {1: b"x" * 600}, block_size=256, data_set=DATA_SET_CELL)
    dat = DatFile(layout.path)
    assert not dat.closed and dat.read(1) == b"x" * 600
    dat.close()
    assert dat.closed
    with pytest.raises(DatError, match="closed"):
        dat.read(1)
    dat.close()  # closing twice is harmless
    with DatFile(layout.path) as dat2:
        assert dat2.read(1) == b"x" * 600
    assert dat2.closed


def test_lookup_reads_only_one_path_of_nodes(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A lookup is a root-to-leaf descent, not a scan of the directory."""
    files = _files(300, 256)
    layout = write_dat(tmp_path / "d.dat", files, block_size=256, data_set=DATA_SET_CELL, fanout=3)
    with DatFile(layout.path) as dat:
        parsed: list[int] = []
        original = dat._parse_node

        def counting(offset: int, file_id: int | None):  # type: ignore[no-untyped-def]
            parsed.append(offset)
            return original(offset, file_id)

        monkeypatch.setattr(dat, "_parse_node", counting)
        target = sorted(files)[123]
        assert dat.read(target) == files[target]
        assert 1 <= len(parsed) <= layout.depth
        assert len(layout.node_blocks) > 10 * layout.depth


def test_build_tree_shapes() -> None:
    ids = list(range(1, 50))
    tree = build_tree(ids, 3)
    flat: list[int] = []

    def inorder(node) -> None:  # type: ignore[no-untyped-def]
        for i, fid in enumerate(node.ids):
            if node.children:
                inorder(node.children[i])
            flat.append(fid)
        if node.children:
            inorder(node.children[-1])

    inorder(tree)
    assert flat == ids
    assert all(len(n.ids) <= 3 for n in tree.walk())
    assert tree.depth() >= 3


def test_directory_node_layout_by_hand(tmp_path: Path) -> None:
    """Cross-check the writer against the layout by hand: entry count after 62 branches."""
    layout = write_dat(tmp_path / "n.dat", {5: b"hello"}, block_size=1024, data_set=DATA_SET_PORTAL)
    raw = layout.path.read_bytes()
    root = struct.unpack_from("<I", raw, HEADER_OFFSET + 8 * 4)[0]
    assert root == layout.root
    node = raw[root + 4 : root + 4 + NODE_SIZE]
    assert struct.unpack_from("<I", node, 62 * 4)[0] == 1
    flags, version, fid, offset, size = struct.unpack_from("<HHIII", node, 62 * 4 + 4)
    assert (flags, version, fid, size) == (0, 2, 5, 5)
    assert raw[offset + 4 : offset + 9] == b"hello"
