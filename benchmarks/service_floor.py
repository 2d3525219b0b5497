"""The floor under the service's one move, measured inside a service's own process.

    python3 -m benchmarks.service_floor PORT     (the service benchmark starts it; prints "floor ready")

A service node is started as `python -m service` starts one (same options, same world source), and two
more queryables are declared on its session, both answering one move with the least the protocol asks:
the request read by the service's own reader (msgspec, `plain_single_move`), `World.move` on the mover's
last position, the State packed by the service's packer, the reply. No key check, stats, queue, engine
lock, publication check or error handling: what those cost is the gap between this floor and the node's
own `P/lb/*/move` in the same process, queried the same way.

- `FLOOR_EXACT_KEY` is declared as it is queried, a literal key, as the bare engine queryable's is;
- `FLOOR_WILD_KEY` is declared with a `*` chunk and queried on a literal one, as the service's
  per-landblock keys are (`P/lb/*/move`), and that literal key is declared on the session as the node
  declares each key it is asked on (service/bus/route_keys.py): the difference is what Zenoh's dispatch
  of a wildcard declaration still costs each query.

Movers are registered through the node's own `register` (the client library); the floor handlers move
them with the core's records. Listens on 127.0.0.1 only; stops on SIGINT or SIGTERM.

`floor_client_move` is the floor's other half, the least a client does for one move: the move map encoded,
the request on a key declared on the session, the State read into typed values by the client library's own
reader. Asked of `FLOOR_EXACT_KEY`, the two halves are one move as the protocol alone costs it
(benchmarks/round_trip_launches.py).
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any

__all__ = ["FLOOR_EXACT_KEY", "FLOOR_WILD_KEY", "FLOOR_WILD_QUERY", "floor_main", "floor_client_move",
           "lean_move_handler"]

FLOOR_EXACT_KEY = "acphys-bench/floor-exact/A9B4"
#: declared with a wildcard chunk; queried as FLOOR_WILD_QUERY
FLOOR_WILD_KEY = "acphys-bench/floor-wild/*"
FLOOR_WILD_QUERY = "acphys-bench/floor-wild/A9B4"


def floor_main(port: int) -> None:
    from service.bus.node import NodeOptions, ServiceNode
    from service.bus.route_keys import RouteKeys
    from service.bus.zconfig import make_config
    from service.world_source import open_world

    from .service_harness import scene_file, stop_event

    stop = stop_event()
    # the options `python -m service` gives its node (service/main.py), the queue as the benchmark's service's
    node = ServiceNode(open_world(scene=str(scene_file())), make_config(listen=[f"tcp/127.0.0.1:{port}"]),
                       NodeOptions(queue_capacity=4096, tune_heap=True))
    node.start()
    session = node.session
    assert node.core is not None and session is not None
    lean_move = lean_move_handler(node.core)

    declared = [session.declare_queryable(key, lean_move) for key in (FLOOR_EXACT_KEY, FLOOR_WILD_KEY)]
    route_keys = RouteKeys(session)  # the query key declared, as the node's are
    route_keys.learn(FLOOR_WILD_QUERY)
    print("floor ready", flush=True)
    stop.wait()
    route_keys.close()
    for d in declared:
        d.undeclare()
    node.shutdown()


def lean_move_handler(core: Any) -> Callable[[Any], None]:
    """The floor's queryable callback on `core`'s world and records: one plain move request answered with its
    State (decode, engine, pack, reply), nothing else."""
    from service.protocol.codec import pack_state
    from service.protocol.frames import STATE_HEAD
    from service.protocol.move_structs import plain_single_move

    world = core.world

    def lean_move(query: Any) -> None:
        plain = plain_single_move(query.payload.to_bytes())
        assert plain is not None, "the floor takes only a plain one-move request"
        item = plain[0]
        assert item.offset is not None, "the floor takes only an offset move"
        rec = core.mover_record(item.id)
        r = world.move(rec.engine_id, rec.last.position.moved(item.offset), item.velocity)
        query.reply(query.key_expr, STATE_HEAD + pack_state(rec.id, r.seq, r, [], item.tag))

    return lean_move


def floor_client_move(session: Any, key: str, mover_id: int) -> Callable[[int], Any]:
    """A series for common.round_trips_in_every_order: one move of `mover_id` asked on `key` as the least client
    would ask it, alternately 0.2 m east and back, each answer its MoverState.

    What `Client.move` does and this leaves out: the Move object and its generated writer, the landblock the
    mover was last seen in, the redirects and errors of a reply that is not a State. What it keeps: the move
    map (docs/protocol.md, "Move request") packed by msgspec, the key declared on the session as the client
    library declares its keys, the first reply taken as it comes (without waiting for the query's end, as
    `Client.move` takes it) and read by the client library's own State reader."""
    import msgspec

    from clients.state_reply import decode_state_reply
    from service.protocol.wire import PROTOCOL_VERSION

    encode = msgspec.msgpack.Encoder().encode
    declared = session.declare_keyexpr(key)
    offsets = ([0.2, 0.0, 0.0], [-0.2, 0.0, 0.0])

    def move(i: int) -> Any:
        request = {"v": PROTOCOL_VERSION, "move": {"id": mover_id, "offset": offsets[i % 2]}}
        first = next(iter(session.get(declared, payload=encode(request), timeout=10.0)), None)  # as Client.move
        state = decode_state_reply(first.ok.payload.to_bytes()) if first is not None and first.ok is not None else None
        if state is None:
            raise RuntimeError(f"move {i} on {key}: no State in the reply")
        return state

    return move


if __name__ == "__main__":
    floor_main(int(sys.argv[1]))
