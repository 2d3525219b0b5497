"""The service's instances in the client library: Client.load_landblock / unload_landblock on a landblock's
owner, and the calls every instance answers, landblocks, health, stats and wait_ready (docs/protocol.md,
"List", "Health", "Stats").

A question to every instance is one query on a key they all serve, with every reply gathered; a client
whose session is younger than SETTLE_S (clients/client.py) first waits until it has met them all.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from service.protocol.wire import Keys

from clients.errors import RequestTimeout
from clients.request_channel import unpack_message
from clients.types import InstanceInfo

__all__ = ["InstanceCalls"]


class InstanceCalls:
    """The calls to the instances, mixed into `Client` (which gives them its keys, its request plumbing and
    the wait for a young session to meet the cluster): call them on a Client."""

    keys: Keys
    _request: Callable[..., dict[str, Any]]
    _replies_of_all: Callable[..., list[Any]]
    _settle: Callable[[], bool]

    def _all(self, key: str, timeout: float | None, settle: bool = True) -> list[InstanceInfo]:
        """Every instance's answer on `key`; `settle`: first wait until the session has met them all."""
        if settle:
            self._settle()
        out = []
        for r in self._replies_of_all(key, {}, timeout):
            if r.ok is None:
                continue
            msg = unpack_message(r.ok.payload.to_bytes())
            if isinstance(msg, dict):
                out.append(InstanceInfo(str(msg.get("instance", "?")), msg))
        return out

    def load_landblock(self, lb: int, timeout: float | None = None) -> bool:
        """Load landblock `lb` (0xXXYY, e.g. 0xA9B5) on the instance that owns it; True when it was loaded
        already. Raises ServiceError: `landblock_unavailable` (its source has no such landblock),
        `forbidden` (with accounts, for a user who is not an `--admin`); NoServiceError when no instance
        owns it; RequestTimeout."""
        return bool(self._request(self.keys.lb(lb, "load"), {}, timeout).get("already"))

    def unload_landblock(self, lb: int, timeout: float | None = None) -> None:
        """Unload landblock `lb` (0xXXYY) on its owner. Raises ServiceError: `landblock_in_use` while
        movers are in it (`details["movers"]` lists them), `landblock_not_loaded`, `forbidden` (with
        accounts, for a user who is not an `--admin`); NoServiceError, RequestTimeout. A world served
        from a scene file cannot load it again."""
        self._request(self.keys.lb(lb, "unload"), {}, timeout)

    def landblocks(self, timeout: float | None = None) -> list[InstanceInfo]:
        """Every instance's owned and loaded landblocks: one `InstanceInfo` per instance that answered
        within `timeout` seconds, with `owned` (`"*"`, a list of 0xXXYY landblocks, or an x range) and
        `loaded` (docs/protocol.md, "List"). An empty list when none answered; raises nothing of its
        own. A client younger than half a second first waits until it is that old (SETTLE_S): a new session
        meets a cluster's other instances some 0.1 s after it connects, and would miss their answers."""
        return self._all(self.keys.landblocks, timeout)

    def health(self, timeout: float | None = None) -> list[InstanceInfo]:
        """Every instance's Health: one `InstanceInfo` per instance that answered within `timeout`
        seconds, with `status` ("ok", "draining", "degraded"), `protocol`, `movers`, `queue_depth`,
        `move_forms`, `queries`, ... (docs/protocol.md, "Health"). An empty list when none answered. A client younger than half a second first waits until it is that old (SETTLE_S): a new session
        meets a cluster's other instances some 0.1 s after it connects, and would miss their answers."""
        return self._all(self.keys.health, timeout)

    def stats(self, timeout: float | None = None) -> list[InstanceInfo]:
        """Every instance's Stats: one `InstanceInfo` per instance that answered within `timeout`
        seconds, with `requests` and `errors` counted by kind, `moves`, `latency_ms`, `engine_ms`
        (milliseconds), `loaded_landblocks`, ... (docs/protocol.md, "Stats"). An empty list when none
        answered. A client younger than half a second first waits until it is that old (SETTLE_S): a new session
        meets a cluster's other instances some 0.1 s after it connects, and would miss their answers."""
        return self._all(self.keys.stats, timeout)

    def wait_ready(self, instances: int = 1, timeout: float = 10.0) -> list[InstanceInfo]:
        """Block until `instances` instances answer on the health key with status "ok"; their Health.
        Raises RequestTimeout when fewer did within `timeout` seconds (asking again every 50 ms)."""
        deadline = time.monotonic() + timeout
        while True:  # asked at once and again: the count wanted says when every instance has been met
            found = [h for h in self._all(self.keys.health, 1.0, settle=False) if h.get("status") == "ok"]
            if len(found) >= instances:
                return found
            if time.monotonic() >= deadline:
                raise RequestTimeout(f"{len(found)} of {instances} service instance(s) ready after {timeout} s")
            time.sleep(0.05)
