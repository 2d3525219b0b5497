"""Test-only writer of dat containers in the client's on-disk layout.

Follows the published layout independently of the reader: a 0x140-byte
preamble (version string, transactions), the header at 0x140 (magic 0x5442,
block size, file size, data set, subset, free list, B-tree root, LRU fields,
master map, pack versions, 16-byte major version, minor version), then
blocks whose first 4 bytes link to the next block of the same chain. Every
file and every B-tree node (62 branch offsets, entry count, 61 entry slots of
24 bytes) is written as such a chain.

The B-tree fan-out can be lowered so a handful of files make a tree of
several levels, and block order is shuffled so chains jump around the file
(backwards too), as they do in real dats.
"""

from __future__ import annotations

import random
import struct
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

HEADER_OFFSET = 0x140
HEADER_END = HEADER_OFFSET + 80
MAGIC = 0x5442
MAX_BRANCHES = 62
MAX_ENTRIES = 61
ENTRY_SIZE = 24
NODE_SIZE = MAX_BRANCHES * 4 + 4 + MAX_ENTRIES * ENTRY_SIZE
DATA_SET_PORTAL = 1
DATA_SET_CELL = 2
ENTRY_VERSION = 2


class Packer:
    """Builds a byte string field by field (little-endian), for records and tests."""

    def __init__(self) -> None:
        self.buf = bytearray()

    def _put(self, fmt: str, *values: object) -> Packer:
        self.buf += struct.pack("<" + fmt, *values)
        return self

    def u8(self, v: int) -> Packer:
        return self._put("B", v)

    def u16(self, v: int) -> Packer:
        return self._put("H", v)

    def i16(self, v: int) -> Packer:
        return self._put("h", v)

    def u32(self, v: int) -> Packer:
        return self._put("I", v)

    def i32(self, v: int) -> Packer:
        return self._put("i", v)

    def f32(self, v: float) -> Packer:
        return self._put("f", v)

    def f64(self, v: float) -> Packer:
        return self._put("d", v)

    def vec3(self, v: list[float] | tuple[float, float, float]) -> Packer:
        return self._put("3f", *v)

    def quat(self, q: list[float] | tuple[float, float, float, float]) -> Packer:
        """A quaternion as the dat stores it: w, x, y, z."""
        return self._put("4f", *q)

    def frame(self, origin: list[float], orientation: list[float]) -> Packer:
        return self.vec3(origin).quat(orientation)

    def sphere(self, origin: list[float], radius: float) -> Packer:
        return self.vec3(origin).f32(radius)

    def plane(self, normal: list[float], d: float) -> Packer:
        return self.vec3(normal).f32(d)

    def tag(self, name: str) -> Packer:
        """A four-character BSP tag: stored as a little-endian uint, so "BPnN" is written b"NnPB"."""
        assert len(name) == 4
        self.buf += name.encode("ascii")[::-1]
        return self

    def compressed_u32(self, v: int) -> Packer:
        """The client's packed count: 1 byte below 0x80, 2 bytes below 0x4000, else 4."""
        if v < 0x80:
            return self.u8(v)
        if v < 0x4000:
            return self.u8(0x80 | (v >> 8)).u8(v & 0xFF)
        return self.u8(0xC0 | (v >> 24)).u8((v >> 16) & 0xFF).u16(v & 0xFFFF)

    def raw(self, data: bytes) -> Packer:
        self.buf += data
        return self

    def align4(self) -> Packer:
        self.buf += b"\0" * ((-len(self.buf)) % 4)
        return self

    def getvalue(self) -> bytes:
        return bytes(self.buf)

    def __len__(self) -> int:
        return len(self.buf)


@dataclass
class TreeNode:
    """One B-tree node before it is written: its file ids and children."""

    ids: list[int]
    children: list[TreeNode] = field(default_factory=list)

    def depth(self) -> int:
        return 1 + (self.children[0].depth() if self.children else 0)

    def walk(self) -> list[TreeNode]:
        out = [self]
        for c in self.children:
            out.extend(c.walk())
        return out


