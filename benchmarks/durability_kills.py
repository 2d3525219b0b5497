"""Killing a loaded `acphys serve --state` at random moments and checking what comes back.

One run: an instance on a free loopback port with `--state FILE --state-sync POLICY`, a dozen movers on
the demo world, and one client sending requests one after the other (single steps and offset moves,
map batches, column batches; steps shorter than a quantum, so time is held over). Every request is
applied first to a mirror: a ServiceCore of its own over the same scene, which resolves it exactly as
the service does, and keeps each mover's whole engine state after every request. At a random moment
the instance gets SIGKILL; it is started again and the movers it restores (the state file its start
wrote, and a Get of each) are checked against the mirror and the answers the client had:

- every policy: each mover's restored state is bit for bit one the mover had at the end of a request
  (nothing invented, nothing half-applied), and together they are one prefix of the requests sent
  (every request before some point, none after); no mover is missing or duplicated; the first move
  after the restart answers a seq above every seq ever answered;
- `always`: nothing answered is lost (each mover is at its last answered State, or one request on when
  a request was in flight at the kill);
- `every-second` and `never`: nothing answered more than WINDOW_S before the kill is lost.

The mirror then restores the same movers (as the service's start does) and the run goes on: the
checks of the next kill start from there. tests/service/persistence/test_durability_kills.py runs a few kills per policy;
benchmarks/bench_durability.py many more.
"""

from __future__ import annotations

import os
import random
import signal
import struct
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from clients import Client, Move
from clients.demo.world import global_to_cell
from clients.errors import AcphysError
from engine import load_scene
from engine.geometry import Position, Vec3
from engine import MoverSpec, SphereSpec

from .standins import SilentBus
from service.column_moves import run_columns
from service.protocol.column_request import parse_column_request
from service.core import ServiceCore
from service.persistence.journal import DEFAULT_BUDGET
from service.persistence.journal_records import mover_state_bytes
from service.protocol.messages import RegisterRequest
from service.ownership import Ownership
from service.protocol.requests import MoveItem, parse_moves
from service.persistence.state_file import SavedMover, read_state, restore
from service.stats import ServiceStats

__all__ = ["WINDOW_S", "KillRun", "Service", "run_kills"]

ROOT = Path(__file__).resolve().parent.parent
DEMO_SCENE = ROOT / "clients" / "demo" / "demo.json"
#: every-second's promise as checked: the log's thread syncs each second; one more second for the sync
#: itself and a loaded machine's scheduling
WINDOW_S = 2.0
#: demo-global places on open ground in landblock A9B4, far enough apart that the movers never meet
SPOTS = [(20.0 + 30.0 * (k % 5), 20.0 + 40.0 * (k // 5)) for k in range(12)]
START_TIMEOUT = 60.0


def player_spec() -> MoverSpec:
    return MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.48), 0.48), SphereSpec((0.0, 0.0, 1.35), 0.48)],
                     step_up_height=0.6, step_down_height=0.4, state=["IsPlayer"])


