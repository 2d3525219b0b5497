"""What the node does with each operation on a landblock's keys, in one table.

`OPERATIONS[op]` says how a request of `op` is read (on the callback thread: ProtocolError for bad
input, before anything runs), what work it becomes (a closure run with the engine lock held, returning
the reply), how many items it holds, and when that work may run in the callback itself instead of on
the engine thread: `"small"` when it holds at most `NodeOptions.inline_max_moves` items, `"always"` for
the one-mover operations, `"never"` for those that may take long (a landblock read from disk, a path
building its graph). ServiceNode (service/bus/node.py) is the only caller, through what NodePort names;
the bus, the queue and the replies stay there.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING, Any, Final, Literal, Protocol

import msgpack

from service.protocol.column_request import column_count, is_column_request
from service.protocol.frames import results_message, state_message
from service.protocol import QUERIES, QUERY_OPS
from service.queries import query_count, query_work
from service.protocol.requests import ItemError, parse_handover, parse_id, parse_moves, parse_register, parse_update

if TYPE_CHECKING:
    from service.core import ServiceCore
    from service.protocol.errors import ProtocolError
    from service.stats import ServiceStats

__all__ = ["Operation", "OPERATIONS", "Work", "NodePort"]

#: the work of a request: run with the engine lock held, it returns the reply (a map, or its packed bytes)
Work = Callable[[], "dict[str, Any] | bytes"]


class _PathOptions(Protocol):
    path_work: int


class NodePort(Protocol):
    """What the operations need of the node that runs them (service/bus/node.py's ServiceNode)."""

    @property
    def core(self) -> ServiceCore | None: ...
    @property
    def stats(self) -> ServiceStats: ...
    @property
    def options(self) -> _PathOptions: ...

    def column_work(self, msg: dict[str, Any], received: float, lb: int | None) -> Callable[[], bytes]: ...
    def item_error(self, op: str, lb: int | None, err: ProtocolError, index: int, mover_id: int | None) -> None: ...
    def query_item_errors(self, op: str, lb: int | None, content: dict[str, Any]) -> dict[str, Any]: ...
    def world_changed(self, answer: dict[str, Any]) -> dict[str, Any]: ...


#: (node, the key's landblock or None for a wildcard, the request map, when it arrived) -> its work
Prepare = Callable[[NodePort, "int | None", "dict[str, Any]", float], Work]


@dataclass(frozen=True, slots=True)
class Operation:
    """How the node runs one operation (the module's docstring)."""

    prepare: Prepare
    inline: Literal["small", "always", "never"]
    #: how many items a request holds (for the inline rule and the request's DEBUG line)
    count: Callable[[dict[str, Any]], int] = lambda msg: 1
    #: changes the world every tenant shares (a landblock loaded or unloaded): only the service's
    #: `--admin` users may send it (NodeOptions.world_admin), and its request has no fields (an empty
    #: payload will do)
    changes_world: bool = False


def _core(node: NodePort) -> ServiceCore:
    core = node.core
    assert core is not None, "the node is not started"
    return core


def _literal(lb: int | None) -> int:
    assert lb is not None, "the key's landblock (a wildcard is refused for this operation)"
    return lb


# -- moves ------------------------------------------------------------------------------------------------
def _move_count(msg: dict[str, Any]) -> int:
    if is_column_request(msg):
        return column_count(msg)
    moves = msg.get("moves")
    return len(moves) if isinstance(moves, list) else 1


def _moves(node: NodePort, lb: int | None, msg: dict[str, Any], received: float) -> Work:
    if is_column_request(msg):
        return node.column_work(msg, received, lb)
    core = _core(node)
    batch = parse_moves(msg)
    if batch.single:
        item = batch.items[0]
        assert not isinstance(item, ItemError)
        return lambda: state_message(core.move_one(item, received, batch_mode=batch.publish_batch))

    def run_batch() -> bytes:
        entries: list[bytes] = []
        for i, r in enumerate(core.moves(batch, received)):
            if isinstance(r, ItemError):
                node.stats.error(r.error.kind)
                node.item_error("move", lb, r.error, i, r.id)
                entries.append(msgpack.packb(r.to_wire(), use_bin_type=True))
            else:
                entries.append(r)
        return results_message(entries)

    return run_batch


# -- movers and landblocks ----------------------------------------------------------------------------------
def _register(node: NodePort, lb: int | None, msg: dict[str, Any], received: float) -> Work:
    return partial(_core(node).register, parse_register(msg))


def _update(node: NodePort, lb: int | None, msg: dict[str, Any], received: float) -> Work:
    return partial(_core(node).update, *parse_update(msg))


def _remove(node: NodePort, lb: int | None, msg: dict[str, Any], received: float) -> Work:
    return partial(_core(node).remove, parse_id(msg))


def _get(node: NodePort, lb: int | None, msg: dict[str, Any], received: float) -> Work:
    return partial(_core(node).get, parse_id(msg))


def _load(node: NodePort, lb: int | None, msg: dict[str, Any], received: float) -> Work:
    core, landblock = _core(node), _literal(lb)
    return lambda: node.world_changed(core.load(landblock))


def _unload(node: NodePort, lb: int | None, msg: dict[str, Any], received: float) -> Work:
    core, landblock = _core(node), _literal(lb)
    return lambda: node.world_changed(core.unload(landblock))


def _handover(node: NodePort, lb: int | None, msg: dict[str, Any], received: float) -> Work:
    return partial(_core(node).handover_in, parse_handover(msg))


# -- queries ------------------------------------------------------------------------------------------------
def _query(op: str) -> Prepare:
    def prepare(node: NodePort, lb: int | None, msg: dict[str, Any], received: float) -> Work:
        core = _core(node)
        work = query_work(op, lb, msg, core.world, lambda i, path: core.engine_id(i, path), core.wire_id,
                          path_work=node.options.path_work)
        return lambda: node.query_item_errors(op, lb, work())
    return prepare


OPERATIONS: Final[dict[str, Operation]] = {
    "move": Operation(_moves, "small", _move_count),
    "register": Operation(_register, "always"),
    "update": Operation(_update, "always"),
    "remove": Operation(_remove, "always"),
    "get": Operation(_get, "always"),
    # may read a landblock from disk
    "load": Operation(_load, "never", changes_world=True),
    "unload": Operation(_unload, "never", changes_world=True),
    # queued with priority by the node (never `busy`, served while it waits on its own hand-over)
    "handover": Operation(_handover, "never"),
    **{op: Operation(_query(op), "small" if QUERIES[op].inline_ok else "never", partial(query_count, op=op))
       for op in QUERY_OPS},
}
