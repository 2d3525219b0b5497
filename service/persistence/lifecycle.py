"""When an instance writes its movers to its state file and log, and how it reads them back at start.

`--state FILE`: restored at start (before any key is declared) from FILE
and its logs (service/persistence/state_replay.py), which are then compacted: a new
FILE holding every mover, a new empty log, the old logs deleted. From then
on every resolved change is a record of the log (service/persistence/journal.py,
service/persistence/journal_records.py), written by the `--state-sync` policy; FILE
is written again every `--state-interval` seconds (and the log starts a
new generation then) and at shutdown once every request is answered
(and the log is closed and deleted). A FILE or log that cannot be
restored in full stops the start, unless `--state-discard-bad`, which
sets it aside (renamed, never deleted).
"""

from __future__ import annotations

import argparse
import logging
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from collections.abc import Callable

import msgpack
import zenoh

from service.core import ServiceCore
from service.protocol.frames import pack
from service.persistence.journal import DEFAULT_POLICY, POLICIES, Journal, journal_files
from service.persistence.journal_records import MoverLog
from service.protocol.wire import Keys, lb_hex
from service.persistence.state_file import SavedMover, StateFileError, restore, set_aside, write_state
from service.persistence.state_layout import user_state_path
from service.persistence.state_replay import Loaded, load_saved

__all__ = ["Persistence", "add_state_arguments", "held_elsewhere", "user_state_path", "SYNC_HELP"]

log = logging.getLogger("acphys.service")

DEFAULT_INTERVAL = 10.0
#: how long a start waits for the owner of a landblock a hand-over was being sent to, to hear whether it took it
IN_DOUBT_WAIT = 10.0
SYNC_HELP = ("when the log of --state reaches the disk: 'every-second' (default: records are written and "
             "fsynced once a second; a SIGKILL, crash or power cut loses at most the changes answered in about "
             "the last second), 'always' (each request's records are fsynced before its reply and its States "
             "go out: nothing answered is ever lost; it costs one fsync per request), 'never' (written once a "
             "second, synced when the OS chooses: a killed process loses at most about a second, a power cut "
             "what the OS had not written). After a kill or crash a mover's seq goes on above every seq answered "
             "(under 'never', not after a power cut)")


def add_state_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("state")
    g.add_argument("--state", metavar="FILE", help="keep the movers in FILE and its log FILE.journal-N: restored "
                   "at start, every change logged as it is answered (--state-sync), FILE written anew at shutdown "
                   "and every --state-interval seconds")
    g.add_argument("--state-sync", choices=POLICIES, default=DEFAULT_POLICY, help=SYNC_HELP)
    g.add_argument("--state-interval", type=float, default=DEFAULT_INTERVAL, metavar="S",
                   help="seconds between writes of the state file, each starting a new log (default %(default)s; "
                        "0: only at start and shutdown, the log growing until then)")
    g.add_argument("--state-discard-bad", action="store_true",
                   help="start without what cannot be restored: a bad state file is set aside (renamed, not "
                        "deleted) and the instance starts empty; a damaged log is set aside and the movers come "
                        "back as of its last whole record")