class Mirror:
    """The same requests resolved by a core of its own; each mover's engine state after every request."""

    def __init__(self) -> None:
        self.core = self._new_core()
        #: mover -> seq -> (its whole engine state, the index of the request that left it there)
        self.history: dict[int, dict[int, tuple[bytes, int]]] = {}
        self.requests = 0

    @staticmethod
    def _new_core() -> ServiceCore:
        return ServiceCore(load_scene(str(DEMO_SCENE)), SilentBus(), ownership=Ownership(), instance="mirror",
                           stats=ServiceStats())

    def _keep(self, ids: list[int]) -> dict[int, int]:
        r = self.requests
        self.requests += 1
        seqs = {}
        for mover_id in dict.fromkeys(ids):
            rec = self.core.movers[mover_id]
            mover = self.core.world.movers[rec.engine_id]
            self.history.setdefault(mover_id, {})[rec.seq] = (mover_state_bytes(mover), r)
            seqs[mover_id] = rec.seq
        return seqs

    def register(self, mover_id: int, position: Position) -> dict[int, int]:
        self.core.register(RegisterRequest(mover_id, player_spec(), position, None, None))
        return self._keep([mover_id])

    def single(self, mover_id: int, kind: str, v: tuple[float, float, float], dt: float) -> dict[int, int]:
        item = (MoveItem("move", mover_id, None, motion=Vec3(*v), dt=dt) if kind == "step"
                else MoveItem("move", mover_id, None, offset=Vec3(*v)))
        self.core.move_one(item, 0.0)
        return self._keep([mover_id])

    def map_batch(self, ids: list[int], motions: list[tuple[float, float, float]], dt: float) -> dict[int, int]:
        batch = parse_moves({"v": 1, "moves": [{"id": i, "motion": list(m), "dt": dt} for i, m in zip(ids, motions)]})
        self.core.moves(batch, 0.0)
        return self._keep(ids)

    def columns(self, ids: list[int], motions: list[tuple[float, float, float]], dt: float) -> dict[int, int]:
        n = len(ids)
        flat = [x for m in motions for x in m]
        msg = {"v": 1, "kind": "motion", "columns": {
            "id": struct.pack(f"<{n}Q", *ids), "motion": struct.pack(f"<{3 * n}d", *flat),
            "dt": struct.pack(f"<{n}d", *([dt] * n))}}
        run_columns(self.core, parse_column_request(msg), 0.0)
        return self._keep(ids)

    def restart(self, saved: list[SavedMover], jump: int) -> None:
        """Restore `saved` into a new core, as the service's start does; their states join the history."""
        self.core = self._new_core()
        restore(self.core, saved, "mirror")
        for m in saved:
            s_log = m.handover.seq - jump
            # the moves after s_log are lost (or were never answered): their seqs will be given again
            hist = {s: v for s, v in self.history[m.handover.id].items() if s <= s_log}
            assert s_log in hist and m.engine_state is not None
            hist[m.handover.seq] = (m.engine_state, hist[s_log][1])
            self.history[m.handover.id] = hist


@dataclass(slots=True)
class Ack:
    seq: int
    at: float  # monotonic time the answer came


@dataclass(slots=True)
class KillRun:
    """What a run of kills found."""

    policy: str
    kills: int = 0
    requests: int = 0
    moves_answered: int = 0
    #: per kill: moves answered but not restored, and the age at the kill of the oldest of them (s)
    lost_moves: list[int] = field(default_factory=list)
    lost_age_s: list[float] = field(default_factory=list)
    #: per kill: seconds from the kill to the restarted instance's first answer
    restart_s: list[float] = field(default_factory=list)
    violations: list[str] = field(default_factory=list)


