"""When an instance writes its movers to its state file, and how it reads them back at start.

`--state FILE`: restored at start (before any key is declared), written
every `--state-interval` seconds, right after a hand-over in or out (so a
mover that changed instances is not restored on both after a crash), and
at shutdown once every request is answered. A file that cannot be restored
in full stops the start, unless `--state-discard-bad`, which sets the file
aside (renamed, never deleted) and starts empty.
"""

from __future__ import annotations

import argparse
import logging
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import Any
from collections.abc import Callable

import zenoh

from .core import ServiceCore
from .frames import pack
from .wire import Keys
from .state_file import SavedMover, StateFileError, read_state, restore, set_aside, write_state
from .state_layout import user_state_path

__all__ = ["Persistence", "add_state_arguments", "held_elsewhere", "user_state_path"]

log = logging.getLogger("acphys.service")

DEFAULT_INTERVAL = 10.0


def add_state_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("state")
    g.add_argument("--state", metavar="FILE", help="keep the movers in FILE: restored at start, written at "
                   "shutdown, after hand-overs and every --state-interval seconds")
    g.add_argument("--state-interval", type=float, default=DEFAULT_INTERVAL, metavar="S",
                   help="seconds between writes of the state file (default %(default)s; 0: only at shutdown "
                        "and after hand-overs)")
    g.add_argument("--state-discard-bad", action="store_true",
                   help="start empty when the state file cannot be restored (it is renamed aside, not deleted)")


@dataclass(slots=True)
class Persistence:
    path: str | None = None
    interval: float = DEFAULT_INTERVAL
    discard_bad: bool = False
    _last_save: float = field(default_factory=time.monotonic)
    _handovers_saved: int = 0
    _saved: list[SavedMover] | None = None  # read at start, until restored

    @classmethod
    def from_args(cls, args: argparse.Namespace, user: str | None = None) -> Persistence:
        """`--state` as given; for a `user` of accounts (service/accounts.py), that user's own file,
        `FILE.user-USER`."""
        interval = float(getattr(args, "state_interval", DEFAULT_INTERVAL))
        if not interval >= 0.0:
            raise ValueError(f"--state-interval must be >= 0, got {interval}")
        path = getattr(args, "state", None)
        if path is not None and user is not None:
            path = user_state_path(path, user)
        p = cls(path, interval, bool(getattr(args, "state_discard_bad", False)))
        if p.path is not None:
            p._read()  # a bad file stops the start before anything is opened
        return p

    @property
    def tick(self) -> float:
        """How often the serving loop wakes (to save on time)."""
        return 0.1 if self.path else 0.5

    def _read(self) -> None:
        assert self.path is not None
        try:
            self._saved = read_state(self.path)
        except StateFileError as e:
            if not self.discard_bad:
                raise StateFileError(f"{e} (use --state-discard-bad to start without these movers)") from None
            aside = set_aside(self.path)
            log.warning("%s; set aside as %s, starting with no movers", e, aside)
            self._saved = None

    def restorer(self, node: Any) -> Callable[[ServiceCore], None]:
        """What ServiceNode.start runs before declaring any key: put the saved movers back, except those
        another instance of the cluster holds now (handed over after this file was written)."""

        def run(core: ServiceCore) -> None:
            if self._saved and node.options.accept_handovers:
                elsewhere = held_elsewhere(node.session, node.keys, [m.handover.id for m in self._saved])
                for m in self._saved:
                    if m.handover.id in elsewhere:
                        log.warning("mover %X is held by another instance now: not restored here", m.handover.id)
                self._saved = [m for m in self._saved if m.handover.id not in elsewhere]
            self.restore(core)

        return run

    def restore(self, core: ServiceCore) -> None:
        """Put the saved movers back (all, or none and StateFileError)."""
        saved = self._saved
        if not saved:
            return
        try:
            restore(core, saved, self.path or "?")
        except StateFileError as e:
            if not self.discard_bad:
                raise StateFileError(f"{e} (use --state-discard-bad to start without these movers)") from None
            for mover_id in list(core.movers):  # all or nothing
                core.remove(mover_id)
            aside = set_aside(self.path or "")
            log.warning("%s; set aside as %s, starting with no movers", e, aside)
        self._saved = None

    def save_locked(self, core: ServiceCore) -> None:
        """Write the file from the engine thread (lock held), right after a hand-over came in."""
        if self.path is None:
            return
        began = time.monotonic()
        try:
            movers = core.snapshot_movers()
            write_state(self.path, movers, core.instance)
        except Exception as e:  # the mover is held in memory all the same; the next save retries
            log.error("cannot write the state file %s after a hand-over: %s", self.path, e)
            return
        _written(self.path, len(movers), "after a hand-over in", began)

    def _handovers(self, node: Any) -> int:
        h = node.stats.handovers
        return int(h.get("in", 0) + h.get("out", 0))

    def maybe_save(self, node: Any) -> None:
        """Save when the interval has passed or a mover changed instances since the last save."""
        if self.path is None:
            return
        due = self.interval > 0 and time.monotonic() - self._last_save >= self.interval
        if due or self._handovers(node) != self._handovers_saved:
            self.save(node)

    def save(self, node: Any) -> bool:
        """Write the state file now; False (and the reason on stderr) when it could not be written."""
        if self.path is None:
            return True
        handovers = self._handovers(node)
        began = time.monotonic()
        try:
            movers = node.snapshot(lambda core: core.snapshot_movers())
            if movers is None:
                return True  # never started: nothing to write, and the old file stays as it was
            write_state(self.path, movers, node.instance)
        except Exception as e:
            print(f"acphys serve: cannot write the state file {self.path}: {e}", file=sys.stderr, flush=True)
            return False
        finally:
            self._last_save = time.monotonic()
        _written(self.path, len(movers), "after a hand-over" if handovers != self._handovers_saved else "", began)
        self._handovers_saved = handovers
        return True


def _written(path: str, movers: int, why: str, began: float) -> None:
    log.info("state written: %d mover(s) to %s%s (%.1f ms)", movers, path, f" {why}" if why else "",
             (time.monotonic() - began) * 1000.0)


def held_elsewhere(session: zenoh.Session, keys: Keys, mover_ids: list[int], timeout: float = 2.0) -> set[int]:
    """Which of `mover_ids` an instance answering on `session` holds now (asked before this instance
    declares its keys, so every answer is another's). Only instances connected by then are asked."""
    held: set[int] = set()
    lock = threading.Lock()
    pending = threading.Semaphore(0)

    def ask(mover_id: int) -> None:
        def on_reply(r: zenoh.Reply) -> None:
            if r.ok is not None:
                with lock:
                    held.add(mover_id)

        session.get(keys.lb("*", "get"), zenoh.handlers.Callback(on_reply, pending.release),
                    payload=pack({"id": mover_id}), target=zenoh.QueryTarget.ALL,
                    consolidation=zenoh.ConsolidationMode.NONE, timeout=timeout)

    for mover_id in mover_ids:
        ask(mover_id)
    deadline = time.monotonic() + timeout + 1.0
    for _ in mover_ids:  # every query ends (Zenoh calls its drop callback), at the latest at its timeout
        if not pending.acquire(timeout=max(0.0, deadline - time.monotonic())):
            break
    with lock:
        return set(held)
