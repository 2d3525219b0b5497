"""The engine thread's inbox: a bounded lane for requests, a priority lane.

Requests from the bus go to the bounded lane and are refused when it is
full (the caller replies `busy`): the queue never grows without bound.
The priority lane carries the service's own work (hand-over arrivals and
replies) which must not be refused and may be taken while the engine
thread waits on a hand-over.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable

__all__ = ["Job", "JobQueue"]

Job = Callable[[], None]


class JobQueue:
    def __init__(self, capacity: int) -> None:
        if capacity < 1:
            raise ValueError("capacity must be at least 1")
        self.capacity = capacity
        self._normal: deque[Job] = deque()
        self._priority: deque[Job] = deque()
        self._cond = threading.Condition()
        self._closed = False
        self._unfinished = 0  # jobs queued and not yet done (see `task_done`)

    def __len__(self) -> int:
        with self._cond:
            return len(self._normal) + len(self._priority)

    def offer(self, job: Job) -> bool:
        """Queue a request; False (nothing queued) when full or closed."""
        with self._cond:
            if self._closed or len(self._normal) >= self.capacity:
                return False
            self._normal.append(job)
            self._unfinished += 1
            self._cond.notify()
            return True

    def put_priority(self, job: Job) -> None:
        with self._cond:
            self._priority.append(job)
            self._unfinished += 1
            self._cond.notify()

    def offer_priority(self, job: Job) -> bool:
        """Queue a job on the priority lane unless closed (a request from another instance: once closed,
        the engine thread may already be gone, so it is refused rather than left unanswered)."""
        with self._cond:
            if self._closed:
                return False
            self._priority.append(job)
            self._unfinished += 1
            self._cond.notify()
            return True

    def close(self) -> None:
        """Refuse new requests; what is queued is still handed out."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()

    @property
    def closed(self) -> bool:
        return self._closed

    def task_done(self) -> None:
        """A job handed out by `get`/`get_priority` has finished."""
        with self._cond:
            self._unfinished -= 1

    @property
    def idle(self) -> bool:
        """Every job ever queued has finished (so work done now cannot overtake a queued job)."""
        return self._unfinished == 0

    def get(self, timeout: float | None = None) -> Job | None:
        """Next job, priority lane first; None on timeout or when closed and empty."""
        deadline = None if timeout is None else time.monotonic() + timeout
        with self._cond:
            while True:
                if self._priority:
                    return self._priority.popleft()
                if self._normal:
                    return self._normal.popleft()
                if self._closed:
                    return None
                remaining = None if deadline is None else deadline - time.monotonic()
                if remaining is not None and remaining <= 0:
                    return None
                self._cond.wait(remaining)

    def get_priority(self, timeout: float) -> Job | None:
        """Next priority job only (used while the engine thread waits)."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while not self._priority:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    return None
                self._cond.wait(remaining)
            return self._priority.popleft()
