"""BSP trees as the client packs them (physics, cell and drawing trees).

Each node starts with a four-character tag stored as a little-endian uint:
`LEAF`, `PORT` (drawing trees), or an internal node whose tag names its
children: `BPnn`/`BPIn` positive child only, `BpIN`/`BpnN` negative child
only, `BPIN`/`BPnN` both. What follows depends on the tree:

* internal node: splitting plane, the children (positive first, each a whole
  subtree), then physics: bounding sphere; drawing: sphere, polygon count
  (uint) and polygon ids (ushorts); cell: nothing.
* `PORT`: plane, both children, then drawing only: sphere, polygon count,
  portal count, polygon ids, (portal index, polygon id) short pairs.
* `LEAF`: leaf index (int), then physics only: solid flag (int), sphere,
  polygon count (uint) and polygon ids (ushorts).

Physics and cell trees come out as the scene format's BSP dicts; drawing
trees are parsed only to step over them. The parser keeps its own work list
instead of recursing, so a deep or corrupt tree cannot exhaust Python's
stack, and every node consumes bytes, so it always ends.
"""

from __future__ import annotations

from typing import Any, Literal

from .binary import RecordReader
from .shapes import read_plane, read_sphere

__all__ = ["BSPKind", "read_bsp", "count_leaves", "INTERNAL_TAGS", "POS_ONLY_TAGS", "NEG_ONLY_TAGS", "BOTH_TAGS"]

BSPKind = Literal["physics", "cell", "drawing"]

POS_ONLY_TAGS = frozenset({"BPnn", "BPIn"})
NEG_ONLY_TAGS = frozenset({"BpIN", "BpnN"})
BOTH_TAGS = frozenset({"BPIN", "BPnN"})
INTERNAL_TAGS = POS_ONLY_TAGS | NEG_ONLY_TAGS | BOTH_TAGS

_BOTH_CHILDREN = ("pos_node", "neg_node")


def _children(tag: str) -> tuple[str, ...] | None:
    if tag in BOTH_TAGS or tag == "PORT":
        return _BOTH_CHILDREN
    if tag in POS_ONLY_TAGS:
        return ("pos_node",)
    if tag in NEG_ONLY_TAGS:
        return ("neg_node",)
    return None


def _read_poly_ids(r: RecordReader, count: int, what: str) -> list[int]:
    r.count(count, 2, what)
    return list(r.array("H", count, what))


def _read_leaf(r: RecordReader, kind: BSPKind) -> dict[str, Any]:
    leaf: dict[str, Any] = {"type": "LEAF", "leaf_index": r.i32("BSP leaf index")}
    if kind == "physics":
        leaf["solid"] = r.i32("BSP leaf solid flag")
        leaf["sphere"] = read_sphere(r, "BSP leaf sphere")
        leaf["in_polys"] = _read_poly_ids(r, r.u32("BSP leaf polygon count"), "BSP leaf polygon ids")
    return leaf


def _finish_node(r: RecordReader, node: dict[str, Any], kind: BSPKind) -> None:
    """The fields stored after a node's children."""
    if kind == "cell":
        return
    if node["type"] == "PORT":
        if kind == "drawing":
            node["sphere"] = read_sphere(r, "BSP portal sphere")
            num_polys = r.u32("BSP portal polygon count")
            num_portals = r.u32("BSP portal count")
            node["in_polys"] = _read_poly_ids(r, num_polys, "BSP portal polygon ids")
            r.count(num_portals, 4, "BSP portal")
            node["in_portals"] = [list(r.array("h", 2, "BSP portal entry")) for _ in range(num_portals)]
        return
    node["sphere"] = read_sphere(r, "BSP node sphere")
    if kind == "drawing":
        node["in_polys"] = _read_poly_ids(r, r.u32("BSP node polygon count"), "BSP node polygon ids")


def read_bsp(r: RecordReader, kind: BSPKind) -> dict[str, Any]:
    """Read one BSP tree of the given kind starting at the cursor; returns its root dict.

    Internal nodes: `{"type", "splitting_plane", "pos_node"?, "neg_node"?, "sphere"?}`;
    leaves: `{"type": "LEAF", "leaf_index", ...}` with `solid`, `sphere` and
    `in_polys` in physics trees.
    """
    holder: dict[str, Any] = {}
    # LIFO work list: ("node", parent dict, key to fill) or ("finish", node dict).
    work: list[tuple[str, dict[str, Any], str]] = [("node", holder, "root")]
    while work:
        step, target, key = work.pop()
        if step == "finish":
            _finish_node(r, target, kind)
            continue
        tag = r.tag("BSP node tag")
        if tag == "LEAF":
            target[key] = _read_leaf(r, kind)
            continue
        children = _children(tag)
        if children is None:
            raise r.error(f"unknown BSP node tag {tag!r} at offset {r.pos - 4}")
        node: dict[str, Any] = {"type": tag, "splitting_plane": read_plane(r, "BSP splitting plane")}
        target[key] = node
        work.append(("finish", node, ""))
        for child in reversed(children):  # positive subtree is stored (and so read) first
            work.append(("node", node, child))
    return holder["root"]


def count_leaves(root: dict[str, Any]) -> int:
    """Number of LEAF nodes under `root` (the GfxObj's informative `num_physics_leaves`)."""
    count = 0
    stack = [root]
    while stack:
        node = stack.pop()
        if node.get("type") == "LEAF":
            count += 1
            continue
        for child in _BOTH_CHILDREN:
            if child in node:
                stack.append(node[child])
    return count
