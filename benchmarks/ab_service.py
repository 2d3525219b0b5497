"""Interleaved A/B of the one-move path: this tree's service and client against another source tree's.

    python3 -m benchmarks.ab_service OTHER_TREE [--rounds 10] [--block 100] [--engine-root DIR]

OTHER_TREE is a copy of the sources to compare with (e.g. `git archive <commit> | tar -x -C /tmp/base`).
On this shared, noisy machine the same code runs 2-3x slower after an idle gap than in a hot loop, and
other processes come and go, so single wall-clock numbers compare nothing: here both trees run side by
side in one run, their blocks alternating (A B, then B A, ...), and the medians of the block medians
are compared. Two measurements:

- handling: each tree's service callback called with stand-in queries (benchmarks/standins.py), the
  engine replaced by a stand-in: what the service itself adds to a move (decode, checks, stats,
  publication check, pack, reply), back to back; and each tree's `Client.move` with a stand-in
  session (the client library's part);
- round trip: each tree's `python -m service` and a client process using that tree's client library,
  one move per request, beside one bare Zenoh echo queried by the same client processes (move / echo).

Blocks in one run compare code warm. For the round trip as the target reads it (fresh launches of every
process, each series asked in every order), compare two trees with `python3 -m benchmarks.round_trip_launches
pairs A B`, and compare a tree with a copy of itself first: identical copies differed by a few µs there.

`--engine-root` (e.g. benchmarks/out/compiled, made by `python3 -m benchmarks --build-compiled`) puts a
compiled engine first on both trees' path. Everything listens on 127.0.0.1; every process is stopped
at the end; every loop is bounded in count.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
ECHO_KEY = "acphys-bench/echo"  # bench_service.ECHO_KEY (not imported: the children run without the package)


# -- children: run by file path, with a tree's service/clients/engine on the path ------------------------
def _player() -> Any:
    from engine import MoverSpec, SphereSpec

    return MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.48), 0.48), SphereSpec((0.0, 0.0, 1.35), 0.48)],
                     state=["Contact", "OnWalkable", "IsPlayer", "EdgeSlide"])


def _start(index: int) -> Any:
    from engine.geometry import Position, Vec3

    x = 20.0 + 15.0 * index  # bench_service.start_position's grid, in landblock A9B4
    return Position.at(0xA9B40000 | (int(x // 24) * 8 + int(20.0 // 24) + 1), Vec3(x, 20.0, 50.0))


def _blocks(run_block: Any) -> None:
    """Answer each stdin line `N` with one JSON line: `run_block(N)`'s samples."""
    print("ready", flush=True)
    for line in sys.stdin:
        print(json.dumps(run_block(int(line))), flush=True)


def handling_child(scene: str) -> None:
    """The service's move callback (engine replaced) and `Client.move` (session replaced), in blocks."""
    import msgpack

    from clients import Client, Move
    from engine.geometry import Position, Vec3
    from engine import MoveResult
    from service.protocol.codec import encode_mover_spec, encode_position, pack_state
    from service.protocol.frames import state_message
    from service.bus.node import NodeOptions, ServiceNode
    from service.protocol.requests import parse_register
    from service.world_source import open_world
    from service.bus.zconfig import make_config
    from standins import NoEngine, StandInQuery, StandInSession  # benchmarks/ is this script's directory

    node = ServiceNode(open_world(scene=scene), make_config(listen=[]), NodeOptions())
    node.start()
    try:
        core = node.core
        assert core is not None
        start = _start(0)
        mid = core.register(parse_register({"v": 1, "mover": encode_mover_spec(_player()),
                                            "position": encode_position(start)}))["state"]["id"]
        core.world = NoEngine(core.world, core.movers[mid].last)
        key = node.keys.move(start.landblock)
        handler: Any = node.lb_queryable("*")
        payloads = [msgpack.packb({"v": 1, "move": Move(mid, offset=(d, 0.0, 0.0)).to_wire()}) for d in (0.2, -0.2)]
        result = MoveResult(True, Position.at(start.cell_id, Vec3(20.0, 20.0, 50.0)), "OK", True, True, None,
                            start.cell_id, None, None, False, 0, ["Contact", "OnWalkable"], [])
        client = Client(session=StandInSession(state_message(pack_state(7, 1, result, []))))  # type: ignore[arg-type]
        client.locate(7, start.landblock)

        def run_block(n: int) -> dict[str, list[float]]:
            out: dict[str, list[float]] = {"service": [], "client": []}
            clock = time.perf_counter
            for i in range(n):
                q = StandInQuery(key, payloads[i % 2])
                t0 = clock()
                handler(q)
                out["service"].append(clock() - t0)
            for _ in range(n):
                t0 = clock()
                client.move(7, offset=(0.2, 0.0, 0.0))
                out["client"].append(clock() - t0)
            return out

        run_block(300)  # warm
        _blocks(run_block)
    finally:
        node.shutdown(timeout=5.0)


