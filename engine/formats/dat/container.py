"""The dat container: header, B-tree directory and chained blocks.

Layout (the retail client's DiskFileInfo / BTree / block chain):

* At byte 0x140 the header: magic 0x5442 ("BT"), block size, file size, data
  set (1 portal, 2 cell), subset, free-list head/tail/count, the offset of the
  B-tree root node, LRU fields, master map id, engine/game pack versions, a
  16-byte major version and a minor version.
* Every stored thing (directory nodes included) is a chain of blocks: the
  first 4 bytes of a block are the offset of the next block (0 ends the
  chain), the other `block_size - 4` bytes are payload.
* A directory node is 62 branch offsets, an entry count and 61 entry slots of
  24 bytes (flags and version as two ushorts, file id, offset of the file's
  first block, size, date, iteration), sorted by file id. A node whose first
  branch is 0 is a leaf; otherwise branch i leads to the ids between entries
  i-1 and i.

Reading a file costs one root-to-leaf descent plus its own blocks: the file is
memory-mapped and nothing is scanned.
"""

from __future__ import annotations

import bisect
import mmap
import os
import struct
import threading
from collections import OrderedDict
from collections.abc import Iterator
from dataclasses import dataclass
from types import TracebackType
from typing import Self

from .errors import DatError, DatFileMissing, format_file_id

__all__ = ["DatFile", "DatHeader", "DirectoryEntry", "HEADER_OFFSET", "DAT_MAGIC", "NODE_SIZE"]

HEADER_OFFSET = 0x140
DAT_MAGIC = 0x5442
MAX_BRANCHES = 62
MAX_ENTRIES = 61
ENTRY_SIZE = 24
NODE_SIZE = MAX_BRANCHES * 4 + 4 + MAX_ENTRIES * ENTRY_SIZE  # 1716 bytes
# Real trees are 3-4 levels deep; anything deeper than this is a cycle or garbage.
MAX_TREE_DEPTH = 32
_NODE_CACHE_SIZE = 2048
ENTRY_FLAG_COMPRESSED = 0x1

_HEADER = struct.Struct("<15I16sI")
_BRANCHES = struct.Struct(f"<{MAX_BRANCHES}I")
_ENTRY = struct.Struct("<HHIIIII")
_U32 = struct.Struct("<I")


class ClosesOnExit:
    """A `with` block closes the object (its `close()`) on the way out."""

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self.close()

    def close(self) -> None:
        raise NotImplementedError


@dataclass(frozen=True, slots=True)
class DatHeader:
    """The dat header at 0x140 (the client's DiskFileInfo)."""

    magic: int
    block_size: int
    file_size: int
    data_set: int
    data_subset: int
    free_head: int
    free_tail: int
    free_count: int
    btree_root: int
    new_lru: int
    old_lru: int
    use_lru: bool
    master_map_id: int
    engine_pack_version: int
    game_pack_version: int
    version_major: bytes
    version_minor: int


@dataclass(frozen=True, slots=True)
class DirectoryEntry:
    """One B-tree entry: where a file's first block is and how many bytes it has."""

    flags: int
    version: int
    file_id: int
    offset: int
    size: int
    date: int
    iteration: int


@dataclass(frozen=True, slots=True)
class _Node:
    ids: list[int]
    entries: list[DirectoryEntry]
    branches: list[int]  # empty for a leaf, else len(entries) + 1 offsets


