"""A column batch's movers, looked up by `ServiceCore.engine_movers_of` and kept for a repeated id column:
what it answers must always be what the core holds now, whatever was added, dropped or replaced between
two requests with the same id bytes."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.standins import SilentBus
from benchmarks.scenes import PLAYER
from engine import load_scene
from engine.geometry import Position, Vec3
from service.column_moves import reply_message, run_columns
from service.core import ServiceCore
from service.ownership import Ownership
from service.protocol.column_request import parse_column_request
from service.protocol.columns import REQUEST_COLUMNS, pack_columns
from service.protocol.requests import RegisterRequest, decode_envelope
from service.protocol.frames import pack
from service.protocol.wire import ErrorKind
from service.stats import ServiceStats
from support.service_harness import DEMO_SCENE

import msgpack

WALKER = PLAYER


@pytest.fixture()
def core() -> ServiceCore:
    world = load_scene(str(DEMO_SCENE))
    return ServiceCore(world, SilentBus(), ownership=Ownership(), instance="t", stats=ServiceStats())


def _register(core: ServiceCore, x: float) -> int:
    cell = 0xA9B40000 | (int(x // 24) * 8 + 1)  # outdoor cells of landblock A9B4 run along x in 24 m steps
    z = core.world.terrain_height(cell, x, 12.0)
    return int(core.register(RegisterRequest(None, WALKER, Position.at(cell, Vec3(x, 12.0, z + 0.01)), None,
                                             None))["state"]["id"])


def _column_request(ids: list[int]) -> bytes:
    return pack({"kind": "offset", "columns": pack_columns(REQUEST_COLUMNS, {
        "id": np.array(ids, dtype=np.uint64), "offset": np.tile([0.1, 0.0, 0.0], (len(ids), 1))})})


def test_the_lookup_answers_what_the_core_holds_after_every_change(core: ServiceCore) -> None:
    a, b, c = (_register(core, x) for x in (30.0, 60.0, 90.0))
    ids = [a, b, c]
    first = core.engine_movers_of(ids)
    assert first == [core.movers[i].mover for i in ids]
    first[0] = None  # the caller's list is its own: the kept lookup is not changed through it
    assert core.engine_movers_of(ids)[0] is core.movers[a].mover
    core.remove(b)
    assert core.engine_movers_of(ids) == [core.movers[a].mover, None, core.movers[c].mover]
    old_c = core.movers[c].mover
    core.update(c, WALKER)  # the engine's Mover is replaced
    got = core.engine_movers_of(ids)
    assert got[2] is core.movers[c].mover and got[2] is not old_c
    d = _register(core, 120.0)
    assert core.engine_movers_of([a, d]) == [core.movers[a].mover, core.movers[d].mover]


def test_a_repeated_id_column_fails_an_item_whose_mover_left_meanwhile(core: ServiceCore) -> None:
    ids = [_register(core, x) for x in (30.0, 60.0, 90.0)]
    payload = _column_request(ids)  # the same bytes every time: parse_column_request shares its id list
    for _ in range(2):
        out, _ = run_columns(core, parse_column_request(decode_envelope(payload)), 0.0)
        assert out.errors == []
    core.remove(ids[1])
    out, _ = run_columns(core, parse_column_request(decode_envelope(payload)), 0.0)
    reply = msgpack.unpackb(reply_message(out))
    assert [(e["index"], e["id"], e["error"]["kind"]) for e in reply["errors"]] == [(1, ids[1], ErrorKind.UNKNOWN_MOVER)]
    seq = np.frombuffer(reply["columns"]["seq"], dtype="<u8")
    assert seq.tolist() == [3, 0, 3]  # the two movers held moved a third time; the removed one did not run
