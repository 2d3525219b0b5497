"""ServiceCore: the service's state and operations, without the bus.

Runs on the engine thread only (the World is not thread-safe); talks to
the outside through a `BusPort` so it can be tested without zenoh. Every
operation returns the reply map's content or raises ProtocolError.
"""

from __future__ import annotations

import logging
import random
from time import monotonic, perf_counter
from dataclasses import dataclass, replace
from collections.abc import Callable
from operator import itemgetter
from typing import Any

import msgpack

from engine.geometry import Plane, Position, Vec3
from engine import Mover, MoverSpec, MoveResult, MoveUndo

from service.bus_port import BusPort
from service.protocol.codec import encode_mover_spec, encode_state, encode_vec, pack_state
from service.engine_errors import to_protocol_error
from service.protocol.errors import ProtocolError
from service.persistence.journal_records import HANDOVER_IN, REGISTER, UPDATE, MoverLog, apply_state, decode_state, mover_state_bytes
from service.protocol.messages import HANDOVER
from service.ownership import Ownership
from service.protocol.requests import HandoverRequest, ItemError, MoveBatch, MoveItem, RegisterRequest
from service.stats import ServiceStats
from service.protocol.wire import ErrorKind, lb_hex

__all__ = ["MoverRecord", "ServiceCore"]

log = logging.getLogger("acphys.service")

_encode_handover = HANDOVER.encode_fn()

#: How many handed-over movers an instance remembers (to answer `moved`).
FORWARD_MEMORY = 100_000
_TRANSIENT = ("Contact", "OnWalkable")

#: the engine's argument names (engine.errors.EngineError.field) as request paths
_REGISTER_FIELDS = {"position": "position", "spec": "mover", "contact_plane": "contact_plane", "sliding_normal": "sliding_normal"}
_UPDATE_FIELDS = {"spec": "mover"}


def _move_fields(item: MoveItem) -> dict[str, str]:
    """The engine's argument names of one move as that move's request paths."""
    base = f"{item.path}." if item.path else ""
    if item.offset is not None:  # the target is the current origin plus the offset, axis by axis
        return {"target.origin": f"{base}offset", "target": f"{base}offset", "velocity": f"{base}velocity"}
    if item.to is not None:
        return {"target": f"{base}to", "velocity": f"{base}velocity"}
    return {"motion": f"{base}motion", "dt": f"{base}dt"}

@dataclass(slots=True)
class MoverRecord:
    """A mover this instance holds. Its seq and last result are the engine's own (Mover.seq, Mover.last),
    counted by every move however it runs (one, a map batch, a column batch) and taken back with it."""

    id: int  # the id on the wire
    engine_id: int  # the World's id (changes on re-add)
    spec: MoverSpec  # as registered or updated
    mover: Mover  # the engine's (a new one after an update)

    @property
    def seq(self) -> int:
        return self.mover.seq

    @property
    def last(self) -> MoveResult:
        last = self.mover.last
        assert last is not None  # set when the mover is added
        return last


def spec_with_contact(spec: MoverSpec, r: MoveResult) -> MoverSpec:
    """The spec whose starting transient flags are the result's (to re-add a mover)."""
    names = [n for n in spec.state if n not in _TRANSIENT]
    if r.contact:
        names.append("Contact")
    if r.on_walkable:
        names.append("OnWalkable")
    return replace(spec, state=names)


