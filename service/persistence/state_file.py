"""The movers of an instance on disk (`acphys serve --state FILE`), so a restart loses none.

The file is one msgpack map:

    {"format": "acphys-state", "v": 1, "saved_at": unix seconds, "instance": zenoh id,
     "count": number of movers, "sha256": hex digest of `movers`, "movers": bin, "journal": generation}

where `movers` is a msgpack array of maps, each a hand-over map
(docs/protocol.md: id, seq, mover, position, contact_plane,
contact_plane_cell, sliding_normal, water_contact) plus `registered_mover`
(the spec as registered or last updated), `velocity` and `engine_state`
(bin: the mover's whole engine state, service/persistence/journal_records.py; absent
in files of earlier versions, whose movers come back from the hand-over
map and velocity alone). The digest makes a truncated or damaged file an
error rather than a partial restore. `journal` is the first generation of
the state log (service/persistence/journal.py) that the file does not hold: a start
replays the logs from that one on (absent: 0).

It is written whole, to a temporary file in the same directory that is
flushed and fsynced and then renamed over the old one (and the directory
fsynced), so a crash leaves either the old file or the new one. Reading
checks everything and either restores every mover or raises
`StateFileError`; it never keeps some movers and drops others.
"""

from __future__ import annotations

import hashlib
import logging
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import msgpack

from engine.geometry import Vec3
from engine.world.batch import MOVER_STATE_BYTES
from engine import MoverSpec

from service.protocol.codec import decode_mover_spec
from service.core import ServiceCore
from service.protocol.errors import ProtocolError
from service.protocol.requests import HandoverRequest, parse_handover
from service.protocol.validate import as_vec3

__all__ = ["FORMAT", "VERSION", "SavedMover", "StateFileError", "write_state", "read_state", "read_snapshot", "restore",
           "set_aside"]

log = logging.getLogger("acphys.service")

FORMAT = "acphys-state"
VERSION = 1


class StateFileError(ValueError):
    """A state file that cannot be restored in full (unreadable, truncated, corrupt, or movers the world
    or this instance cannot take)."""


@dataclass(slots=True)
class SavedMover:
    handover: HandoverRequest  # where and how it is, as a hand-over would carry it
    spec: MoverSpec  # as registered or last updated
    velocity: Vec3 | None
    #: the map as the file holds it (written back unchanged when movers move to another file)
    entry: dict[str, Any] = field(default_factory=dict, repr=False)
    #: the mover's whole engine state (service/persistence/journal_records.py), when the file or log has it
    engine_state: bytes | None = field(default=None, repr=False)


def write_state(path: str | Path, movers: list[dict[str, Any]], instance: str, journal: int = 0) -> None:
    """Write `movers` (ServiceCore.snapshot_movers) atomically: temp file, fsync, rename, fsync the dir.
    `journal`: the first log generation the file does not hold."""
    path = Path(path)
    body = msgpack.packb(movers, use_bin_type=True)
    data = msgpack.packb({
        "format": FORMAT, "v": VERSION, "saved_at": time.time(), "instance": instance, "count": len(movers),
        "sha256": hashlib.sha256(body).hexdigest(), "movers": body, "journal": journal,
    }, use_bin_type=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    dir_fd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(dir_fd)  # the rename itself survives a crash
    finally:
        os.close(dir_fd)


def read_state(path: str | Path) -> list[SavedMover] | None:
    """The movers saved in `path`; None when there is no file (a first start); StateFileError when it
    cannot be read in full. (Only the file: service/persistence/state_replay.py adds its logs.)"""
    return read_snapshot(path)[0]


def read_snapshot(path: str | Path) -> tuple[list[SavedMover] | None, int]:
    """The movers saved in `path` and the first log generation the file does not hold; (None, 0) when
    there is no file; StateFileError when it cannot be read in full."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return None, 0
    except OSError as e:
        raise StateFileError(f"state file {path}: {e}") from None
    what = f"state file {path}"
    try:
        top = msgpack.unpackb(data, raw=False)
    except Exception as e:  # msgpack raises several unrelated types
        raise StateFileError(f"{what} is not readable msgpack (truncated or corrupt?): {type(e).__name__}: {e}") from None
    if not isinstance(top, dict) or top.get("format") != FORMAT:
        raise StateFileError(f"{what} is not an {FORMAT} file")
    if top.get("v") != VERSION:
        raise StateFileError(f"{what} has version {top.get('v')!r}; this service reads version {VERSION}")
    body = top.get("movers")
    if not isinstance(body, bytes) or hashlib.sha256(body).hexdigest() != top.get("sha256"):
        raise StateFileError(f"{what}: the movers do not match their checksum (corrupt)")
    try:
        raw = msgpack.unpackb(body, raw=False, strict_map_key=False)
    except Exception as e:
        raise StateFileError(f"{what}: movers unreadable: {type(e).__name__}: {e}") from None
    if not isinstance(raw, list) or len(raw) != top.get("count"):
        raise StateFileError(f"{what}: expected {top.get('count')!r} movers")
    generation = top.get("journal", 0)
    if not isinstance(generation, int) or isinstance(generation, bool) or generation < 0:
        raise StateFileError(f"{what}: journal must be a generation number, got {generation!r}")
    out = []
    for i, entry in enumerate(raw):
        try:
            if not isinstance(entry, dict):
                raise ProtocolError("wrong_type", "not a map")
            handover = parse_handover(entry)
            spec = decode_mover_spec(entry.get("registered_mover"), "registered_mover")
            vel = entry.get("velocity")
            velocity = None if vel is None else Vec3(*as_vec3(vel, "velocity"))
            engine_state = entry.get("engine_state")
            if engine_state is not None and (not isinstance(engine_state, bytes)
                                             or len(engine_state) != MOVER_STATE_BYTES):
                raise ProtocolError("bad_value", f"engine_state must be {MOVER_STATE_BYTES} bytes", "engine_state")
        except ProtocolError as e:
            raise StateFileError(f"{what}: mover {i}: {e.message}") from None
        out.append(SavedMover(handover, spec, velocity, entry, engine_state))
    return out, generation


def restore(core: ServiceCore, movers: list[SavedMover], source: str | Path) -> None:
    """Put every saved mover back; StateFileError (naming the mover) if one cannot be."""
    for m in movers:
        try:
            core.restore_mover(m.handover, m.spec, m.velocity, m.engine_state)
        except ProtocolError as e:
            raise StateFileError(f"state file {source}: mover {m.handover.id:X} cannot be restored: {e.message}") from None
    log.info("restored %d mover(s) from %s", len(movers), source)


def set_aside(path: str | Path) -> Path:
    """Rename a bad state file out of the way (kept for inspection, never deleted); the new name."""
    path = Path(path)
    aside = path.with_name(f"{path.name}.bad-{time.strftime('%Y%m%dT%H%M%S')}-{os.getpid()}")
    os.replace(path, aside)
    return aside