def client_child(service_endpoint: str, echo_endpoint: str, index: int) -> None:
    """One move per request through this tree's client library, and the bare echo, in blocks."""
    import msgpack
    import zenoh

    from clients import Client, Move
    from service.bus.zconfig import make_config

    with Client([service_endpoint], timeout=30.0) as c:
        mid = c.register(_player(), _start(index)).id
        probe = msgpack.packb({"v": 1, "move": Move(mid, offset=(0.2, 0.0, 0.0)).to_wire()}, use_bin_type=True)
        echo = zenoh.open(make_config(connect=[echo_endpoint]))
        try:
            sign = [1.0]

            def run_block(n: int) -> dict[str, list[float]]:
                out: dict[str, list[float]] = {"echo": [], "move": []}
                clock = time.perf_counter
                for _ in range(n):
                    t0 = clock()
                    replies = list(echo.get(ECHO_KEY, payload=probe, timeout=10.0))
                    out["echo"].append(clock() - t0)
                    assert replies and replies[0].ok is not None
                for _ in range(n):
                    t0 = clock()
                    c.move(mid, offset=(0.2 * sign[0], 0.0, 0.0))
                    out["move"].append(clock() - t0)
                    sign[0] = -sign[0]
                return out

            run_block(50)  # warm both routes
            _blocks(run_block)
        finally:
            echo.close()
        c.remove(mid)


# -- the parent ------------------------------------------------------------------------------------------
def _env(tree: Path, engine_root: Path | None) -> dict[str, str]:
    env = dict(os.environ)
    first = [str(engine_root)] if engine_root else []
    env["PYTHONPATH"] = os.pathsep.join([*first, str(tree)])
    env["PYTHONUNBUFFERED"] = "1"
    return env


