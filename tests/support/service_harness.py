"""Shared helpers of the service and client tests.

Every service runs as a subprocess (`python -m service`) on a free
loopback port with multicast scouting off (the service's default), and is
stopped by signal; every loop here is bounded in count and time.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import msgpack
import zenoh

from clients.demo.world import global_to_cell
from engine import MoverSpec, SphereSpec, World, load_scene
from engine.geometry import Position, Vec3
from engine.world.types import MoveResult
from service.protocol.codec import encode_mover_spec, encode_position, encode_state
from service.protocol.requests import parse_register
from service.bus.zconfig import make_config

ROOT = Path(__file__).resolve().parents[2]
TESTS = ROOT / "tests"
DEMO_SCENE = ROOT / "clients" / "demo" / "demo.json"
START_TIMEOUT = 30.0


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def endpoint(port: int) -> str:
    return f"tcp/127.0.0.1:{port}"


def child_env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    env["PYTHONUNBUFFERED"] = "1"
    return env


class ServiceProcess:
    """`python -m service` on a free loopback port; a context manager that always stops it."""

    def __init__(self, scene: Path = DEMO_SCENE, *, own: str = "*", connect: Sequence[str] = (),
                 extra: Sequence[str] = ()) -> None:
        self.port = free_port()
        self.endpoint = endpoint(self.port)
        self.args = [sys.executable, "-m", "service", "--scene", str(scene), "--listen", self.endpoint,
                     "--own", own, "--log-level", "WARNING", *extra]
        for c in connect:
            self.args += ["--connect", c]
        self.proc: subprocess.Popen[str] | None = None
        self.output: list[str] = []

    def start(self) -> ServiceProcess:
        self.proc = subprocess.Popen(self.args, cwd=ROOT, env=child_env(), stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True)
        ready = threading.Event()

        def pump() -> None:
            assert self.proc is not None and self.proc.stdout is not None
            for line in self.proc.stdout:
                self.output.append(line)
                if "acphys service ready" in line:
                    ready.set()

        threading.Thread(target=pump, daemon=True).start()
        deadline = time.monotonic() + START_TIMEOUT
        while not ready.wait(0.05):
            if self.proc.poll() is not None or time.monotonic() > deadline:
                self.kill()
                raise RuntimeError("service did not start:\n" + "".join(self.output))
        return self

    def stop(self, sig: int = signal.SIGINT, timeout: float = 20.0) -> int:
        """Signal the service and wait; its exit status."""
        assert self.proc is not None
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
        try:
            return self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            self.kill()
            raise

    def kill(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(10)

    def __enter__(self) -> ServiceProcess:
        return self.start()

    def __exit__(self, *_: object) -> None:
        if self.proc is not None and self.proc.poll() is None:
            try:
                self.stop(timeout=10)
            except subprocess.TimeoutExpired:
                pass
        self.kill()


def raw_session(*endpoints: str) -> zenoh.Session:
    """A plain zenoh peer session connected to the given endpoints (no client library)."""
    return zenoh.open(make_config(connect=list(endpoints)))


def raw_query(session: zenoh.Session, key: str, payload: bytes | None, timeout: float = 5.0) -> tuple[bool, Any]:
    """(ok, decoded msgpack) of the single reply to a query."""
    kwargs: dict[str, Any] = {"timeout": timeout}
    if payload is not None:
        kwargs["payload"] = payload
    replies = list(session.get(key, **kwargs))
    assert len(replies) == 1, f"expected one reply on {key}, got {len(replies)}"
    r = replies[0]
    if r.ok is not None:
        return True, msgpack.unpackb(r.ok.payload.to_bytes(), raw=False)
    return False, msgpack.unpackb(r.err.payload.to_bytes(), raw=False)


# -- movers and the engine called directly ---------------------------------------------
def human(contact: bool = False) -> MoverSpec:
    state = ["IsPlayer"] + (["Contact", "OnWalkable"] if contact else [])
    return MoverSpec(
        spheres=[SphereSpec((0.0, 0.0, 0.48), 0.48), SphereSpec((0.0, 0.0, 1.35), 0.48)],
        step_up_height=0.6,
        step_down_height=0.4,
        state=state,
    )


def register_human(core: Any, gx: float = 40.0, gy: float = 40.0) -> int:
    """Register a `human()` straight into a node's ServiceCore, 60 m above the demo world's global (gx, gy)
    (it falls to the ground at its first move); its id."""
    cell, x, y = global_to_cell(gx, gy)
    req = parse_register({"v": 1, "mover": encode_mover_spec(human()),
                          "position": encode_position(Position.at(cell, Vec3(x, y, 60.0)))})
    return int(core.register(req)["state"]["id"])


def demo_world() -> World:
    return load_scene(str(DEMO_SCENE))


def start_on_ground(world: World, cell: int, x: float, y: float) -> Position:
    return Position.at(cell, Vec3(x, y, world.terrain_height(cell, x, y) + 0.5))


def comparable(state_or_result: Any) -> dict[str, Any]:
    """A State map (or a MoveResult) without id, seq and tag: what two runs must agree on."""
    if isinstance(state_or_result, MoveResult):
        m = encode_state(0, 0, state_or_result, [])
    elif isinstance(state_or_result, dict):
        m = dict(state_or_result)
    else:  # clients.MoverState
        m = encode_state(0, 0, state_or_result.result, [])
    for k in ("id", "seq", "tag", "collide_objects"):
        m.pop(k, None)
    return m


# -- a load-test worker, run in its own process -----------------------------------------------
def load_worker(endpoint_: str, index: int, requests: int, batch_every: int) -> dict[str, Any]:
    """Register a mover, send `requests` move requests (some as batches of 3) and
    watch its state key; report what came back."""
    from clients import Client, Move

    out: dict[str, Any] = {"index": index, "replies": {}, "errors": [], "states": []}
    states: list[int] = []
    lock = threading.Lock()
    with Client([endpoint_], timeout=20.0) as c:
        from clients.demo.world import global_to_cell

        cell, lx, ly = global_to_cell(30.0 + 20.0 * index, 30.0)
        st = c.register(human(), Position.at(cell, Vec3(lx, ly, 70.0)))
        mover_id = st.id

        def on_state(s: Any) -> None:
            with lock:
                states.append(s.seq)

        class _Seq:
            def __init__(self, seq: int) -> None:
                self.seq = seq

        sub = c.subscribe(on_state, mover_id)
        base = prime_states(c, mover_id, lambda: [_Seq(q) for q in list(states)])
        out["base_seq"] = base
        sent = 0
        while sent < requests:
            if batch_every and sent % batch_every == 0 and sent + 3 <= requests:
                tags = [f"{index}-{sent + k}" for k in range(3)]
                res = c.move_many([Move(mover_id, offset=(0.02, 0.0, 0.0), tag=t) for t in tags])
                for t, r in zip(tags, res):
                    out["replies"][t] = out["replies"].get(t, 0) + 1
                    if not hasattr(r, "seq"):
                        out["errors"].append(str(r))
                sent += 3
            else:
                t = f"{index}-{sent}"
                r = c.move(mover_id, offset=(0.0, 0.02, 0.0), tag=t)
                assert r.tag == t
                out["replies"][t] = out["replies"].get(t, 0) + 1
                sent += 1
        final = c.get(mover_id)[0]
        out["final_seq"] = final.seq
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline:
            with lock:
                if states and states[-1] >= final.seq:
                    break
            time.sleep(0.05)
        sub.close()
        with lock:
            out["states"] = [q for q in states if q > base]
        c.remove(mover_id)
    return out


def run_load_workers(endpoint_: str, processes: int, requests: int, batch_every: int = 5,
                     timeout: float = 240.0) -> list[dict[str, Any]]:
    """Start `processes` load workers at once and collect their reports."""
    code = (
        "import json, sys; sys.path.insert(0, {tests!r}); from support.service_harness import load_worker; "
        "print('RESULT ' + json.dumps(load_worker({ep!r}, {i}, {n}, {b})))"
    )
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", code.format(tests=str(TESTS), ep=endpoint_, i=i, n=requests, b=batch_every)],
            cwd=ROOT, env=child_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        )
        for i in range(processes)
    ]
    reports = []
    deadline = time.monotonic() + timeout
    for p in procs:
        try:
            stdout, stderr = p.communicate(timeout=max(1.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            for q in procs:
                q.kill()
            raise
        lines = [ln for ln in stdout.splitlines() if ln.startswith("RESULT ")]
        assert p.returncode == 0 and lines, f"load worker failed ({p.returncode}):\n{stderr[-3000:]}"
        reports.append(json.loads(lines[-1][len("RESULT "):]))
    return reports


def prime_states(client: Any, mover_id: int, seen: Any, timeout: float = 10.0) -> int:
    """Make sure a state subscription is live: zero moves until one is seen.

    `seen()` returns the states received so far. Returns the mover's seq
    after priming; every later state must then arrive.
    """
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        st = client.move(mover_id, offset=(0.0, 0.0, 0.0))
        if wait_until(lambda seq=st.seq: any(x.seq == seq for x in seen()), timeout=0.2):
            return int(st.seq)
    raise AssertionError("the state subscription never went live")


def wait_until(predicate: Any, timeout: float = 10.0, interval: float = 0.02) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(interval)
    return bool(predicate())


class _Payload:
    def __init__(self, data: bytes) -> None:
        self.data = data

    def __len__(self) -> int:  # as zenoh.ZBytes: the node refuses a payload by its length before copying it
        return len(self.data)

    def to_bytes(self) -> bytes:
        return self.data


class _Sample:
    """A reply's sample: its payload."""

    def __init__(self, data: bytes) -> None:
        self.payload = _Payload(data)


class StandInReply:
    """What a client reads of a zenoh.Reply: `ok` (a sample, or None) or `err` (its error's sample)."""

    def __init__(self, ok: bytes | None = None, err: bytes | None = None) -> None:
        self.ok = None if ok is None else _Sample(ok)
        self.err = None if err is None else _Sample(err)


class StandInQuery:
    """What the node's query callback uses of a zenoh.Query; keeps what it was answered."""

    def __init__(self, key: str, content: dict[str, Any]) -> None:
        self.key_expr = key
        self.payload = _Payload(msgpack.packb(content, use_bin_type=True))
        self.ok: list[Any] = []
        self.err: list[Any] = []
        self.dropped = 0

    def reply(self, _key: Any, payload: bytes) -> None:
        self.ok.append(msgpack.unpackb(payload, raw=False, strict_map_key=False))

    def reply_err(self, payload: bytes) -> None:
        self.err.append(msgpack.unpackb(payload, raw=False, strict_map_key=False))

    def drop(self) -> None:
        self.dropped += 1
