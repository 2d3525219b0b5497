"""Which files `--state FILE` stands for under a worker count, and moving saved movers between them.

A single process keeps its movers in `FILE`; `--workers N` gives worker I
its own `FILE.worker-I-of-N` (with accounts, each user's file of either
kind ends in `.user-USER`). A restart with another worker count (or
another `--own`, or a world whose split changed) finds the movers in the
files of the old layout. Before any worker starts, `regroup_state` reads
every file of every layout present (with its logs replayed:
service/persistence/state_replay.py), gives each mover to the file of the
worker that owns its landblock now, writes the new layout's files
(atomically, as always) and only then renames the old layout's files
aside (`<file>.regrouped-<time>-<pid>`, never deleted), their logs
with them; a new file names a log generation past its old logs, which its
instance then deletes. A crash between the two leaves both layouts; the
next start merges them again, keeping of a mover found twice the copy with
the higher `seq` (then the newer file).

It refuses, changing no file, when a file of another layout cannot be
read in full (unless `--state-discard-bad`: that file is set aside as
usual) or a saved mover lies in a landblock no worker owns now.
"""

from __future__ import annotations

import logging
import os
import re
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from service.persistence.journal import journal_files
from service.ownership import Ownership
from service.persistence.state_file import SavedMover, StateFileError, set_aside, write_state
from service.persistence.state_replay import load_saved
from service.protocol.wire import lb_hex

__all__ = ["Regrouped", "layout_paths", "regroup_state", "saved_files", "user_state_path", "worker_state_path"]

log = logging.getLogger("acphys.service")

#: the `instance` written into files made by a regroup (no running instance wrote them)
REGROUPED_BY = "regrouped"


def user_state_path(path: str, user: str) -> str:
    """Where a user's movers are kept when accounts share one `--state FILE`."""
    return f"{path}.user-{user}"


def worker_state_path(path: str, index: int, count: int) -> str:
    """Worker `index`'s own file under `--workers count`."""
    return f"{path}.worker-{index}-of-{count}"


def layout_paths(state: str, count: int, workers: int, user: str | None = None) -> list[Path]:
    """The files of one layout: `FILE` for a single process (`count` 1), else one per worker that starts
    (`workers`, which may be fewer than `count` when there are fewer landblocks to give)."""
    base = [state] if count == 1 else [worker_state_path(state, i, count) for i in range(workers)]
    return [Path(user_state_path(p, user) if user is not None else p) for p in base]


def saved_files(state: str, user: str | None = None) -> list[Path]:
    """Every file of `state` present, whatever its layout: `FILE` and `FILE.worker-I-of-N` (each with
    `.user-USER` for a user), sorted by name; one that has only logs (`FILE.journal-G`) is named too.
    Files set aside (`.bad-`, `.regrouped-`) are not among them."""
    path = Path(state)
    suffix = re.escape(f".user-{user}") if user is not None else ""
    pattern = re.compile("(" + re.escape(path.name) + r"(?:\.worker-\d+-of-\d+)?" + suffix + r")(\.journal-\d+)?")
    try:
        names = os.listdir(path.parent)
    except FileNotFoundError:
        return []
    found = set()
    for n in names:
        m = pattern.fullmatch(n)
        if m and (path.parent / n).is_file():
            found.add(path.parent / m.group(1))
    return sorted(found)


@dataclass(frozen=True, slots=True)
class Regrouped:
    """What a regroup did: the movers per new file, and where the old layout's files went."""
    movers: dict[Path, int]
    sources: list[Path]
    aside: dict[Path, Path]


