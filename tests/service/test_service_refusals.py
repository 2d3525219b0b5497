"""Refused requests leave everything as if they had never been asked.

A move refused with `no_owner`: an instance that owns only some landblocks hands a mover whose move
ended outside them to the owner; when no instance takes it, the move is refused. The mover must then be
exactly as before the move: same place, velocity, time held over, seq and engine object, so that its
next move gives what an instance that never got the refused move gives, bit for bit. (It used to be
removed and registered again: that reset its velocity, and a position the start checks refuse lost the
mover altogether.) A refused registration must not use up the id the next one is given.

Two in-process instances, A and a control B, own A9B4 and A9B5 (the demo world's west half, no
cluster, so nobody takes a hand-over); their query handlers are called with recording stand-ins for
Zenoh's queries.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

from service.protocol.columns import REPLY_BY_NAME, REQUEST_COLUMNS, pack_columns, unpack_column
from service.bus.node import NodeOptions, ServiceNode
from service.ownership import Ownership
from service.world_source import open_world
from service.bus.zconfig import make_config
from support.service_harness import StandInQuery, free_port

DEMO = "clients/demo/demo.json"
MOVER = 0x70000001
WALKER = {"spheres": [{"center": [0, 0, 0.48], "radius": 0.48}, {"center": [0, 0, 1.35], "radius": 0.48}],
          "step_up_height": 0.6, "step_down_height": 0.4, "state": ["IsPlayer"]}
#: outdoor cell 0x39 of A9B4 holds x 168..192, y 0..24: 12 m short of the border with AAB4 (not owned)
CELL = 0xA9B40039


def _node() -> ServiceNode:
    node = ServiceNode(open_world(scene=DEMO), make_config(listen=[f"tcp/127.0.0.1:{free_port()}"]),
                       NodeOptions(ownership=Ownership.parse("A9B4,A9B5"), handover_timeout=0.5))
    node.start()
    return node


@pytest.fixture()
def nodes() -> Iterator[tuple[ServiceNode, ServiceNode]]:
    a, b = _node(), _node()
    try:
        yield a, b
    finally:
        a.shutdown(timeout=5.0)
        b.shutdown(timeout=5.0)


def ask(node: ServiceNode, op: str, body: dict[str, Any]) -> StandInQuery:
    """One request on A9B4's key, answered (queued work included) before this returns."""
    q = StandInQuery(node.keys.lb("A9B4", op), {"v": 1, **body})
    node.lb_queryable("*")(q)
    deadline = time.monotonic() + 10.0
    while len(q.ok) + len(q.err) == 0 and time.monotonic() < deadline:
        time.sleep(0.002)
    node.snapshot(lambda _core: None)
    assert len(q.ok) + len(q.err) == 1, "every request is answered exactly once"
    return q


def ok(node: ServiceNode, op: str, body: dict[str, Any]) -> Any:
    q = ask(node, op, body)
    assert not q.err, q.err
    return q.ok[0]


def engine_mover(node: ServiceNode) -> Any:
    return node.snapshot(lambda core: core.world.movers[core.movers[MOVER].engine_id])


def engine_state(node: ServiceNode) -> tuple[Any, ...]:
    """Everything of the engine's mover a move reads or writes, exactly (the values are immutable)."""
    def read(core: Any) -> tuple[Any, ...]:
        m = core.world.movers[core.movers[MOVER].engine_id]
        return (m.position.cell_id, m.position.frame.origin, m.position.frame.orientation, m.velocity,
                m.acceleration, m.transient, m.contact_plane, m.contact_plane_cell_id, m.sliding_normal,
                m.held_time, m.held_motion, m.missile, m.colliding_with_environment, core.movers[MOVER].seq)
    return node.snapshot(read)


def _falling(*instances: ServiceNode) -> None:
    """The mover registered 12 m from the border, 30 m up, then half a second of falling."""
    for node in instances:
        ok(node, "register", {"id": MOVER, "mover": WALKER, "position": {"cell": CELL, "origin": [180.0, 20.0, 90.0]}})
        ok(node, "move", {"move": {"id": MOVER, "motion": [0.0, 0.0, 0.0], "dt": 0.5}})