class _Service:
    """A tree's `python -m service` (that tree's code, the compiled engine first when given), stopped by SIGINT."""

    def __init__(self, tree: Path, engine_root: Path | None, scene: str, endpoint: str) -> None:
        self.proc = subprocess.Popen([sys.executable, "-m", "service", "--scene", scene, "--listen", endpoint,
                                      "--log-level", "WARNING"], cwd=engine_root or tree, env=_env(tree, engine_root),
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        assert self.proc.stdout is not None
        lines = []
        for line in self.proc.stdout:  # ends when the process does
            lines.append(line)
            if "acphys service ready" in line:
                break
            if len(lines) > 200:
                break
        else:
            self.stop()
            raise RuntimeError(f"the service of {tree} did not start:\n" + "".join(lines[-30:]))
        # drained from here on, so that a service that logs much never blocks on a full pipe
        threading.Thread(target=lambda: [None for _ in self.proc.stdout or ()], daemon=True).start()

    def stop(self) -> None:
        from .service_harness import interrupt

        interrupt(self.proc)


class _BlockChild:
    """A child answering `N` lines with a block's samples."""

    def __init__(self, args: list[str], tree: Path, engine_root: Path | None) -> None:
        self.proc = subprocess.Popen([sys.executable, str(Path(__file__).resolve()), *args], cwd=engine_root or tree,
                                     env=_env(tree, engine_root), stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     text=True)
        assert self.proc.stdout is not None
        line = self.proc.stdout.readline().strip()
        if line != "ready":
            self.stop()
            raise RuntimeError(f"{args[0]} in {tree} did not start ({line!r})")

    def block(self, n: int) -> dict[str, list[float]]:
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.write(f"{n}\n")
        self.proc.stdin.flush()
        out: dict[str, list[float]] = json.loads(self.proc.stdout.readline())
        return out

    def stop(self) -> None:
        if self.proc.stdin is not None:
            self.proc.stdin.close()
        try:
            self.proc.wait(30)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(10)


def _interleave(children: dict[str, _BlockChild], rounds: int, block: int) -> dict[str, dict[str, float]]:
    """Blocks alternating between the trees (ABBA...); per tree and measurement the median of block medians (µs)."""
    medians: dict[str, dict[str, list[float]]] = {k: {} for k in children}
    names = list(children)
    for r in range(rounds):
        for k in (names if r % 2 == 0 else names[::-1]):
            for what, samples in children[k].block(block).items():
                medians[k].setdefault(what, []).append(statistics.median(samples) * 1e6)
    return {k: {what: statistics.median(v) for what, v in m.items()} for k, m in medians.items()}


def run(other: Path, rounds: int, block: int, engine_root: Path | None) -> dict[str, Any]:
    from .service_harness import Child, free_port, scene_file

    if engine_root is not None and not (engine_root / "engine").is_dir():
        raise SystemExit(f"{engine_root} holds no engine/")

    trees = {"other": other.resolve(), "this": HERE.parent}
    scene = str(scene_file())
    children: dict[str, _BlockChild] = {}
    try:
        for k, tree in trees.items():
            children[k] = _BlockChild(["handling-child", scene], tree, engine_root)
        handling = _interleave(children, rounds, block * 10)
    finally:
        for c in children.values():
            c.stop()
    echo_port = free_port()
    echo = Child([sys.executable, "-m", "benchmarks.bench_service", "echo", str(echo_port)], "echo ready")
    services: dict[str, _Service] = {}
    children = {}
    try:
        for i, (k, tree) in enumerate(trees.items()):
            endpoint = f"tcp/127.0.0.1:{free_port()}"
            services[k] = _Service(tree, engine_root, scene, endpoint)
            children[k] = _BlockChild(["client-child", endpoint, f"tcp/127.0.0.1:{echo_port}", str(i)], tree,
                                      engine_root)
        round_trip = _interleave(children, rounds, block)
    finally:
        for c in children.values():
            c.stop()
        for s in services.values():
            s.stop()
        echo.stop()
    for rt in round_trip.values():
        rt["move_to_echo"] = rt["move"] / rt["echo"]
    return {"trees": {k: str(v) for k, v in trees.items()}, "engine_root": str(engine_root) if engine_root else None,
            "rounds": rounds, "block": block, "handling_us": handling, "round_trip_us": round_trip}


def main(argv: list[str]) -> None:
    p = argparse.ArgumentParser(prog="python3 -m benchmarks.ab_service", description=__doc__.split("\n\n")[0])
    p.add_argument("other", type=Path, help="the source tree to compare this one with")
    p.add_argument("--rounds", type=int, default=10, help="blocks per tree (default %(default)s)")
    p.add_argument("--block", type=int, default=100, help="round trips per block; handling runs 10x as many")
    p.add_argument("--engine-root", type=Path, default=None, help="a compiled engine to put first on both paths")
    a = p.parse_args(argv)
    out = run(a.other, a.rounds, a.block, a.engine_root.resolve() if a.engine_root else None)
    for what, table in (("handling", out["handling_us"]), ("round trip", out["round_trip_us"])):
        for k, row in table.items():
            print(f"{what:10s} {k:5s} " + "  ".join(f"{m} {v:.2f}" if m == "move_to_echo" else f"{m} {v:.1f} µs"
                                                    for m, v in row.items()))
    print(json.dumps(out))


if __name__ == "__main__":
    if sys.argv[1] == "handling-child":
        handling_child(sys.argv[2])
    elif sys.argv[1] == "client-child":
        client_child(sys.argv[2], sys.argv[3], int(sys.argv[4]))
    else:
        main(sys.argv[1:])
