"""The one-move floor (benchmarks/service_floor.py) does the move the service's own path does: a move
answered by its lean handler and one answered by the node's move key follow each other on one mover,
each a State of the next seq, each 0.2 m further east on the benchmark's flat ground."""

from __future__ import annotations

import sys

import msgpack
import pytest

from benchmarks.service_floor import FLOOR_EXACT_KEY, FLOOR_WILD_QUERY
from benchmarks.service_harness import Child, bench_walker, free_port, start_position


def test_the_floor_and_the_node_s_own_path_move_the_same_mover_alike() -> None:
    from clients import Client, Move

    port = free_port()
    floor = Child([sys.executable, "-m", "benchmarks.service_floor", str(port)], "floor ready")
    try:
        with Client([f"tcp/127.0.0.1:{port}"], timeout=30.0) as c:
            start = c.register(bench_walker(), start_position(0))
            request = msgpack.packb({"v": 1, "move": Move(start.id, offset=(0.2, 0.0, 0.0)).to_wire()})
            keys = [FLOOR_EXACT_KEY, c.keys.move(start.landblock), FLOOR_WILD_QUERY, c.keys.move(start.landblock)]
            x0 = start.position.origin.x
            for k, key in enumerate(keys, 1):
                (reply,) = list(c.session.get(key, payload=request, timeout=30.0))
                assert reply.ok is not None, key
                state = msgpack.unpackb(reply.ok.payload.to_bytes())["state"]
                assert state["id"] == start.id and state["seq"] == start.seq + k, key
                # flat ground: every move of 0.2 m east ends 0.2 m further east, on the ground it started on
                assert state["position"]["origin"][0] == pytest.approx(x0 + 0.2 * k, abs=1e-5), key
                assert state["position"]["origin"][2] == pytest.approx(start.position.origin.z, abs=1e-5), key
    finally:
        floor.stop()