class DatFile(ClosesOnExit):
    """One dat file (`client_cell_1.dat`, `client_portal.dat`, ...), opened read-only.

    `read(file_id)` returns a file's bytes; `file_id in dat` tests presence;
    `iter_ids()` walks the whole directory in id order. Errors in the file
    raise `DatError` naming the path (and the file id where there is one); a
    missing id raises `DatFileMissing` (also a KeyError). Safe to share
    between threads for reading.
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = os.fspath(path)
        self._lock = threading.Lock()
        self._nodes: OrderedDict[int, _Node] = OrderedDict()
        try:
            self._fh = open(self.path, "rb")
        except OSError as exc:
            raise DatError(f"cannot open dat file: {exc.strerror or exc}", path=self.path) from exc
        try:
            self._length = os.fstat(self._fh.fileno()).st_size
            if self._length < HEADER_OFFSET + _HEADER.size:
                raise DatError(
                    f"bad header: file is {self._length} bytes, too short for a dat header "
                    f"(needs {HEADER_OFFSET + _HEADER.size})",
                    path=self.path,
                )
            self._map: mmap.mmap | None = mmap.mmap(self._fh.fileno(), 0, access=mmap.ACCESS_READ)
            self.header = self._read_header()
        except BaseException:
            self._close_handles()
            raise

    # -- header ---------------------------------------------------------------

    def _read_header(self) -> DatHeader:
        assert self._map is not None
        f = _HEADER.unpack_from(self._map, HEADER_OFFSET)
        header = DatHeader(
            magic=f[0], block_size=f[1], file_size=f[2], data_set=f[3], data_subset=f[4],
            free_head=f[5], free_tail=f[6], free_count=f[7], btree_root=f[8],
            new_lru=f[9], old_lru=f[10], use_lru=f[11] == 1, master_map_id=f[12],
            engine_pack_version=f[13], game_pack_version=f[14],
            version_major=f[15], version_minor=f[16],
        )  # fmt: skip
        if header.magic != DAT_MAGIC:
            raise DatError(
                f"bad header: magic 0x{header.magic:08X} at 0x{HEADER_OFFSET:X}, expected 0x{DAT_MAGIC:08X}",
                path=self.path,
            )
        if not 16 <= header.block_size <= 1 << 20 or header.block_size % 4:
            raise DatError(f"bad header: implausible block size {header.block_size}", path=self.path)
        root = header.btree_root
        if root == 0 or root + header.block_size > self._length:
            raise DatError(
                f"bad header: B-tree root offset 0x{root:X} is outside the file ({self._length} bytes"
                f"{self._size_note(header)})",
                path=self.path,
            )
        return header

    def _size_note(self, header: DatHeader | None = None) -> str:
        header = header or self.header
        if header.file_size > self._length:
            return f"; the header says {header.file_size}: the file is truncated"
        return ""

    # -- block chains ---------------------------------------------------------

    def _read_chain(self, offset: int, size: int, file_id: int | None, what: str) -> bytes:
        """Gather `size` payload bytes from the chain of blocks starting at `offset`."""
        if self._map is None:
            raise DatError("dat file is closed", path=self.path, file_id=file_id)
        if size == 0:
            return b""
        block_size = self.header.block_size
        payload = block_size - 4
        # Checked before allocating, so a corrupt size cannot ask for gigabytes.
        if size > (self._length // block_size + 1) * payload:
            raise DatError(
                f"{what} claims {size} bytes, more than the whole file ({self._length} bytes) can hold",
                path=self.path, file_id=file_id,
            )  # fmt: skip
        out = bytearray(size)
        seen: set[int] = set()
        filled = 0
        block = offset
        mm = self._map
        while filled < size:
            if block == 0:
                raise DatError(
                    f"{what}: block chain ends after {filled} of {size} bytes (truncated chain)",
                    path=self.path, file_id=file_id,
                )  # fmt: skip
            if block in seen:
                raise DatError(
                    f"{what}: block chain loops back to block 0x{block:X} after {filled} of {size} bytes",
                    path=self.path, file_id=file_id,
                )  # fmt: skip
            take = min(payload, size - filled)
            if block + 4 + take > self._length:
                raise DatError(
                    f"{what}: block offset 0x{block:X} is past the end of the file "
                    f"({self._length} bytes{self._size_note()})",
                    path=self.path, file_id=file_id,
                )  # fmt: skip
            seen.add(block)
            out[filled : filled + take] = mm[block + 4 : block + 4 + take]
            filled += take
            block = _U32.unpack_from(mm, block)[0]
        return bytes(out)

    # -- directory ------------------------------------------------------------

    def _node(self, offset: int, file_id: int | None) -> _Node:
        with self._lock:
            node = self._nodes.get(offset)
            if node is not None:
                self._nodes.move_to_end(offset)
                return node
        node = self._parse_node(offset, file_id)
        with self._lock:
            self._nodes[offset] = node
            if len(self._nodes) > _NODE_CACHE_SIZE:
                self._nodes.popitem(last=False)
        return node

    def _parse_node(self, offset: int, file_id: int | None) -> _Node:
        what = f"B-tree node at 0x{offset:X}"
        raw = self._read_chain(offset, NODE_SIZE, file_id, what)
        branches = list(_BRANCHES.unpack_from(raw, 0))
        count = _U32.unpack_from(raw, MAX_BRANCHES * 4)[0]
        if count > MAX_ENTRIES:
            raise DatError(f"{what} has {count} entries (at most {MAX_ENTRIES})", path=self.path, file_id=file_id)
        entries = [
            DirectoryEntry(*_ENTRY.unpack_from(raw, MAX_BRANCHES * 4 + 4 + i * ENTRY_SIZE)) for i in range(count)
        ]
        ids = [e.file_id for e in entries]
        if any(a >= b for a, b in zip(ids, ids[1:])):
            raise DatError(f"{what} has entries out of id order", path=self.path, file_id=file_id)
        if branches[0] == 0:
            return _Node(ids, entries, [])
        kids = branches[: count + 1]
        if 0 in kids:
            raise DatError(f"{what} is an inner node with a missing branch", path=self.path, file_id=file_id)
        return _Node(ids, entries, kids)

    def find(self, file_id: int) -> DirectoryEntry | None:
        """The directory entry of `file_id`, or None: one descent from the root."""
        file_id &= 0xFFFFFFFF
        offset = self.header.btree_root
        visited: set[int] = set()
        for _ in range(MAX_TREE_DEPTH):
            if offset in visited:
                raise DatError(f"B-tree loops back to node 0x{offset:X}", path=self.path, file_id=file_id)
            visited.add(offset)
            node = self._node(offset, file_id)
            i = bisect.bisect_left(node.ids, file_id)
            if i < len(node.ids) and node.ids[i] == file_id:
                return node.entries[i]
            if not node.branches:
                return None
            offset = node.branches[i]
        raise DatError(f"B-tree is deeper than {MAX_TREE_DEPTH} levels (corrupt)", path=self.path, file_id=file_id)

    def entry(self, file_id: int) -> DirectoryEntry:
        """Like `find`, but a missing id raises `DatFileMissing`."""
        found = self.find(file_id)
        if found is None:
            raise DatFileMissing("no such file in this dat", path=self.path, file_id=file_id)
        return found

    def read(self, file_id: int) -> bytes:
        """The bytes of file `file_id` (raises `DatFileMissing` if absent, `DatError` if damaged)."""
        e = self.entry(file_id)
        if e.flags & ENTRY_FLAG_COMPRESSED:
            # Retail dats never compress; later tools can, in a layout we do not read.
            raise DatError("entry is flagged compressed, which this reader does not support",
                           path=self.path, file_id=file_id)  # fmt: skip
        return self._read_chain(e.offset, e.size, e.file_id, "file data")

    def __contains__(self, file_id: object) -> bool:
        return isinstance(file_id, int) and self.find(file_id) is not None

    def iter_entries(self) -> Iterator[DirectoryEntry]:
        """Every directory entry, in id order (an in-order B-tree walk)."""
        root = self.header.btree_root
        visited = {root}
        # LIFO work list: a node with the index of its next branch/entry, or an entry to yield.
        work: list[tuple[_Node, int] | DirectoryEntry] = [(self._node(root, None), 0)]
        while work:
            item = work.pop()
            if isinstance(item, DirectoryEntry):
                yield item
                continue
            node, i = item
            if i < len(node.entries):
                work.append((node, i + 1))
                work.append(node.entries[i])
            if i < len(node.branches):
                child = node.branches[i]
                if child in visited:  # also what keeps a corrupt tree from walking forever
                    raise DatError(f"B-tree reaches node 0x{child:X} twice (corrupt)", path=self.path)
                visited.add(child)
                work.append((self._node(child, None), 0))

    def iter_ids(self) -> Iterator[int]:
        """Every file id in the dat, ascending."""
        for e in self.iter_entries():
            yield e.file_id

    # -- lifetime -------------------------------------------------------------

    def _close_handles(self) -> None:
        m, self._map = getattr(self, "_map", None), None
        if m is not None:
            m.close()
        fh = getattr(self, "_fh", None)
        if fh is not None:
            fh.close()

    def close(self) -> None:
        """Release the file; further reads raise DatError."""
        self._close_handles()

    @property
    def closed(self) -> bool:
        return self._map is None

    def __repr__(self) -> str:
        state = "closed" if self.closed else f"block size {self.header.block_size}"
        return f"DatFile({self.path!r}, {state})"

    def describe(self, file_id: int) -> str:
        """A one-line description of an entry, for logs and CLIs."""
        e = self.entry(file_id)
        return f"{format_file_id(e.file_id)}: {e.size} bytes at 0x{e.offset:X}, iteration {e.iteration}"