@dataclass(slots=True)
class Persistence:
    path: str | None = None
    interval: float = DEFAULT_INTERVAL
    discard_bad: bool = False
    sync: str = DEFAULT_POLICY
    #: the log being written (once the movers are restored)
    journal: Journal | None = None
    _last_save: float = field(default_factory=time.monotonic)
    _loaded: Loaded | None = None  # read at start, until restored
    _compact: bool = False  # write the state file at start even when no log was replayed

    @classmethod
    def from_args(cls, args: argparse.Namespace, user: str | None = None) -> Persistence:
        """`--state` as given; for a `user` of accounts (service/security/accounts.py), that user's own file,
        `FILE.user-USER`."""
        interval = float(getattr(args, "state_interval", DEFAULT_INTERVAL))
        if not interval >= 0.0:
            raise ValueError(f"--state-interval must be >= 0, got {interval}")
        sync = getattr(args, "state_sync", DEFAULT_POLICY) or DEFAULT_POLICY
        if sync not in POLICIES:
            raise ValueError(f"--state-sync must be one of {', '.join(POLICIES)}, got {sync!r}")
        path = getattr(args, "state", None)
        if path is not None and user is not None:
            path = user_state_path(path, user)
        p = cls(path, interval, bool(getattr(args, "state_discard_bad", False)), sync)
        if p.path is not None:
            p._read()  # a bad file stops the start before anything is opened
        return p

    @property
    def tick(self) -> float:
        """How often the serving loop wakes (to save on time)."""
        return 0.1 if self.path else 0.5

    @property
    def _saved(self) -> list[SavedMover] | None:
        return self._loaded.movers if self._loaded is not None else None

    def _read(self) -> None:
        assert self.path is not None
        try:
            self._loaded = load_saved(self.path, self.discard_bad)
        except StateFileError as e:
            if not self.discard_bad:
                raise StateFileError(f"{e} (use --state-discard-bad to start without these movers)") from None
            self._discard(str(e))

    def _discard(self, why: str) -> None:
        """Set FILE and its logs aside (renamed, kept) and start with no movers."""
        assert self.path is not None
        aside = [set_aside(p) for p in [Path(self.path), *journal_files(self.path).values()] if p.exists()]
        log.warning("%s; set aside as %s, starting with no movers", why, ", ".join(str(a) for a in aside) or "-")
        self._loaded = Loaded(None, 0)

    def restorer(self, node: Any) -> Callable[[ServiceCore], None]:
        """What ServiceNode.start runs before declaring any key: put the saved movers back, except those
        another instance of the cluster holds now (handed over after this file was written), compact the
        file and its logs, and start the log."""

        def run(core: ServiceCore) -> None:
            loaded = self._loaded
            if loaded is not None and loaded.movers and node.options.accept_handovers:
                # a session just opened may not reach the others yet (its links come up, their keys' routes
                # arrive, a peer it does not connect to itself retries after a pause): a question asked then
                # reaches nobody, and a mover another instance took would be put back here too
                _await_cluster(node.session, node.keys, IN_DOUBT_WAIT)
            if loaded is not None and loaded.movers and loaded.in_doubt and node.options.accept_handovers:
                taken = _taken_elsewhere(node.session, node.keys, loaded.in_doubt)
                loaded.movers = [m for m in loaded.movers if m.handover.id not in taken]
                self._compact = self._compact or bool(taken)
            if loaded is not None and loaded.movers and node.options.accept_handovers:
                elsewhere = held_elsewhere(node.session, node.keys, [m.handover.id for m in loaded.movers])
                for m in loaded.movers:
                    if m.handover.id in elsewhere:
                        log.warning("mover %X is held by another instance now: not restored here", m.handover.id)
                loaded.movers = [m for m in loaded.movers if m.handover.id not in elsewhere]
                self._compact = bool(elsewhere)  # the file no longer holds what this instance holds
            self.restore(core)
            self.start_log(core)

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
            self._discard(str(e))

    def start_log(self, core: ServiceCore) -> None:
        """Compact (when logs were replayed: a new FILE with every mover restored, the old logs deleted) and
        open the log every change is recorded in from now on."""
        if self.path is None:
            return
        loaded = self._loaded or Loaded(None, 0)
        self._loaded = None
        generation = loaded.generation
        if loaded.replayed or loaded.jump or self._compact:
            began = time.monotonic()
            movers = core.snapshot_movers()
            write_state(self.path, movers, core.instance, journal=generation)
            log.info("state log replayed: %d record(s) of %s on %s%s; compacted: %d mover(s) to %s (%.1f ms)",
                     loaded.records, ", ".join(p.name for p in loaded.replayed) or "no log", self.path,
                     f", every seq raised by {loaded.jump} (moves answered after the last sync may be lost)"
                     if loaded.jump else "", len(movers), self.path, (time.monotonic() - began) * 1000.0)
        for p in [*loaded.replayed, *loaded.stale]:
            p.unlink(missing_ok=True)
        self.journal = Journal(self.path, generation, self.sync)
        core.attach_log(MoverLog(self.journal))
        self._last_save = time.monotonic()

    def save_locked(self, core: ServiceCore) -> None:
        """Right after a hand-over came in (engine lock held): its record is already synced in the log
        (ServiceCore.handover_in), so there is nothing left to write."""

    def maybe_save(self, node: Any) -> None:
        """Write the state file (starting a new log) when the interval has passed."""
        if self.path is None or self.journal is None:
            return
        if self.interval > 0 and time.monotonic() - self._last_save >= self.interval:
            self.save(node, final=False)

    def save(self, node: Any, final: bool | None = None) -> bool:
        """Write the state file now; False (and the reason on stderr) when it could not be written. `final`
        (default: when the node is shut down): the log is closed and, once the file holds everything,
        deleted; else a new log generation starts."""
        if self.path is None:
            return True
        if final is None:
            final = getattr(node, "session", True) is None
        journal = self.journal
        began = time.monotonic()

        def take(core: ServiceCore) -> tuple[list[dict[str, Any]], int]:
            movers = core.snapshot_movers()
            if journal is None:
                return movers, 0
            return movers, journal.close() if final else journal.rotate()

        try:
            got = node.snapshot(take)
            if got is None:
                return True  # never started: nothing to write, and the old file stays as it was
            movers, generation = got
            write_state(self.path, movers, node.instance, journal=generation)
        except Exception as e:
            print(f"acphys serve: cannot write the state file {self.path}: {e}", file=sys.stderr, flush=True)
            return False
        finally:
            self._last_save = time.monotonic()
        for g, p in journal_files(self.path).items():
            if g < generation:
                p.unlink(missing_ok=True)  # wholly in the file now
        _written(self.path, len(movers), "at shutdown" if final else "", began)
        return True