def regroup_state(state: str, count: int, owners: Sequence[Ownership], *, user: str | None = None,
                  discard_bad: bool = False) -> Regrouped | None:
    """Make the files of `count`'s layout (one per owner, in order) hold every saved mover of `state`,
    each in the file of the owner of its landblock. None when there was nothing to move (no file, or
    only the layout's own files with every mover where it belongs: a bad one of those is left for its
    instance to report). StateFileError, with no file changed, when a mover cannot be placed."""
    targets = layout_paths(state, count, len(owners), user)
    present = saved_files(state, user)
    others = [p for p in present if p not in targets]
    if not others and len(targets) == 1:
        # one file, its own: nothing to move (a mover no owner takes is its instance's to refuse), so its log
        # is not replayed here only for the start to replay it again
        return None
    read: dict[Path, list[SavedMover]] = {}
    generations: dict[Path, int] = {}
    hint = "use --state-discard-bad to start without that file's movers"
    for p in present:
        try:
            loaded = load_saved(p)
            read[p] = loaded.movers or []
            generations[p] = loaded.generation
        except StateFileError as e:
            if not others:
                return None  # the usual layout: the worker (or instance) reports its own file, as always
            if not discard_bad:
                raise StateFileError(f"{e}; its movers would be redistributed to this start's "
                                     f"{_layout_name(count)}: {hint}") from None
            kept = [set_aside(q) for q in [p, *journal_files(p).values()] if q.exists()]
            log.warning("%s; set aside as %s, its movers are not restored", e, ", ".join(map(str, kept)))
    chosen = _merge(read)
    home = {mover_id: _owner_of(m, owners) for mover_id, m in chosen.items()}
    held = [(p, m) for p in targets if p in read for m in read[p]]
    misplaced = len(held) != len(chosen) or any(home[m.handover.id] != targets.index(p) for p, m in held)
    if not others and (not misplaced or None in home.values()):
        # the usual layout with every mover where it belongs, or one no worker owns, which its worker
        # refuses, naming it (the files stay as they are)
        return None
    homeless = [m for m in chosen.values() if home[m.handover.id] is None]
    if homeless:
        m = homeless[0]
        where = ", ".join(str(p) for p in read if any(x is m for x in read[p]))
        raise StateFileError(
            f"state file {where}: mover {m.handover.id:X} lies in landblock {lb_hex(m.handover.position.landblock)}, "
            f"which none of this start's {_layout_name(count)} owns ({_owned(owners)}); "
            f"{len(homeless)} mover(s) have no home. Start with an --own that covers them (or the old worker "
            f"count); no state file was changed")
    by_file: dict[Path, list[SavedMover]] = {p: [] for p in targets}
    for m in chosen.values():
        by_file[targets[home[m.handover.id] or 0]].append(m)
    for p, movers in by_file.items():
        # past its old logs (if any): they are in the movers now, and its instance deletes them
        write_state(p, [m.entry for m in movers], REGROUPED_BY, journal=generations.get(p, 0))
    aside: dict[Path, Path] = {}
    stamp = f"{time.strftime('%Y%m%dT%H%M%S')}-{os.getpid()}"
    for p in others:
        for q in [p, *journal_files(p).values()]:
            if q.exists():  # a bad file set aside above is gone already
                aside[q] = q.with_name(f"{q.name}.regrouped-{stamp}")
                os.replace(q, aside[q])
    done = Regrouped({p: len(ms) for p, ms in by_file.items()}, sorted(read), aside)
    log.info("state: %d mover(s) from %s redistributed by landblock to %s (%s)%s", len(chosen),
             ", ".join(str(p) for p in done.sources), _layout_name(count),
             ", ".join(f"{p.name}: {n}" for p, n in done.movers.items()),
             "; the old files kept as " + ", ".join(str(p) for p in aside.values()) if aside else "")
    return done


def _owner_of(m: SavedMover, owners: Sequence[Ownership]) -> int | None:
    lb = m.handover.position.landblock
    return next((i for i, o in enumerate(owners) if o.owns(lb)), None)


def _merge(read: dict[Path, list[SavedMover]]) -> dict[int, SavedMover]:
    """One copy of each mover: the highest `seq`, then the most recently written file's."""
    chosen: dict[int, tuple[int, float, SavedMover]] = {}
    for p, movers in read.items():
        mtime = max([q.stat().st_mtime for q in [p, *journal_files(p).values()] if q.exists()], default=0.0)
        for m in movers:
            rank = (m.handover.seq, mtime)
            had = chosen.get(m.handover.id)
            if had is None or rank > had[:2]:
                chosen[m.handover.id] = (*rank, m)
    return {mover_id: m for mover_id, (_seq, _t, m) in sorted(chosen.items())}


def _layout_name(count: int) -> str:
    return "single process" if count == 1 else f"{count} workers"


def _owned(owners: Sequence[Ownership]) -> str:
    return "; ".join(o.to_text() for o in owners)
