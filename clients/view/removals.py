"""How the live map learns that a mover is gone: it asks the service about movers that fell quiet.

A remove publishes nothing (docs/protocol.md, "Remove" and "State
publication"), so the view asks: a mover that has published no State for
`QUIET_S` is looked for with the protocol's documented search, a `get` on
`P/lb/*/get` to every instance (`Client.find`). When the instances answer
`unknown_mover` twice in a row (a second time `RETRY_S` later, so that a
mover caught between two instances in a hand-over is not dropped), the
board forgets it and the page drops it from the map and the list. A mover
still held is asked after again only every `RECHECK_S`; no answer at all
(the service away) changes nothing. At most `PER_ROUND` movers are asked
per round, so that a service with many idle movers is not flooded.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

from clients.view.board import MoverBoard

__all__ = ["PER_ROUND", "QUIET_S", "RECHECK_S", "RETRY_S", "ROUND_S", "RemovalWatch", "held_by_service"]

log = logging.getLogger("acphys.view")

QUIET_S = 3.0  # a mover silent this long is asked after
RETRY_S = 1.0  # after one "not held": ask again this soon
RECHECK_S = 15.0  # a mover found held is asked after again this much later
ROUND_S = 1.0  # between rounds
PER_ROUND = 20  # movers asked per round at most

#: ask(mover id) -> True: held; False: every instance that answered holds no such mover; None: no answer
Ask = Callable[[int], bool | None]


def held_by_service(client: object) -> Ask:
    """`ask` for a `clients.Client`: its `find` (a get to every instance)."""
    from service.protocol.wire import ErrorKind

    from clients.client import Client
    from clients.errors import AcphysError, ServiceError

    assert isinstance(client, Client)

    def ask(mover_id: int) -> bool | None:
        try:
            client.find(mover_id, timeout=1.0)
            return True
        except ServiceError as e:
            return False if e.kind == ErrorKind.UNKNOWN_MOVER else None
        except AcphysError:  # no instance answered, or not in time
            return None

    return ask


@dataclass(slots=True)
class _Asked:
    received: float  # the State it was asked about (a newer one starts over)
    misses: int
    next_at: float


class RemovalWatch:
    """Asks after quiet movers and makes the board forget those the service no longer holds."""

    def __init__(self, board: MoverBoard, ask: Ask) -> None:
        self.board = board
        self.ask = ask
        self._asked: dict[str, _Asked] = {}
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def run_once(self, now: float) -> list[str]:
        """One round at wall-clock time `now` (the board's `received` clock): the ids forgotten."""
        quiet = self.board.quiet(now, QUIET_S)
        present = {k for k, _ in quiet}
        for k in [k for k in self._asked if k not in present]:  # it spoke again, or is gone already
            del self._asked[k]
        due = []
        for key, received in quiet:
            a = self._asked.get(key)
            if a is None or a.received != received:
                a = self._asked[key] = _Asked(received, 0, now)
            if a.next_at <= now:
                due.append((a.next_at, key, a))
        due.sort()
        dropped = []
        for _, key, a in due[:PER_ROUND]:
            held = self.ask(int(key, 16))
            if held is None:
                a.next_at = now + RETRY_S
            elif held:
                a.misses, a.next_at = 0, now + RECHECK_S
            else:
                a.misses += 1
                a.next_at = now + RETRY_S
                if a.misses >= 2 and self.board.forget(key, received=a.received):
                    del self._asked[key]
                    dropped.append(key)
        return dropped

    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="acphys-view-removals", daemon=True)
        self._thread.start()

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5.0)

    def _run(self) -> None:
        while not self._stop.wait(ROUND_S):
            try:
                for key in self.run_once(time.time()):
                    log.info("mover %s is no longer held by the service: dropped from the map", key)
            except Exception:  # the view keeps showing what it has
                log.exception("asking the service after quiet movers failed")
