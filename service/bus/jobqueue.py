"""The engine thread's inbox: bounded lanes for requests, a priority lane.

Requests from the bus go to a bounded lane and are refused when it is
full (the caller replies `busy`): the queue never grows without bound.
Each tenant of a service with accounts (service/security/accounts.py) has a lane of
its own, with the whole capacity, and the engine thread takes the lanes'
requests in turn: one user's flood fills that user's lane only, and waits
its turn behind the others' requests instead of ahead of them. Within a
lane requests run in arrival order. The priority lane carries the
service's own work (hand-over arrivals and replies) which must not be
refused and may be taken while the engine thread waits on a hand-over.
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
        self.capacity = capacity  # of each lane
        self._lanes: list[deque[Job]] = [deque()]  # lane 0 is there from the start
        self._turn = 0  # the lane `get` looks at first
        self._priority: deque[Job] = deque()
        self._cond = threading.Condition()
        #: refusing new requests (`close`); a plain attribute, read by every request without the lock
        self.closed = False
        #: jobs queued and not yet done (see `task_done`); read without the lock by the node's one-move
        #: path (an int read is atomic): 0 is `idle`
        self.unfinished = 0

    def __len__(self) -> int:
        with self._cond:
            return sum(len(lane) for lane in self._lanes) + len(self._priority)

    def new_lane(self) -> int:
        """Another bounded lane (a tenant's); its number, for `offer` and `depth`."""
        with self._cond:
            self._lanes.append(deque())
            return len(self._lanes) - 1

    def depth(self, lane: int) -> int:
        """Requests waiting in one lane."""
        with self._cond:
            return len(self._lanes[lane])

    def offer(self, job: Job, lane: int = 0) -> bool:
        """Queue a request in `lane`; False (nothing queued) when that lane is full or the queue closed."""
        with self._cond:
            queue = self._lanes[lane]
            if self.closed or len(queue) >= self.capacity:
                return False
            queue.append(job)
            self.unfinished += 1
            self._cond.notify()
            return True

    def put_priority(self, job: Job) -> None:
        with self._cond:
            self._priority.append(job)
            self.unfinished += 1
            self._cond.notify()

    def offer_priority(self, job: Job) -> bool:
        """Queue a job on the priority lane unless closed (a request from another instance: once closed,
        the engine thread may already be gone, so it is refused rather than left unanswered)."""
        with self._cond:
            if self.closed:
                return False
            self._priority.append(job)
            self.unfinished += 1
            self._cond.notify()
            return True

    def close(self) -> None:
        """Refuse new requests; what is queued is still handed out."""
        with self._cond:
            self.closed = True
            self._cond.notify_all()

    def task_done(self) -> None:
        """A job handed out by `get`/`get_priority` has finished."""
        with self._cond:
            self.unfinished -= 1

    @property
    def idle(self) -> bool:
        """Every job ever queued has finished (so work done now cannot overtake a queued job)."""
        return not self.unfinished

    def get(self, timeout: float | None = None) -> Job | None:
        """Next job, priority lane first; None on timeout or when closed and empty."""
        deadline = None if timeout is None else time.monotonic() + timeout
        with self._cond:
            while True:
                if self._priority:
                    return self._priority.popleft()
                lanes = self._lanes
                if len(lanes) == 1:  # no tenants: the one lane, without the turn's arithmetic
                    if lanes[0]:
                        return lanes[0].popleft()
                else:
                    for k in range(len(lanes)):  # the lanes in turn, from the one after the last served
                        i = (self._turn + k) % len(lanes)
                        if lanes[i]:
                            self._turn = (i + 1) % len(lanes)
                            return lanes[i].popleft()
                if self.closed:
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