class ServiceCore:
    def __init__(self, world: Any, bus: BusPort, *, ownership: Ownership, instance: str, stats: ServiceStats) -> None:
        self.world = world
        self.bus = bus
        self.ownership = ownership
        self._owns_all = ownership.everything  # frozen: read once, not per move
        self.instance = instance
        self.stats = stats
        self.movers: dict[int, MoverRecord] = {}
        #: each held mover's engine Mover by wire id (its record's `mover`): what a column batch hands the
        #: engine, looked up a whole id column at a time
        self.engine_movers: dict[int, Mover] = {}
        #: bumped whenever `engine_movers` changes (a mover added, dropped or replaced): a column batch's
        #: lookup of the same id column is kept while it stands (`engine_movers_of`)
        self.movers_version = 0
        self._movers_of: dict[int, tuple[list[int], int, tuple[Mover | None, ...]]] = {}
        self._by_engine: dict[int, int] = {}
        self._forwarded: dict[int, int] = {}
        # assigned ids sit above 2^32 so they never collide with AC guids a client may choose
        self._id_base = (random.getrandbits(24) + 1) << 32
        self._next_id = 1
        # snapshots other threads may read (health/stats are answered off the engine thread)
        self.loaded: tuple[int, ...] = ()
        self.engine_cache: dict[str, Any] = {}
        self._cache_read_at = 0.0
        #: with accounts (service/security/accounts.py), told after this core read its snapshots, so the other users'
        #: cores over the same world read theirs; and how many of their movers are in a landblock (an unload
        #: must wait for theirs too)
        self.world_changed: Callable[[ServiceCore], None] | None = None
        self.foreign_movers_in: Callable[[int], int] | None = None
        self.refresh()
        # the core runs on one thread at a time (the engine thread, or a callback holding the engine lock)
        self._packer = msgpack.Packer(use_bin_type=True)
        #: the state log's writer (`--state`, service/persistence/lifecycle.py): every resolved change is recorded
        #: before its reply goes out; None: nothing is recorded
        self.log: MoverLog | None = None
        #: under `--state-sync always`, the States of the request running, published once its records are
        #: synced (a subscriber never hears of a State a kill could take back); None otherwise
        self._deferred: list[tuple[int, bytes]] | None = None

    def attach_log(self, log: MoverLog | None) -> None:
        """Record every resolved change in `log` from now on (None: stop recording)."""
        self.log = log
        self._deferred = [] if log is not None and log.always else None

    def publish_state(self, mover_id: int, packed: bytes) -> None:
        """Publish a State now, or once the request's records are synced (`--state-sync always`)."""
        if self._deferred is not None:
            self._deferred.append((mover_id, packed))
        else:
            self.bus.publish_state(mover_id, packed)

    @property
    def publishes_after_reply(self) -> bool:
        """Whether a single move's State may be published after its reply has gone (`publish_if_watched`):
        when this instance owns every landblock (no hand-over can take the mover, whose new owner would then
        publish its later States) and States are not held for a sync (`--state-sync always`)."""
        return self._owns_all and self._deferred is None

    def publish_if_watched(self, mover_id: int, packed: bytes) -> None:
        """Publish a State when anyone subscribes to the state keys now: a single move's, after its reply."""
        if self.bus.states_watched():
            self.bus.publish_state(mover_id, packed)

    def commit(self) -> None:
        """The request's changes are done: its records go to the log (synced under `always`), then the
        States held back for it are published."""
        log = self.log
        if log is None:
            return
        log.commit()
        deferred = self._deferred
        if deferred:
            self._deferred = []
            for mover_id, packed in deferred:
                self.bus.publish_state(mover_id, packed)

    def refresh(self) -> None:
        """Read again the snapshots other threads answer from; with accounts, the other users' cores too
        (they share the world: `world_changed`)."""
        self.read_snapshots()
        if self.world_changed is not None:
            self.world_changed(self)

    def read_snapshots(self) -> None:
        self.loaded = tuple(sorted(self.world.loaded_landblocks()))
        self.engine_cache = self.cache_stats()
        self._cache_read_at = monotonic()

    # -- helpers ------------------------------------------------------------
    def _record(self, mover_id: int, path: str | None = None) -> MoverRecord:
        rec = self.movers.get(mover_id)
        if rec is not None:
            return rec
        lb = self._forwarded.get(mover_id)
        if lb is not None:
            raise ProtocolError(
                ErrorKind.MOVED, f"mover {mover_id:X} was handed over to landblock {lb_hex(lb)}", path, landblock=lb
            )
        raise ProtocolError(ErrorKind.UNKNOWN_MOVER, f"no mover {mover_id:X} here", path)

    def engine_id(self, mover_id: int, path: str | None = None) -> int:
        """The engine's id of mover `mover_id` held here; ProtocolError `moved` or `unknown_mover` naming
        `path` otherwise (a query's `target`, `viewer`, or a path's walker)."""
        return self._record(mover_id, path).engine_id

    def wire_id(self, engine_id: int) -> int:
        """The wire id of the engine's object `engine_id` when it is one of this instance's movers, else 0
        (a static object of a landblock): how a query's Blocker names it."""
        return self._by_engine.get(engine_id, 0)

    def _collide_ids(self, r: MoveResult) -> list[int]:
        """The wire ids of the movers a result touched (the engine's ids translated)."""
        return [self._by_engine[e] for e in r.collide_objects if e in self._by_engine] if r.collide_objects else []

    def _state(self, rec: MoverRecord, tag: int | str | None = None) -> dict[str, Any]:
        return encode_state(rec.id, rec.seq, rec.last, self._collide_ids(rec.last), tag)

    def _add(self, mover_id: int, spec: MoverSpec, position: Position, plane: Plane | None, plane_cell: int | None,
             seq: int = 0, sliding_normal: Vec3 | None = None, water_contact: bool = False) -> MoverRecord:
        try:
            eid = self.world.add_mover(
                spec, position, plane, plane_cell, sliding_normal=sliding_normal, water_contact=water_contact
            )
        except Exception as e:
            raise to_protocol_error(e, "position", fields=_REGISTER_FIELDS) from None
        mover = self.world.mover(eid)
        mover.seq = seq
        mover.last = self.world.mover_state(eid)
        rec = MoverRecord(mover_id, eid, spec, mover)
        self.movers[mover_id] = rec
        self.engine_movers[mover_id] = mover
        self.movers_version += 1
        self._by_engine[eid] = mover_id
        self._forwarded.pop(mover_id, None)
        return rec

    def _drop(self, rec: MoverRecord) -> None:
        self.world.remove_mover(rec.engine_id)
        self.bus.forget_mover(rec.id)
        self.movers.pop(rec.id, None)
        self.engine_movers.pop(rec.id, None)
        self.movers_version += 1
        self._by_engine.pop(rec.engine_id, None)

    def _check_owner(self, lb: int, what: str) -> None:
        if not self.ownership.owns(lb):
            raise ProtocolError(
                ErrorKind.WRONG_LANDBLOCK, f"{what} is in landblock {lb_hex(lb)}, which this instance does not own",
                None, landblock=lb,
            )

    # -- movers ---------------------------------------------------------------
    def register(self, req: RegisterRequest) -> dict[str, Any]:
        self._check_owner(req.position.landblock, "the start position")
        if req.id is None:
            while (self._id_base | self._next_id) in self.movers:
                self._next_id += 1
            mover_id = self._id_base | self._next_id
        else:
            mover_id = req.id
            if mover_id in self.movers:
                raise ProtocolError(ErrorKind.DUPLICATE_MOVER, f"mover {mover_id:X} is already registered", "id")
        rec = self._add(mover_id, req.spec, req.position, req.contact_plane, req.contact_plane_cell,
                        sliding_normal=req.sliding_normal, water_contact=bool(req.water_contact))
        if req.id is None:
            self._next_id += 1  # taken only once the mover is in: a refused register leaves the next id free
        state = self._state(rec)
        self.refresh()  # a dat world loads the start landblock on demand
        if self.log is not None:
            self.log.movers(REGISTER, rec.id, rec.seq, rec.mover, encode_mover_spec(rec.spec))
            self.commit()
        if self.bus.states_watched():  # as for a move's: unwatched, its State key is not even declared yet
            self.bus.publish_state(rec.id, self._packer.pack(state))
        return {"state": state}

    def update(self, mover_id: int, spec: MoverSpec) -> dict[str, Any]:
        rec = self._record(mover_id, "id")
        try:
            self.world.update_mover(rec.engine_id, spec)
            rec.mover = self.engine_movers[rec.id] = self.world.mover(rec.engine_id)
            self.movers_version += 1
            rec.mover.last = self.world.mover_state(rec.engine_id)
        except Exception as e:
            raise to_protocol_error(e, "mover", fields=_UPDATE_FIELDS) from None
        rec.spec = spec
        if self.log is not None:
            self.log.movers(UPDATE, rec.id, rec.seq, rec.mover, encode_mover_spec(spec))
            self.commit()
        return {"state": self._state(rec)}

    def remove(self, mover_id: int) -> dict[str, Any]:
        rec = self._record(mover_id, "id")
        try:
            self._drop(rec)
        except Exception as e:
            raise to_protocol_error(e, "id") from None
        if self.log is not None:
            self.log.removed(mover_id)
            self.commit()
        return {"id": mover_id, "removed": True}

    def get(self, mover_id: int) -> dict[str, Any]:
        rec = self._record(mover_id, "id")
        return {"state": self._state(rec), "mover": encode_mover_spec(rec.spec)}

    # -- moves ----------------------------------------------------------------
    def _engine_error(self, e: Exception, rec: MoverRecord, item: MoveItem) -> ProtocolError:
        """The engine's refusal of a move as the protocol's error (called in `except`: a fault is logged)."""
        err = to_protocol_error(e, item.path or None, fields=_move_fields(item))
        if err.kind == ErrorKind.INTERNAL:
            log.exception("engine failed on move of %X", rec.id)
        return err

    def _move(self, item: MoveItem, publish: bool) -> tuple[bytes, float]:
        """Apply one move and, when `publish`, publish its State: the State packed, and the engine's time."""
        rec = self.movers.get(item.id)
        if rec is None:
            rec = self._record(item.id, f"{item.path}.id" if item.path else "id")
        # an instance owning only some landblocks may have to refuse a move after it ended (no owner takes
        # the mover): kept so that the move can be taken back
        undo = None if self._owns_all else MoveUndo(rec.mover)
        t0 = perf_counter()
        try:  # the engine counts the move: result.seq is the mover's new seq
            pos = rec.mover.last.position  # type: ignore[union-attr]  # rec.last without its property: set at add
            if item.offset is not None:
                result = self.world.move(rec.engine_id, pos.moved(item.offset), item.velocity)
            elif item.to is not None:
                result = self.world.move(rec.engine_id, item.to.resolve(pos), item.velocity)
            else:
                assert item.motion is not None and item.dt is not None
                result = self.world.step(rec.engine_id, item.motion, item.dt)
        except Exception as e:
            raise self._engine_error(e, rec, item) from None
        engine = perf_counter() - t0
        packed = pack_state(rec.id, result.seq, result, self._collide_ids(result) if result.collide_objects else [], item.tag)
        lb = (result.position.cell_id >> 16) & 0xFFFF
        if not self._owns_all and not self.ownership.owns(lb):
            assert undo is not None
            # the new owner publishes this State: its next ones follow it on the same session
            self._hand_over(rec, lb, packed if publish else None, undo)
            return packed, engine
        if self.log is not None:
            self.log.moved(rec.id, result.seq, rec.mover)
        if publish:
            self.publish_state(rec.id, packed)
        return packed, engine

    def _done(self, latency: list[float], engine: list[float]) -> None:
        self.stats.moves_done(latency, engine)
        if monotonic() - self._cache_read_at > 1.0:
            self.refresh()

    def _publishing(self, batch_mode: bool) -> tuple[bool, bool]:
        """(publish each State on its mover's key, collect them for one P/states message), asked once per
        request: a subscriber declared before the request was sent is seen here."""
        if batch_mode:
            return False, self.bus.batch_watched()
        return self.bus.states_watched(), False

    def move_one(self, item: MoveItem, received: float, publish: bool | None = None, batch_mode: bool = False) -> bytes:
        """Apply one move; its State packed (published too when anyone subscribes), or raises. `publish`
        given: whether to publish on the mover's key (the caller asked); else asked here."""
        if publish is not None:
            each, collect = publish, False
        elif batch_mode:
            each, collect = False, self.bus.batch_watched()
        else:
            each, collect = self.bus.states_watched(), False
        packed, engine = self._move(item, each)
        if self.log is not None:
            self.commit()
        # `_done` for one sample, written out: this is every single-move request's path
        now = monotonic()
        self.stats.move_done(now - received, engine)
        if now - self._cache_read_at > 1.0:
            self.refresh()
        if collect:
            self.bus.publish_batch([packed])
        return packed

    def move_single(self, item: MoveItem, received: float) -> bytes:
        """`move_one` of a single move whose State is published after its reply (`publishes_after_reply` holds:
        nothing hands the mover over, nothing is held for a sync): its State packed, nothing published.

        The usual case (a mover held here, no state log, an offset or a target) is `_move` and `move_one`
        written out in one call: run after the idle gap between one move and the next, as in a round trip,
        each step costs several times what it costs back to back (benchmarks/bench_service.py, `handling`),
        and this is every single move's path. Anything else is `move_one`'s."""
        rec = self.movers.get(item.id)
        if rec is None or self.log is not None or item.motion is not None:
            return self.move_one(item, received, False)
        pos = rec.mover.last.position  # type: ignore[union-attr]  # rec.last without its property: set at add
        t0 = perf_counter()
        try:
            target = pos.moved(item.offset) if item.offset is not None else item.to.resolve(pos)  # type: ignore[union-attr]
            result = self.world.move(rec.engine_id, target, item.velocity)
        except Exception as e:
            raise self._engine_error(e, rec, item) from None
        engine = perf_counter() - t0
        packed = pack_state(rec.id, result.seq, result, self._collide_ids(result) if result.collide_objects else [],
                            item.tag)
        now = monotonic()
        self.stats.move_done(now - received, engine)
        if now - self._cache_read_at > 1.0:
            self.refresh()
        return packed

    def moves(self, batch: MoveBatch, received: float) -> list[bytes | ItemError]:
        """Every item in order, each a packed State or its error; an item's failure is its own result only."""
        out: list[bytes | ItemError] = []
        latency: list[float] = []
        engine: list[float] = []
        each, collect = self._publishing(batch.publish_batch)
        for item in batch.items:
            if isinstance(item, ItemError):
                out.append(item)
                continue
            try:
                packed, t = self._move(item, each)
            except ProtocolError as e:
                out.append(ItemError(e, item.id, item.tag))
                continue
            out.append(packed)
            latency.append(monotonic() - received)
            engine.append(t)
        if self.log is not None:
            self.commit()
        self._done(latency, engine)
        if collect and engine:
            self.bus.publish_batch([r for r in out if isinstance(r, bytes)])
        return out

    def push(self, batch: MoveBatch, raw_items: list[Any], received: float) -> None:
        """Fire-and-forget: states are published; errors go to the object's error key."""
        each, collect = self._publishing(batch.publish_batch)
        collected: list[bytes] = []
        for item, raw in zip(batch.items, raw_items):
            if isinstance(item, ItemError):
                self.stats.error(item.error.kind)
                self.bus.publish_error(item.id, item.to_wire(), item.id in self.movers)
                continue
            fwd = self._forwarded.get(item.id)
            if item.id not in self.movers and fwd is not None:
                # keep the mover's order: everything sent here after the hand-over follows it
                self.bus.forward_push(fwd, raw, batch.publish_batch)
                continue
            try:
                packed = self.move_one(item, received, each)
            except ProtocolError as e:
                self.stats.error(e.kind)
                self.bus.publish_error(item.id, ItemError(e, item.id, item.tag).to_wire(), item.id in self.movers)
                continue
            if collect:
                collected.append(packed)
        if self.log is not None:
            self.commit()
        if collected:
            self.bus.publish_batch(collected)

    # -- what the column form (service.column_moves) shares with the map form ----------
    def mover_record(self, mover_id: int, path: str | None = None) -> MoverRecord:
        """The mover's record, or ProtocolError `moved` / `unknown_mover` naming `path`."""
        return self._record(mover_id, path)

    def forwarded_to(self, mover_id: int) -> int | None:
        """The landblock a mover this instance no longer holds was handed over to, if remembered."""
        return None if mover_id in self.movers else self._forwarded.get(mover_id)

    def collide_ids(self, r: MoveResult) -> list[int]:
        return self._collide_ids(r)

    def hand_over(self, rec: MoverRecord, lb: int, state: bytes | None, undo: MoveUndo) -> None:
        self._hand_over(rec, lb, state, undo)

    def batch_done(self, shift: float, finished_at: bytes, engine: bytes) -> None:
        """A column batch's moves resolved: each one's latency is its finishing time plus `shift` (the
        times as the engine's batch rows write them, little-endian float64s)."""
        self.stats.batch_done(shift, finished_at, engine)
        if monotonic() - self._cache_read_at > 1.0:
            self.refresh()

    def engine_movers_of(self, ids: list[int]) -> list[Mover | None]:
        """Each id's engine Mover (None where it is not held here), a fresh list the caller may change. A
        client moving the same movers every tick sends the same id column, read into one shared list
        (service.protocol.column_request): its lookup is kept while no mover is added, dropped or replaced."""
        kept = self._movers_of.get(id(ids))
        if kept is not None and kept[0] is ids and kept[1] == self.movers_version:
            return list(kept[2])
        held = self.engine_movers
        movers: list[Mover | None]
        try:  # every id held, the usual case: one C call looks them all up
            movers = list(itemgetter(*ids)(held)) if len(ids) > 1 else [held[i] for i in ids]
        except KeyError:
            movers = list(map(held.get, ids))
        if len(self._movers_of) >= 64:
            self._movers_of.clear()
        self._movers_of[id(ids)] = (ids, self.movers_version, tuple(movers))  # holds `ids`: its id stays its own
        return movers

    # -- hand-over (scale-out) ----------------------------------------------------
    def _handover_payload(self, rec: MoverRecord, state: bytes | None = None) -> dict[str, Any]:
        """The Hand-over map (service/protocol/messages.py, HANDOVER) of the mover as it stands, with the packed
        State the new owner is to publish, if any."""
        r = rec.last
        return _encode_handover(HandoverRequest(
            rec.id, rec.seq, spec_with_contact(rec.spec, r), r.position, r.contact_plane, r.contact_plane_cell,
            r.sliding_normal, r.water_contact, self.instance, state))

    def _hand_over(self, rec: MoverRecord, lb: int, state: bytes | None, undo: MoveUndo) -> None:
        """Pass the mover to `lb`'s owner (which publishes `state`, the crossing move's State, when given),
        or take the move back (`undo`, taken before it: the mover, its velocity, its time held over, its
        shadows, its seq and last result exactly as they were) and refuse it."""
        if self.log is not None:
            self.log.handing_over(rec.id, lb)
        try:
            self.bus.handover(lb, self._handover_payload(rec, state))
        except ProtocolError as e:
            self.stats.bump("handovers", "failed")
            if self.log is not None:
                self.log.handover_failed(rec.id)
            undo.restore()
            raise ProtocolError(
                ErrorKind.NO_OWNER,
                f"the move ends in landblock {lb_hex(lb)} and no instance took the mover ({e.kind}: {e.message}); "
                "it stays where it was",
                None, landblock=lb,
            ) from None
        self.stats.bump("handovers", "out")
        if self.log is not None:
            self.log.handed_over(rec.id, lb)
        self._drop(rec)
        self._forwarded[rec.id] = lb
        if len(self._forwarded) > FORWARD_MEMORY:
            del self._forwarded[next(iter(self._forwarded))]

    def handover_in(self, req: HandoverRequest) -> dict[str, Any]:
        self._check_owner(req.position.landblock, "the handed-over position")
        if req.id in self.movers:
            raise ProtocolError(ErrorKind.DUPLICATE_MOVER, f"mover {req.id:X} is already here", "id")
        lb = req.position.landblock
        if lb not in set(self.world.loaded_landblocks()):
            self.load(lb)
        rec = self._add(req.id, req.spec, req.position, req.contact_plane, req.contact_plane_cell, req.seq,
                        req.sliding_normal, req.water_contact)
        self.stats.bump("handovers", "in")
        log.info("took mover %X from %s in %s", req.id, req.source, lb_hex(lb))
        if self.log is not None:
            # on disk before the sender hears that it was taken (and forgets it), whatever the policy
            self.log.movers(HANDOVER_IN, rec.id, rec.seq, rec.mover, encode_mover_spec(rec.spec))
            self.log.commit(durable=True)
        if req.state is not None and self.bus.states_watched():
            self.bus.publish_state(req.id, req.state)
        return {"id": rec.id, "accepted": True}

    # -- durability (service/persistence/state_file.py) -----------------------------------------
    def snapshot_movers(self) -> list[dict[str, Any]]:
        """Every mover as a hand-over map plus what a restart also needs: the spec as registered and the
        velocity (a mover falling when the instance stops falls on after the restart)."""
        out = []
        for rec in self.movers.values():
            entry = self._handover_payload(rec)
            mover = rec.mover
            entry["registered_mover"] = encode_mover_spec(rec.spec)
            entry["velocity"] = encode_vec(mover.velocity)
            entry["engine_state"] = mover_state_bytes(mover)
            out.append(entry)
        return out

    def restore_mover(self, req: HandoverRequest, spec: MoverSpec, velocity: Vec3 | None,
                      engine_state: bytes | None = None) -> None:
        """Put back a mover read from a state file (before any request is served); ProtocolError if the
        world or this instance's ownership cannot take it. `engine_state` (service/persistence/journal_records.py):
        the mover's whole state, put back exactly (velocity, time held over, every transient flag)."""
        self._check_owner(req.position.landblock, "the saved position")
        if req.id in self.movers:
            raise ProtocolError(ErrorKind.DUPLICATE_MOVER, f"mover {req.id:X} appears twice", "id")
        if req.position.landblock not in set(self.world.loaded_landblocks()):
            self.load(req.position.landblock)
        rec = self._add(req.id, req.spec, req.position, req.contact_plane, req.contact_plane_cell, req.seq,
                        req.sliding_normal, req.water_contact)
        rec.spec = spec
        mover = rec.mover
        if engine_state is not None:
            apply_state(mover, decode_state(engine_state))
            mover.last = self.world.mover_state(rec.engine_id)
        elif velocity is not None:
            mover.set_velocity(velocity)
        self.refresh()

    # -- landblocks -----------------------------------------------------------
    def load(self, lb: int) -> dict[str, Any]:
        if lb in set(self.world.loaded_landblocks()):
            self.stats.bump("lb_cache", "hits")
            return {"landblock": lb, "loaded": True, "already": True}
        self.stats.bump("lb_cache", "misses")
        try:
            self.world.load_landblock(lb)
        except Exception as e:
            # whatever the source's reason (absent, unreadable, corrupt), the answer is the same kind
            if not isinstance(e, (KeyError, ValueError, OSError)):
                log.exception("loading landblock %s failed", lb_hex(lb))
            msg = to_protocol_error(e).message
            raise ProtocolError(ErrorKind.LANDBLOCK_UNAVAILABLE, f"landblock {lb_hex(lb)} cannot be loaded: {msg}") from None
        self.refresh()
        return {"landblock": lb, "loaded": True, "already": False}

    def unload(self, lb: int) -> dict[str, Any]:
        if lb not in set(self.world.loaded_landblocks()):
            raise ProtocolError(ErrorKind.LANDBLOCK_NOT_LOADED, f"landblock {lb_hex(lb)} is not loaded")
        inside = [r.id for r in self.movers.values() if r.last.position.landblock == lb]
        foreign = self.foreign_movers_in(lb) if self.foreign_movers_in is not None else 0
        if inside or foreign:
            shown = ", ".join(f"{i:X}" for i in inside[:10])
            # other users' movers are counted, never named (service/security/accounts.py)
            others = f"{'; and ' if inside else ''}{foreign} mover(s) of other users" if foreign else ""
            raise ProtocolError(
                ErrorKind.LANDBLOCK_IN_USE,
                f"landblock {lb_hex(lb)} holds {f'{len(inside)} mover(s): {shown}' if inside else ''}{others}", None,
                movers=inside[:100],
            )
        try:
            self.world.unload_landblock(lb)
        except Exception as e:
            raise to_protocol_error(e) from None
        self.refresh()
        return {"landblock": lb, "loaded": False}

    def cache_stats(self) -> dict[str, Any]:
        """The engine's own cache counters, when it keeps any."""
        out: dict[str, Any] = {}
        try:
            raw = getattr(self.world, "stats", None)
            if isinstance(raw, dict):
                out.update(raw)
            fn = getattr(self.world, "cache_stats", None)
            if callable(fn):
                out.update(fn())
        except Exception:  # a stats call must never fail the stats reply
            pass
        return {k: v for k, v in out.items() if isinstance(v, (int, float))}