class Service:
    """`python -m service` on the demo world on a free loopback port; with `state`, `--state` and the policy."""

    def __init__(self, state: Path | None, policy: str, engine_root: Path | None = None,
                 interval: float = 3600.0) -> None:
        import socket

        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
            s.bind(("127.0.0.1", 0))
            port = int(s.getsockname()[1])
        self.endpoint = f"tcp/127.0.0.1:{port}"
        env = dict(os.environ)
        first = [str(engine_root)] if engine_root is not None else []
        env["PYTHONPATH"] = os.pathsep.join([*first, str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
        env["PYTHONUNBUFFERED"] = "1"
        self.args = [sys.executable, "-m", "service", "--scene", str(DEMO_SCENE), "--listen", self.endpoint,
                     "--log-level", "WARNING"]
        if state is not None:
            self.args += ["--state", str(state), "--state-sync", policy, "--state-interval", str(interval)]
        self.env, self.cwd = env, engine_root or ROOT
        self.proc: subprocess.Popen[str] | None = None
        self.output: list[str] = []

    def start(self) -> None:
        self.output = []
        self.proc = subprocess.Popen(self.args, cwd=self.cwd, env=self.env, stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True)
        ready = threading.Event()
        proc = self.proc

        def pump() -> None:
            assert proc.stdout is not None
            for line in proc.stdout:
                self.output.append(line)
                if "acphys service ready" in line:
                    ready.set()

        threading.Thread(target=pump, daemon=True).start()
        deadline = time.monotonic() + START_TIMEOUT
        while not ready.wait(0.05):
            if proc.poll() is not None or time.monotonic() > deadline:
                self.kill()
                raise RuntimeError("the service did not start:\n" + "".join(self.output[-30:]))

    def cpu_seconds(self) -> float:
        """The process's user + system CPU time so far (all its threads), from /proc."""
        assert self.proc is not None
        with open(f"/proc/{self.proc.pid}/stat", encoding="ascii") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

    def kill(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGKILL)
            self.proc.wait(10)

    def stop(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(20)
            except subprocess.TimeoutExpired:
                self.kill()


def _load(c: Client, mirror: Mirror, rng: random.Random, acked: dict[int, list[Ack]], inflight: dict[int, int],
          stop: threading.Event, run: KillRun) -> None:
    """Requests one after the other until one fails (the kill) or `stop`."""
    ids = sorted(acked)
    while not stop.is_set():
        op = rng.random()
        sign = 1.0 if rng.random() < 0.5 else -1.0
        dt = rng.choice((0.2, 0.1, 0.02))  # 0.02 s is short of a quantum: held over with its motion
        if op < 0.4:
            chosen = [rng.choice(ids)]
            call = "step" if rng.random() < 0.7 else "offset"
            v = (0.0, 0.5 * sign, 0.0) if call == "step" else (0.3 * sign, 0.0, 0.0)
            expect = mirror.single(chosen[0], call, v, dt)
        else:
            chosen = rng.sample(ids, rng.randint(2, len(ids)))
            if rng.random() < 0.3:
                chosen.append(chosen[0])  # one mover twice: it moves twice, the second time from the first's end
            motions = [(0.0, 0.4 * sign, 0.0)] * len(chosen)
            call = "map" if op < 0.7 else "columns"
            expect = (mirror.map_batch if call == "map" else mirror.columns)(chosen, motions, dt)
        inflight.clear()
        inflight.update(expect)  # sent: applied or not, until answered
        try:
            if call == "step":
                got = _answered([c.step(chosen[0], v, dt)], chosen)
            elif call == "offset":
                got = _answered([c.move(chosen[0], offset=v)], chosen)
            elif call == "map":
                got = _answered(c.move_many([Move(i, motion=m, dt=dt) for i, m in zip(chosen, motions)]), chosen)
            else:
                out = c.move_batch(np.array(chosen, dtype=np.uint64), motions=np.array(motions), dt=dt)
                got = None if out.errors else {int(i): int(q) for i, q in zip(chosen, out.seq)}
        except AcphysError:
            return  # the kill: the request stays in flight
        if got is None:
            return
        now = time.monotonic()
        for mover_id, seq in got.items():
            if expect.get(mover_id) != seq:
                run.violations.append(f"the service answered mover {mover_id:X} seq {seq}, the mirror "
                                      f"{expect.get(mover_id)}")
            acked[mover_id].append(Ack(seq, now))
        inflight.clear()
        run.requests += 1
        run.moves_answered += len(chosen)


def _answered(states: list[Any], ids: list[int]) -> dict[int, int] | None:
    """The last seq answered for each mover of a reply's States; None when one failed."""
    from clients import MoverState

    if any(not isinstance(s, MoverState) for s in states):
        return None
    return {s.id: s.seq for s in states}


def run_kills(policy: str, kills: int, seed: int = 1, engine_root: Path | None = None,
              load_s: tuple[float, float] = (0.3, 1.5), workdir: Path | None = None) -> KillRun:
    """`kills` rounds of load, SIGKILL at a random moment, restart and checks (see the module's docstring)."""
    rng = random.Random(seed)
    run = KillRun(policy)
    jump = 0 if policy == "always" else DEFAULT_BUDGET + 1
    with tempfile.TemporaryDirectory(prefix="acphys-kills-", dir=workdir) as tmp:
        state = Path(tmp) / "movers.state"
        svc = Service(state, policy, engine_root)
        mirror = Mirror()
        acked: dict[int, list[Ack]] = {}
        svc.start()
        try:
            with Client([svc.endpoint], timeout=5.0) as c:
                c.wait_ready()
                for k, (gx, gy) in enumerate(SPOTS):
                    cell, x, y = global_to_cell(gx, gy)
                    pos = Position.at(cell, Vec3(x, y, mirror.core.world.terrain_height(cell, x, y) + 0.5))
                    mover_id = 0xD000 + k
                    mirror.register(mover_id, pos)
                    st = c.register(player_spec(), pos, mover_id=mover_id)
                    acked[mover_id] = [Ack(st.seq, time.monotonic())]
            if policy != "always":
                time.sleep(WINDOW_S)  # the registers are past the window: every kill must keep every mover
            for _k in range(kills):
                _one_kill(svc, state, mirror, acked, rng, run, jump, load_s)
                if run.violations:
                    break  # what follows would start from a wrong place
        finally:
            svc.stop()
    return run


def _one_kill(svc: Service, state: Path, mirror: Mirror, acked: dict[int, list[Ack]], rng: random.Random,
              run: KillRun, jump: int, load_s: tuple[float, float]) -> None:
    inflight: dict[int, int] = {}
    stop = threading.Event()
    with Client([svc.endpoint], timeout=3.0) as c:
        c.wait_ready()
        loader = threading.Thread(target=_load, args=(c, mirror, rng, acked, inflight, stop, run), daemon=True)
        loader.start()
        time.sleep(rng.uniform(*load_s))
        svc.kill()
        killed_at = time.monotonic()
        stop.set()
        loader.join(30.0)
    run.kills += 1
    svc.start()
    saved = read_state(state) or []  # the start compacted: the file holds what it restored
    _check(saved, mirror, acked, inflight, killed_at, run, jump)
    if run.violations:
        return
    with Client([svc.endpoint], timeout=5.0) as c:
        c.wait_ready()
        run.restart_s.append(time.monotonic() - killed_at)
        for m in saved:
            got, _spec = c.get(m.handover.id)
            if got.seq != m.handover.seq:
                run.violations.append(f"mover {m.handover.id:X}: Get answers seq {got.seq}, the file {m.handover.seq}")
    mirror.restart(saved, jump)
    for m in saved:  # the restored State is the mover's latest: the next answer follows it
        acked[m.handover.id] = [Ack(m.handover.seq, time.monotonic())]


def _check(saved: list[SavedMover], mirror: Mirror, acked: dict[int, list[Ack]], inflight: dict[int, int],
           killed_at: float, run: KillRun, jump: int) -> None:
    by_id = {m.handover.id: m for m in saved}
    if len(by_id) != len(saved) or sorted(by_id) != sorted(acked):
        run.violations.append(f"restored movers {sorted(by_id)} (with duplicates: {len(saved) - len(by_id)}), "
                              f"expected {sorted(acked)}")
    applied: list[int] = []  # the request that left each mover where it is
    following: list[int] = []  # the next request that moved it (or none)
    lost, oldest = 0, 0.0
    for mover_id, m in by_id.items():
        hist = mirror.history.get(mover_id, {})
        s_log = m.handover.seq - jump
        had = hist.get(s_log)
        if had is None or had[0] != m.engine_state:
            run.violations.append(f"mover {mover_id:X}: restored seq {s_log} is not a state it had at the end of a "
                                  f"request ({'no such seq' if had is None else 'different engine state'})")
            continue
        applied.append(had[1])
        later = [r for s, (_b, r) in hist.items() if s > s_log and r > had[1]]
        if later:
            following.append(min(later))
        acks = acked[mover_id]
        last = acks[-1].seq
        lost_acks = [a for a in acks if a.seq > s_log]
        if lost_acks:
            lost += last - s_log
            oldest = max(oldest, killed_at - lost_acks[0].at)
        if run.policy == "always" and s_log < last:
            run.violations.append(f"mover {mover_id:X}: answered seq {last}, restored {s_log} (always loses nothing)")
        if s_log > max(last, inflight.get(mover_id, last)):
            run.violations.append(f"mover {mover_id:X}: restored seq {s_log} beyond any sent ({last})")
        if run.policy != "always":
            old_enough = [a.seq for a in acks if a.at <= killed_at - WINDOW_S]
            if old_enough and s_log < max(old_enough):
                run.violations.append(f"mover {mover_id:X}: seq {max(old_enough)}, answered more than {WINDOW_S} s "
                                      f"before the kill, is lost (restored {s_log})")
    if applied and following and max(applied) >= min(following):
        run.violations.append(f"the restored movers are not one prefix of the requests: one is at request "
                              f"{max(applied)}, another misses request {min(following)}")
    run.lost_moves.append(lost)
    run.lost_age_s.append(oldest)
