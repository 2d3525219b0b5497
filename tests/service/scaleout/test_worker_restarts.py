"""`serve --workers`: when the parent starts a dead worker again, and when it gives up (no processes here:
a stand-in process that has always just died)."""

from __future__ import annotations

import argparse
from typing import Any

import pytest

from service.ownership import Ownership
from service.scaleout.workers import RESTART_DELAY_MAX, WorkerProcess, WorkerSupervisor, restart_delay


class _DeadProcess:
    """A worker process that has exited with code 1."""

    def __init__(self, pid: int) -> None:
        self.pid = pid
        self.returncode = 1

    def poll(self) -> int:
        return 1


def _supervisor(restarts: int) -> tuple[WorkerSupervisor, WorkerProcess, list[float]]:
    sup = WorkerSupervisor(argparse.Namespace(prefix="acphys", worker_restarts=restarts), 1)
    w = WorkerProcess(0, Ownership(), [])
    w.proc = _DeadProcess(100)  # type: ignore[assignment]
    sup.workers.append(w)
    started: list[float] = []

    def spawn(worker: WorkerProcess, at: list[float] = started) -> None:
        worker.proc = _DeadProcess(101 + len(at))  # type: ignore[assignment]
        at.append(now[0])

    now = [0.0]
    sup._spawn = spawn  # type: ignore[method-assign, assignment]
    sup._now = now  # type: ignore[attr-defined]
    return sup, w, started


def _run(sup: WorkerSupervisor, until: float, tick: float = 0.05) -> None:
    now: list[float] = sup._now  # type: ignore[attr-defined]
    while now[0] <= until:
        sup.watch(now[0])
        now[0] = round(now[0] + tick, 6)


def test_the_delay_doubles_from_half_a_second_up_to_thirty() -> None:
    assert [restart_delay(k) for k in range(8)] == [0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 30.0, 30.0]
    assert RESTART_DELAY_MAX == 30.0


def test_a_worker_dying_at_every_start_is_started_again_after_each_delay_then_given_up() -> None:
    sup, w, started = _supervisor(restarts=3)
    _run(sup, until=60.0)
    # died at 0: started at 0.5; its death is seen at the next look (0.55), started 1.0 s later (1.55);
    # seen dead at 1.6, started 2.0 s later (3.6); the third restart was the last
    assert started == pytest.approx([0.5, 1.55, 3.6])
    assert w.restarts == 3 and w.died and w.proc is not None and w.proc.pid == 103


def test_no_restarts_when_told_none_or_while_stopping() -> None:
    sup, w, started = _supervisor(restarts=0)
    _run(sup, until=5.0)
    assert started == [] and w.died and w.restarts == 0
    sup, w, started = _supervisor(restarts=5)
    sup.draining = True
    _run(sup, until=5.0)
    assert started == [] and not w.died


def test_a_worker_that_comes_back_alive_is_left_alone(monkeypatch: Any) -> None:
    sup, w, started = _supervisor(restarts=5)

    class _Alive(_DeadProcess):
        def poll(self) -> None:  # type: ignore[override]
            return None

    def spawn(worker: WorkerProcess) -> None:
        worker.proc = _Alive(200)  # type: ignore[assignment]
        started.append(sup._now[0])  # type: ignore[attr-defined]

    monkeypatch.setattr(sup, "_spawn", spawn)
    _run(sup, until=10.0)
    assert started == [0.5] and w.restarts == 1 and w.down_since is None