def test_a_refused_move_leaves_a_falling_mover_as_it_was(nodes: tuple[ServiceNode, ServiceNode]) -> None:
    a, b = nodes
    _falling(a, b)
    before, mover_before = engine_state(a), engine_mover(a)
    assert before[3].z < -4.0  # falling: the refused move must not stop it
    q = ask(a, "move", {"move": {"id": MOVER, "offset": [14.0, 0.0, 0.0]}})  # ends in AAB4: nobody owns it
    assert q.err and q.err[0]["error"]["kind"] == "no_owner" and q.err[0]["error"]["landblock"] == 0xAAB4
    assert engine_state(a) == before
    assert engine_mover(a) is mover_before  # the same engine object: nothing removed and added again
    assert engine_state(a) == engine_state(b)
    # the next step falls on as on the instance that never got the refused move, bit for bit
    sa = ok(a, "move", {"move": {"id": MOVER, "motion": [0.0, 0.0, 0.0], "dt": 0.5}})["state"]
    sb = ok(b, "move", {"move": {"id": MOVER, "motion": [0.0, 0.0, 0.0], "dt": 0.5}})["state"]
    assert sa == sb and sa["seq"] == 2
    assert engine_state(a) == engine_state(b)


def test_a_refused_move_keeps_a_mover_the_start_checks_would_refuse(nodes: tuple[ServiceNode, ServiceNode]) -> None:
    a, _ = nodes
    # legal at x = 193 (past the cell's edge) only because its sphere sits 1.5 m west of its origin
    off_centre = {"spheres": [{"center": [-1.5, 0, 0.48], "radius": 0.48}], "state": ["IsPlayer"]}
    ok(a, "register", {"id": MOVER, "mover": off_centre, "position": {"cell": CELL, "origin": [191.0, 20.0, 90.0]}})
    ok(a, "move", {"move": {"id": MOVER, "offset": [2.0, 0.0, 0.0]}})  # origin past 192, the sphere still in A9B4
    ok(a, "update", {"id": MOVER, "mover": WALKER})  # now a position the start checks refuse
    before = engine_state(a)
    q = ask(a, "move", {"move": {"id": MOVER, "offset": [3.0, 0.0, 0.0]}})
    assert q.err and q.err[0]["error"]["kind"] == "no_owner"
    assert ok(a, "get", {"id": MOVER})["state"]["id"] == MOVER  # still here
    assert engine_state(a) == before


def _column_move(node: ServiceNode, offsets: list[list[float]]) -> Any:
    ids = np.full(len(offsets), MOVER, dtype=np.uint64)
    cols = pack_columns(REQUEST_COLUMNS, {"id": ids, "offset": np.array(offsets, dtype=np.float64)})
    return ask(node, "move", {"kind": "offset", "columns": cols}).ok[0]


def test_a_refused_column_item_leaves_the_mover_as_it_was(nodes: tuple[ServiceNode, ServiceNode]) -> None:
    a, b = nodes
    _falling(a, b)
    before = engine_state(a)
    # item 0 crosses into AAB4 (refused), item 1 moves the same mover from where it was before item 0
    reply = _column_move(a, [[14.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])
    assert [(e["index"], e["error"]["kind"]) for e in reply["errors"]] == [(0, "no_owner")]
    seq = unpack_column(REPLY_BY_NAME["seq"], reply["columns"]["seq"], 2).tolist()
    assert seq == [0, 2]
    assert engine_state(a) != before  # item 1 ran
    ok(b, "move", {"move": {"id": MOVER, "offset": [-1.0, 0.0, 0.0]}})  # the control only gets item 1
    assert engine_state(a) == engine_state(b)
    sa = ok(a, "move", {"move": {"id": MOVER, "motion": [0.0, 0.0, 0.0], "dt": 0.5}})["state"]
    sb = ok(b, "move", {"move": {"id": MOVER, "motion": [0.0, 0.0, 0.0], "dt": 0.5}})["state"]
    assert sa == sb and sa["seq"] == 3


def test_a_refused_register_leaves_the_next_assigned_id_as_it_was(nodes: tuple[ServiceNode, ServiceNode]) -> None:
    a, b = nodes
    q = ask(a, "register", {"mover": WALKER, "position": {"cell": 0xA9B40100, "origin": [20.0, 20.0, 60.0]}})
    assert q.err and q.err[0]["error"]["kind"] == "unknown_cell"
    b.snapshot(lambda core: setattr(core, "_id_base", a.core._id_base if a.core else 0))  # same id space
    spot = {"mover": WALKER, "position": {"cell": 0xA9B40001, "origin": [20.0, 20.0, 60.0]}}
    assert ok(a, "register", spot)["state"]["id"] == ok(b, "register", spot)["state"]["id"]
