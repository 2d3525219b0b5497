"""The pieces every service benchmark shares: child processes, their reports, and the scenes they serve.

`Child` starts a subprocess (a service, an echo, a worker) on this checkout (or another checkout's engine,
`engine_root`) and stops it; `free_port` gives a loopback port nobody listens on; `collect_reports` reads
each worker process's `RESULT {json}` line; `process_tree_cpu_seconds` reads a process's CPU time from /proc;
`stop_event` is what a child (an echo, a bare queryable) serves until.
The scenes: `scene_file` (flat terrain around landblock A9B4, written under the output directory),
`demo_scene` (the client demo's world), `start_position` (mover i's spot on a 15 m grid) and `bench_walker`
(the mover every benchmark registers).

Used by benchmarks/bench_service.py, bench_batches.py, bench_spanning.py and the other benchmarks that run
the service; it imports none of them.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import threading
import time
from pathlib import Path
from typing import Any

from . import common

__all__ = ["Child", "START_TIMEOUT", "bench_walker", "child_env", "collect_reports", "demo_scene", "free_port", "interrupt",
           "process_tree_cpu_seconds", "scene_file", "start_position"]

#: seconds a child has to print its ready marker
START_TIMEOUT = 30.0


def free_port() -> int:
    """A loopback TCP port nobody listens on now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def child_env(engine_root: Path | None = None) -> dict[str, str]:
    """The environment of a child: the repo on the path (after `engine_root`, whose engine then wins)."""
    env = dict(os.environ)
    first = [str(engine_root)] if engine_root is not None else []
    env["PYTHONPATH"] = os.pathsep.join([*first, str(common.ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    env["PYTHONUNBUFFERED"] = "1"
    return env


def _proc_cpu_seconds(pid: int) -> float:
    with open(f"/proc/{pid}/stat", encoding="ascii") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def process_tree_cpu_seconds(pid: int) -> float:
    """user + system CPU time of `pid` and of its children that are still running (read from /proc)."""
    total = _proc_cpu_seconds(pid)
    try:
        with open(f"/proc/{pid}/task/{pid}/children", encoding="ascii") as f:
            children = [int(c) for c in f.read().split()]
    except OSError:  # a kernel without the children file: the parent alone
        children = []
    for child in children:
        try:
            total += _proc_cpu_seconds(child)
        except OSError:  # it exited meanwhile
            pass
    return total


class Child:
    """A subprocess that prints `marker` when ready; stopped by SIGINT, then killed."""

    def __init__(self, args: list[str], marker: str, engine_root: Path | None = None) -> None:
        # `python -m` puts the working directory first on the path: the engine copy's root when given
        self.proc = subprocess.Popen(args, cwd=engine_root or common.ROOT, env=child_env(engine_root),
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        self.output: list[str] = []
        ready = threading.Event()

        def pump() -> None:
            assert self.proc.stdout is not None
            for line in self.proc.stdout:
                self.output.append(line)
                if marker in line:
                    ready.set()

        threading.Thread(target=pump, daemon=True).start()
        deadline = time.monotonic() + START_TIMEOUT
        while not ready.wait(0.05):
            if self.proc.poll() is not None or time.monotonic() > deadline:
                self.stop()
                raise RuntimeError(f"{args[:4]} did not start:\n" + "".join(self.output[-30:]))

    def cpu_seconds(self) -> float:
        """user + system CPU time so far of the process and its live children (`--workers`' engines)."""
        return process_tree_cpu_seconds(self.proc.pid)

    def stop(self) -> None:
        interrupt(self.proc)


def stop_event() -> threading.Event:
    """An event SIGINT or SIGTERM sets (the service's own `stop_on_signals`): a benchmark's child process
    serves until it is set, as `Child.stop` asks."""
    import logging

    from service.command import stop_on_signals

    return stop_on_signals(logging.getLogger("acphys.bench"), "stopping")


def interrupt(proc: subprocess.Popen[str]) -> None:
    """Stop a service as Ctrl-C does (SIGINT: it drains and exits); killed if it has not within 15 s."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(15)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(10)


def collect_reports(procs: list[subprocess.Popen[str]], timeout: float, what: str) -> list[dict[str, Any]]:
    """Each worker process's `RESULT {json}` line, in order; every one killed if any overruns `timeout`."""
    reports = []
    for p in procs:
        try:
            out, err = p.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            for q in procs:
                q.kill()
            raise
        lines = [ln for ln in out.splitlines() if ln.startswith("RESULT ")]
        if p.returncode != 0 or not lines:
            raise RuntimeError(f"{what} failed ({p.returncode}):\n{err[-2000:]}")
        reports.append(json.loads(lines[-1][7:]))
    return reports


# -- the scenes the services serve ---------------------------------------------------------------------
def scene_file() -> Path:
    """A flat terrain scene around the benchmark landblock, written under the output directory."""
    from .scenes import around, flat_heights, terrain_scene

    common.OUT.mkdir(parents=True, exist_ok=True)
    path = common.OUT / "bench-service-flat.json"
    path.write_text(json.dumps(terrain_scene("bench-service-flat", flat_heights, around())))
    return path


def start_position(index: int, lb: int | None = None) -> Any:
    """Mover `index`'s start, in landblock `lb` (XXYY; default the scene's centre)."""
    from engine.geometry import Position, Vec3

    from .scenes import LB, cell_at

    block = LB if lb is None else lb << 16
    x, y = 20.0 + 15.0 * (index % 10), 20.0 + 15.0 * (index // 10)
    return Position.at(cell_at(block, x, y), Vec3(x, y, 50.0))


def bench_walker() -> Any:
    """The mover every service benchmark registers (the player's shape)."""
    from .scenes import PLAYER

    return PLAYER


def demo_scene() -> Path:
    """The client demo's world (clients/demo/demo.json)."""
    return common.ROOT / "clients" / "demo" / "demo.json"