def _written(path: str, movers: int, why: str, began: float) -> None:
    log.info("state written: %d mover(s) to %s%s (%.1f ms)", movers, path, f" {why}" if why else "",
             (time.monotonic() - began) * 1000.0)


def _taken_elsewhere(session: zenoh.Session, keys: Keys, in_doubt: dict[int, int]) -> set[int]:
    """Of the movers whose hand-over was sent just before the stop (its outcome not logged), those the
    landblock's owner took: each owner is asked (a Get of the mover on its landblock's key) until it answers,
    for up to IN_DOUBT_WAIT seconds, since after a restart the other instances may take a moment to connect
    again. One that does not answer in time, or answers that it does not hold the mover (`unknown_mover`, or
    `moved`: it passed the mover on, perhaps long before): the mover stays here (if the owner did take it,
    its own start asks this instance, finds the mover here, and does not restore it; an instance the mover
    was passed on to is asked by `held_elsewhere` like every other)."""
    taken: set[int] = set()
    deadline = time.monotonic() + IN_DOUBT_WAIT
    for mover_id, lb in in_doubt.items():
        answer = None
        while answer is None and time.monotonic() < deadline:
            for r in session.get(keys.lb(lb_hex(lb), "get"), payload=pack({"id": mover_id}), timeout=2.0):
                if r.ok is not None:
                    answer = "held"
                elif r.err is not None:
                    try:
                        answer = str(msgpack.unpackb(r.err.payload.to_bytes(), raw=False)["error"]["kind"])
                    except Exception:  # an answer all the same
                        answer = "unreadable"
                break
            if answer is None:
                time.sleep(0.2)
        if answer == "held":
            taken.add(mover_id)
            log.warning("mover %X was being handed over to %s when this instance stopped: the owner took it, so "
                        "it is not restored here", mover_id, lb_hex(lb))
        elif answer is None:
            log.warning("mover %X was being handed over to %s when this instance stopped, and no owner answered "
                        "within %.0f s: restored here", mover_id, lb_hex(lb), IN_DOUBT_WAIT)
        else:
            log.info("mover %X was being handed over to %s when this instance stopped; the owner does not hold it "
                     "(%s): restored here", mover_id, lb_hex(lb), answer)
    return taken


def _await_cluster(session: zenoh.Session, keys: Keys, timeout: float) -> bool:
    """Wait until some other instance of the cluster answers Health (this one has declared no key yet, so any
    answer is another's), for up to `timeout` seconds; whether one did. A cluster whose other instances are all
    down costs a start this long."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if any(r.ok is not None for r in session.get(keys.health, timeout=1.0)):
            return True
        time.sleep(0.2)
    log.warning("no other instance of the cluster answered within %.0f s: the saved movers are restored without "
                "asking whether one holds them now", timeout)
    return False


def held_elsewhere(session: zenoh.Session, keys: Keys, mover_ids: list[int], timeout: float = 2.0) -> set[int]:
    """Which of `mover_ids` an instance answering on `session` holds now (asked before this instance
    declares its keys, so every answer is another's). Only instances connected by then are asked: the start
    first waits for the cluster to answer at all (_await_cluster)."""
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
