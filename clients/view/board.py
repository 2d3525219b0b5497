"""The live map's picture of the movers: the latest State of each, fed by the service's publications.

`MoverBoard` subscribes (through a Zenoh session) to `P/obj/*/state` and
`P/states`, keeps each mover's newest State (by `seq`), and hands every new
one to the web page's listeners (asyncio queues of the server's event loop)
as a `state` event. A mover the service no longer holds is forgotten
(`forget`, called by `clients.view.removals`) and the page told with a
`removed` event. States go to the page as JSON with the mover id also in hex
(`id_hex`): ids are 64-bit and JavaScript numbers are not.
"""

from __future__ import annotations

import asyncio
import json
import logging
import threading
import time
from typing import Any

import msgpack

from service.protocol.wire import Keys

from clients.client import Subscription

__all__ = ["MoverBoard", "PageEvent", "state_for_page"]

log = logging.getLogger("acphys.view")

_QUEUE_LIMIT = 2048  # a listener this far behind loses states (the page catches up with the next ones)

#: what a page listener gets: (event name, JSON text): ("state", State) or ("removed", {"id": hex})
PageEvent = tuple[str, str]


def state_for_page(state: dict[str, Any]) -> dict[str, Any]:
    """A State map made safe for JSON and JavaScript: ids as hex strings, a receive time."""
    out = dict(state)
    out["id"] = f"{int(state['id']):X}"
    out["id_hex"] = out["id"]
    pos = state.get("position")
    if isinstance(pos, dict) and isinstance(pos.get("cell"), int):
        out["cell_hex"] = f"{pos['cell']:08X}"
    out["collide_objects"] = [f"{int(i):X}" for i in state.get("collide_objects") or []]
    out["received"] = time.time()
    return out


class MoverBoard:
    """Latest State per mover, and the page listeners to tell of each new one."""

    def __init__(self, session: Any, prefix: str) -> None:
        self.keys = Keys(prefix)
        self._session = session
        self._states: dict[str, dict[str, Any]] = {}
        self._seq: dict[str, int] = {}  # kept after a mover is forgotten: an older State arriving late stays out
        self._lock = threading.Lock()
        self._listeners: set[asyncio.Queue[PageEvent]] = set()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._subs = Subscription([])
        self.received = 0

    # -- the bus side (Zenoh's callback threads) ---------------------------------------
    def start(self) -> None:
        self._subs = Subscription([self._session.declare_subscriber(self.keys.state("*"), self._on_state),
                                   self._session.declare_subscriber(self.keys.states, self._on_states)])

    def close(self) -> None:
        self._subs.close()

    def _on_state(self, sample: Any) -> None:
        try:
            self.offer(msgpack.unpackb(sample.payload.to_bytes(), raw=False, strict_map_key=False)["state"])
        except Exception:
            log.warning("unreadable state on %s", sample.key_expr)

    def _on_states(self, sample: Any) -> None:
        try:
            states = msgpack.unpackb(sample.payload.to_bytes(), raw=False, strict_map_key=False)["states"]
        except Exception:
            log.warning("unreadable states on %s", sample.key_expr)
            return
        for st in states:
            try:
                self.offer(st)
            except Exception:
                log.warning("unreadable state in a batch on %s", sample.key_expr)

    def offer(self, state: dict[str, Any]) -> bool:
        """Take a State map; True when it is news (not older than what the board has for that mover)."""
        page = state_for_page(state)
        key, seq = page["id"], int(state.get("seq", 0))
        with self._lock:
            last = self._seq.get(key, -1)
            # a forgotten mover comes back only with a newer State (it was there after all)
            if seq < last or (seq == last and key not in self._states):
                return False
            self._seq[key] = seq
            self._states[key] = page
            self.received += 1
        self._tell("state", json.dumps(page))
        return True

    def forget(self, key: str, received: float | None = None) -> bool:
        """Drop mover `key` (hex id): the service no longer holds it. With `received`, only if its
        latest State is still the one received then (no newer one came meanwhile). True when dropped."""
        with self._lock:
            st = self._states.get(key)
            if st is None or (received is not None and st["received"] != received):
                return False
            del self._states[key]
        self._tell("removed", json.dumps({"id": key}))
        return True

    def quiet(self, now: float, quiet_s: float) -> list[tuple[str, float]]:
        """(hex id, time received) of every mover whose latest State is at least `quiet_s` old at `now`."""
        with self._lock:
            return [(k, st["received"]) for k, st in self._states.items() if now - st["received"] >= quiet_s]

    def _tell(self, event: str, text: str) -> None:
        with self._lock:
            loop, listeners = self._loop, list(self._listeners)
        if loop is not None and listeners:
            for q in listeners:
                loop.call_soon_threadsafe(_put, q, (event, text))

    # -- the page side (the server's event loop) ---------------------------------------
    def snapshot(self) -> list[dict[str, Any]]:
        with self._lock:
            return list(self._states.values())

    def listen(self) -> asyncio.Queue[PageEvent]:
        q: asyncio.Queue[PageEvent] = asyncio.Queue(maxsize=_QUEUE_LIMIT)
        with self._lock:
            self._loop = asyncio.get_running_loop()
            self._listeners.add(q)
        return q

    def unlisten(self, q: asyncio.Queue[PageEvent]) -> None:
        with self._lock:
            self._listeners.discard(q)


def _put(q: asyncio.Queue[PageEvent], item: PageEvent) -> None:
    try:
        q.put_nowait(item)
    except asyncio.QueueFull:
        pass