def build_tree(ids: list[int], fanout: int) -> TreeNode:
    """A valid B-tree over sorted `ids` with at most `fanout` entries per node (2..61)."""
    assert 2 <= fanout <= MAX_ENTRIES
    n = len(ids)
    if n <= fanout:
        return TreeNode(list(ids))
    k = min(fanout, (n - 1) // 2)  # separators, leaving every child at least one id
    rest = n - k
    sizes = [rest // (k + 1) + (1 if i < rest % (k + 1) else 0) for i in range(k + 1)]
    node = TreeNode([])
    pos = 0
    for i, size in enumerate(sizes):
        node.children.append(build_tree(ids[pos : pos + size], fanout))
        pos += size
        if i < k:
            node.ids.append(ids[pos])
            pos += 1
    return node


@dataclass
class DatLayout:
    """Where the writer put things, so tests can damage them precisely."""

    path: Path
    block_size: int
    root: int
    depth: int
    file_blocks: dict[int, list[int]]
    node_blocks: list[list[int]]
    free_blocks: list[int]
    sizes: dict[int, int]


def write_dat(
    path: str | Path,
    files: Mapping[int, bytes],
    *,
    block_size: int,
    data_set: int,
    subset: int = 0,
    fanout: int = MAX_ENTRIES,
    seed: int = 1,
    free_blocks: int = 2,
    iteration: int = 1,
    date: int = 0x588FD380,
) -> DatLayout:
    """Write `files` (id -> bytes) as one dat file; returns where everything went."""
    path = Path(path)
    payload = block_size - 4
    ids = sorted(files)
    tree = build_tree(ids, fanout)
    nodes = tree.walk()

    def blocks_for(size: int) -> int:
        return max(1, -(-size // payload))

    counts = [blocks_for(len(files[i])) for i in ids] + [blocks_for(NODE_SIZE)] * len(nodes) + [1] * free_blocks
    first = -(-HEADER_END // block_size) * block_size
    offsets = [first + i * block_size for i in range(sum(counts))]
    random.Random(seed).shuffle(offsets)
    it = iter(offsets)
    file_blocks = {i: [next(it) for _ in range(blocks_for(len(files[i])))] for i in ids}
    node_blocks = [[next(it) for _ in range(blocks_for(NODE_SIZE))] for _ in nodes]
    free = [next(it) for _ in range(free_blocks)]
    total = first + len(offsets) * block_size
    buf = bytearray(total)

    def write_chain(blocks: list[int], data: bytes) -> None:
        for n, b in enumerate(blocks):
            struct.pack_into("<I", buf, b, blocks[n + 1] if n + 1 < len(blocks) else 0)
            chunk = data[n * payload : (n + 1) * payload]
            buf[b + 4 : b + 4 + len(chunk)] = chunk

    for i in ids:
        write_chain(file_blocks[i], files[i])
    node_offset = {id(node): blocks[0] for node, blocks in zip(nodes, node_blocks)}
    for node, blocks in zip(nodes, node_blocks):
        p = Packer()
        branches = [node_offset[id(c)] for c in node.children]
        for slot in range(MAX_BRANCHES):
            p.u32(branches[slot] if slot < len(branches) else 0)
        p.u32(len(node.ids))
        for fid in node.ids:
            p.u16(0).u16(ENTRY_VERSION).u32(fid).u32(file_blocks[fid][0]).u32(len(files[fid])).u32(date).u32(iteration)
        p.raw(b"\0" * (ENTRY_SIZE * (MAX_ENTRIES - len(node.ids))))
        assert len(p) == NODE_SIZE
        write_chain(blocks, p.getvalue())
    write_chain(free, b"")  # the free list is a chain of empty blocks
    root = node_offset[id(tree)]
    header = Packer()
    header.u32(MAGIC).u32(block_size).u32(total).u32(data_set).u32(subset)
    header.u32(free[0] if free else 0).u32(free[-1] if free else 0).u32(len(free)).u32(root)
    header.u32(0).u32(0).u32(0).u32(0)  # new LRU, old LRU, use LRU, master map
    header.u32(22).u32(0).raw(b"\0" * 16).u32(1)  # engine/game pack versions, major, minor
    assert HEADER_OFFSET + len(header) == HEADER_END
    buf[HEADER_OFFSET:HEADER_END] = header.getvalue()
    path.write_bytes(bytes(buf))
    return DatLayout(path, block_size, root, tree.depth(), file_blocks, node_blocks, free,
                     {i: len(files[i]) for i in ids})  # fmt: skip
