"""The synchronous client: talk to acphys service instances over Zenoh.

    with Client() as c:                       # tcp/127.0.0.1:7447, loopback
        st = c.register(spec, Position.at(0xA9B40001, Vec3(10, 10, 52)))
        st = c.move(st.id, offset=(1, 0, 0))

The client remembers which landblock each mover it has seen is in (from
every state it receives) and sends that mover's requests to that
landblock's key; when the service answers that a mover was handed over to
another instance, it follows and retries.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import msgpack
import zenoh

from engine.geometry import Plane, Position, Vec3
from engine.world.types import MoverSpec
from service.codec import encode_mover_spec
from service.messages import REGISTER, RegisterRequest
from service.wire import DEFAULT_PREFIX, MAX_PAYLOAD, PROTOCOL_VERSION, ErrorKind, Keys, user_prefix
from service.zconfig import DEFAULT_ENDPOINT, make_config

from .batch import BatchResults, move_batch
from .spatial import SpatialQueries
from .errors import AcphysError, NoServiceError, RequestTimeout, ServiceError
from .types import InstanceInfo, Move, MoverState, item_result

__all__ = ["Client", "Subscription"]

log = logging.getLogger("acphys.client")

#: Error kinds that say "ask again at landblock `landblock`".
_REDIRECTS = (ErrorKind.MOVED, ErrorKind.WRONG_LANDBLOCK)
_MAX_REDIRECTS = 4
#: most per-landblock request keys kept parsed (`Client._lb_key`)
_KEY_CACHE = 4096


_encode_register = REGISTER.encode_fn()


def _pack(content: dict[str, Any]) -> bytes:
    return msgpack.packb({"v": PROTOCOL_VERSION, **content}, use_bin_type=True)


def _unpack(data: bytes) -> Any:
    return msgpack.unpackb(data, raw=False, strict_map_key=False)


@dataclass(slots=True)
class PendingRequest:
    """A request on its way (`Client._send`): the key it went to, Zenoh's receiver of its replies, and
    the seconds it may take."""

    key: str | zenoh.KeyExpr
    replies: Any
    timeout: float


class Subscription:
    """A live subscription; `close()` (or leaving a `with` block) ends it."""

    def __init__(self, subscribers: list[Any]) -> None:
        self._subs = subscribers

    def close(self) -> None:
        for s in self._subs:
            try:
                s.undeclare()
            except Exception:  # the session may already be closed
                pass
        self._subs = []

    def __enter__(self) -> Subscription:
        return self

    def __exit__(self, *_: object) -> None:
        self.close()


class Client(SpatialQueries):
    def __init__(
        self,
        connect: Sequence[str] | None = None,
        *,
        config_file: str | None = None,
        prefix: str = DEFAULT_PREFIX,
        timeout: float = 5.0,
        session: zenoh.Session | None = None,
        user: str | None = None,
        password: str | None = None,
    ) -> None:
        """Connect to `connect` endpoints (default tcp/127.0.0.1:7447) or as a zenoh config file says.

        `user` and `password`: log in to a service run with accounts (`acphys serve --users`); the client then
        speaks under `prefix/u/user`, where that user's movers are (docs/protocol.md, "Accounts")."""
        self.user = user
        self.keys = Keys(user_prefix(prefix, user) if user is not None else prefix)
        self.timeout = timeout
        self._own_session = session is None
        if session is None:
            if config_file is None and not connect:
                connect = [DEFAULT_ENDPOINT]
            session = zenoh.open(make_config(config_file=config_file, connect=list(connect or []),
                                             user=user, password=password))
        self.session = session
        self._where: dict[int, int] = {}
        # fire-and-forget keeps one route per mover: the old owner forwards after a hand-over,
        # in order, where switching keys mid-stream could overtake moves still in flight
        self._push_route: dict[int, int] = {}
        self._lock = threading.Lock()
        # per-landblock request keys as parsed key expressions: Zenoh parses a string key on every get
        self._lb_keys: dict[tuple[int, str], zenoh.KeyExpr] = {}

    # -- lifecycle ------------------------------------------------------------------
    def close(self) -> None:
        if self._own_session and not self.session.is_closed():
            self.session.close()

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *_: object) -> None:
        self.close()

    # -- plumbing -------------------------------------------------------------------
    def _learn(self, st: MoverState) -> MoverState:
        self._where[st.id] = st.landblock
        return st

    def locate(self, mover_id: int, landblock: int) -> None:
        """Tell the client where a mover it has not seen is (e.g. registered by another client)."""
        self._where[mover_id] = landblock

    def landblock_of(self, mover_id: int) -> int:
        """Where the mover is, as last seen; asks every instance when it has not been seen."""
        lb = self._where.get(mover_id)
        if lb is None:
            lb = self.find(mover_id).landblock
        return lb

    def find(self, mover_id: int, timeout: float | None = None) -> MoverState:
        """Ask every instance for the mover (a `get` on every landblock key); its state."""
        errors: list[ServiceError] = []
        for r in self._replies_of_all(self.keys.lb("*", "get"), {"id": mover_id}, timeout):
            if r.ok is not None:
                msg = _unpack(r.ok.payload.to_bytes())
                return self._learn(MoverState.from_wire(msg["state"]))
            try:
                errors.append(ServiceError.from_wire(_unpack(r.err.payload.to_bytes())["error"]))
            except Exception:
                continue
        for e in errors:
            if e.kind == ErrorKind.MOVED and isinstance(e.details.get("landblock"), int):
                self._where[mover_id] = e.details["landblock"]
                return self.get(mover_id, timeout)[0]
        if errors:
            raise errors[0]
        raise NoServiceError(f"no service instance answers for mover {mover_id:X}")

    def _lb_key(self, lb: int, op: str) -> zenoh.KeyExpr:
        """`P/lb/XXYY/op`, parsed once."""
        key = self._lb_keys.get((lb, op))
        if key is None:
            if len(self._lb_keys) >= _KEY_CACHE:
                self._lb_keys.clear()
            key = self._lb_keys[lb, op] = zenoh.KeyExpr(self.keys.lb(lb, op))
        return key

    def _replies_of_all(self, key: str | zenoh.KeyExpr, content: dict[str, Any], timeout: float | None) -> list[Any]:
        """Every instance's reply to one query (`key` may match many)."""
        return list(self.session.get(key, payload=_pack(content), timeout=self.timeout if timeout is None else timeout,
                                     target=zenoh.QueryTarget.ALL, consolidation=zenoh.ConsolidationMode.NONE))

    def _send(self, key: str | zenoh.KeyExpr, content: dict[str, Any], timeout: float | None = None) -> PendingRequest:
        """Put one request to the instance serving `key` on the bus and return at once (Zenoh gathers its
        reply meanwhile): a batch sends every landblock's request before it reads any reply, so that the
        instances (or `--workers`' engines) serving them work at the same time."""
        wait = self.timeout if timeout is None else timeout
        return PendingRequest(key, self.session.get(key, payload=_pack(content), timeout=wait), wait)

    def _receive(self, pending: PendingRequest) -> dict[str, Any]:
        """The reply map of a request `_send` sent (waiting for it), or an exception."""
        key, timeout = pending.key, pending.timeout
        replies = list(pending.replies)
        if not replies:
            raise NoServiceError(f"no service answers on {key}")
        r = replies[0]
        if r.ok is not None:
            msg = _unpack(r.ok.payload.to_bytes())
            if not isinstance(msg, dict):
                raise ServiceError(ErrorKind.MALFORMED, f"unreadable reply on {key}")
            return msg
        raw = r.err.payload.to_bytes()
        try:
            err = _unpack(raw)["error"]
        except Exception:
            text = raw.decode("utf-8", "replace")
            if "timeout" in text.lower():
                raise RequestTimeout(f"no answer on {key} within {timeout} s") from None
            raise ServiceError(ErrorKind.MALFORMED, f"unreadable error reply on {key}: {text}") from None
        raise ServiceError.from_wire(err)

    def _request(self, key: str | zenoh.KeyExpr, content: dict[str, Any], timeout: float | None = None) -> dict[str, Any]:
        """One request to the instance serving `key`: its reply map, or an exception."""
        return self._receive(self._send(key, content, timeout))

    def _lb_request(self, lb: int, op: str, content: dict[str, Any], mover_id: int | None = None,
                    timeout: float | None = None) -> dict[str, Any]:
        """A per-landblock request, following `moved` / `wrong_landblock` redirects."""
        for _ in range(_MAX_REDIRECTS):
            try:
                return self._request(self._lb_key(lb, op), content, timeout)
            except ServiceError as e:
                target = e.details.get("landblock")
                if e.kind not in _REDIRECTS or not isinstance(target, int) or target == lb:
                    raise
                lb = target
                if mover_id is not None:
                    self._where[mover_id] = lb
        return self._request(self.keys.lb(lb, op), content, timeout)

    def _all(self, key: str, timeout: float | None) -> list[InstanceInfo]:
        out = []
        for r in self._replies_of_all(key, {}, timeout):
            if r.ok is None:
                continue
            msg = _unpack(r.ok.payload.to_bytes())
            if isinstance(msg, dict):
                out.append(InstanceInfo(str(msg.get("instance", "?")), msg))
        return out

    # -- movers -----------------------------------------------------------------------
    def register(
        self,
        spec: MoverSpec,
        position: Position,
        *,
        contact_plane: Plane | None = None,
        contact_plane_cell: int | None = None,
        sliding_normal: Vec3 | None = None,
        water_contact: bool = False,
        mover_id: int | None = None,
        timeout: float | None = None,
    ) -> MoverState:
        """Add a mover at `position`; its id is `mover_id` or one the service assigns."""
        content = _encode_register(RegisterRequest(mover_id, spec, position, contact_plane, contact_plane_cell,
                                                   sliding_normal, water_contact or None))
        reply = self._lb_request(position.landblock, "register", content, timeout=timeout)
        return self._learn(MoverState.from_wire(reply["state"]))

    def update(self, mover_id: int, spec: MoverSpec, timeout: float | None = None) -> MoverState:
        reply = self._lb_request(self.landblock_of(mover_id), "update",
                                 {"id": mover_id, "mover": encode_mover_spec(spec)}, mover_id, timeout)
        return self._learn(MoverState.from_wire(reply["state"]))

    def remove(self, mover_id: int, timeout: float | None = None) -> None:
        self._lb_request(self.landblock_of(mover_id), "remove", {"id": mover_id}, mover_id, timeout)
        self._where.pop(mover_id, None)
        self._push_route.pop(mover_id, None)

    def get(self, mover_id: int, timeout: float | None = None) -> tuple[MoverState, dict[str, Any]]:
        """A mover's current state and its spec (as the wire map)."""
        reply = self._lb_request(self.landblock_of(mover_id), "get", {"id": mover_id}, mover_id, timeout)
        return self._learn(MoverState.from_wire(reply["state"])), reply["mover"]

    # -- moves --------------------------------------------------------------------------
    def move(
        self,
        mover_id: int,
        to: Position | None = None,
        *,
        offset: Vec3 | tuple[float, float, float] | None = None,
        velocity: Vec3 | tuple[float, float, float] | None = None,
        tag: int | str | None = None,
        timeout: float | None = None,
    ) -> MoverState:
        """One transition toward `to` (or current position + `offset`); raises ServiceError on failure."""
        return self.send(Move(mover_id, to=to, offset=offset, velocity=velocity, tag=tag), timeout)

    def step(self, mover_id: int, motion: Vec3 | tuple[float, float, float], dt: float, *,
             tag: int | str | None = None, timeout: float | None = None) -> MoverState:
        """One physics step: own motion `motion` (object frame) over `dt` seconds, with gravity."""
        return self.send(Move(mover_id, motion=motion, dt=dt, tag=tag), timeout)

    def send(self, move: Move, timeout: float | None = None) -> MoverState:
        lb = self.landblock_of(move.id)
        reply = self._lb_request(lb, "move", {"move": move.to_wire()}, move.id, timeout)
        return self._learn(MoverState.from_wire(reply["state"]))

    def move_many(self, moves: Sequence[Move], timeout: float | None = None,
                  publish: str | None = None) -> list[MoverState | AcphysError]:
        """A batch: one request per landblock (all sent before any reply is read), each mover's moves in order.

        Returns one entry per move, in order: its State, or the error for that move alone.
        `publish="batch"`: the service publishes each request's States as one message on
        `P/states` (see `subscribe_batches`) instead of one per mover on its state key.
        """
        out: list[MoverState | AcphysError] = []
        for entry in self._move_many(moves, timeout, publish):
            if isinstance(entry, AcphysError):
                out.append(entry)
                continue
            r = item_result(entry)
            out.append(self._learn(r) if isinstance(r, MoverState) else r)
        return out

    def move_many_maps(self, moves: Sequence[Move], timeout: float | None = None,
                       publish: str | None = None) -> list[dict[str, Any] | AcphysError]:
        """`move_many` without building objects: each move's entry as the service sent it (a State map,
        or `{"id", "tag"?, "error"}`: docs/protocol.md, Move reply), or an AcphysError when its request
        failed. For callers that read a few fields, or pass the states on: decoding every State into a
        MoverState costs the client more CPU than the service spends packing it. The entries are not
        validated; the client only learns each mover's landblock from them (to route its next request)."""
        return self._move_many(moves, timeout, publish)

    def _move_many(self, moves: Sequence[Move], timeout: float | None,
                   publish: str | None = None) -> list[dict[str, Any] | AcphysError]:
        """Send the batch grouped by landblock, follow redirects; the raw entries in the moves' order."""
        results: list[dict[str, Any] | AcphysError | None] = [None] * len(moves)
        pending = list(range(len(moves)))
        for attempt in range(_MAX_REDIRECTS + 1):
            groups: dict[int, list[int]] = {}
            for i in pending:
                m = moves[i]
                try:
                    lb = self.landblock_of(m.id)
                except AcphysError as e:
                    results[i] = e
                    continue
                groups.setdefault(lb, []).append(i)
            retry: list[int] = []
            sent: list[tuple[list[int], PendingRequest]] = []
            for lb, idx in groups.items():  # every landblock's request on its way before any reply is read
                body: dict[str, Any] = {"moves": [moves[i].to_wire() for i in idx]}
                if publish is not None:
                    body["publish"] = publish
                sent.append((idx, self._send(self._lb_key(lb, "move"), body, timeout)))
            for idx, pending_request in sent:
                try:
                    reply = self._receive(pending_request)
                except AcphysError as e:
                    for i in idx:
                        results[i] = e
                    continue
                entries = reply.get("results")
                if not isinstance(entries, list) or len(entries) != len(idx):
                    err = ServiceError(ErrorKind.MALFORMED, "batch reply does not match the request")
                    for i in idx:
                        results[i] = err
                    continue
                where = self._where
                for i, entry in zip(idx, entries):
                    if type(entry) is not dict:
                        results[i] = ServiceError(ErrorKind.MALFORMED, f"unreadable entry in reply: {entry!r:.80}")
                        continue
                    err_map = entry.get("error")
                    if err_map is None:
                        mid, elb = entry.get("id"), entry.get("landblock")
                        if type(mid) is int and type(elb) is int:
                            where[mid] = elb
                        results[i] = entry
                        continue
                    target = err_map.get("landblock") if isinstance(err_map, dict) else None
                    if isinstance(err_map, dict) and err_map.get("kind") in _REDIRECTS and isinstance(target, int) \
                            and attempt < _MAX_REDIRECTS:
                        where[moves[i].id] = target
                        retry.append(i)
                        continue
                    results[i] = entry
            if not retry:
                break
            pending = sorted(retry)
        return [r if r is not None else AcphysError("no result") for r in results]

    def move_batch(self, ids: Any, offsets: Any = None, targets: Any = None, motions: Any = None, dt: Any = None,
                   *, cells: Any = None, orientations: Any = None, velocities: Any = None,
                   publish: str | None = None, timeout: float | None = None) -> BatchResults:
        """A batch in the column form (docs/protocol.md, "Column batches"): numpy arrays in and out.

        `ids` (n,) mover ids and exactly one of: `offsets` (n, 3); `targets` (n, 3) origins, with
        optional `cells` (n,) (0: the mover's current cell) and `orientations` (n, 4) (all zeros:
        the current one); `motions` (n, 3) with `dt` (n,) or one number. `velocities` (n, 3) goes
        with offsets or targets. One request per landblock, all sent before any reply is read (the
        instances serving them work at the same time); a mover handed over meanwhile is followed.
        `publish`: "each" (default), "batch" or "columns" (one columnar message on
        `P/state_columns`). Returns the results in the moves' order; failed moves are in
        `errors` by index. ValueError for arguments of the wrong shape or combination. Needs an
        instance whose Health lists "columns" in `move_forms`.
        """
        return move_batch(self, ids, offsets, targets, motions, dt, cells=cells, orientations=orientations,
                          velocities=velocities, publish=publish, timeout=timeout)

    def push(self, moves: Sequence[Move], publish: str | None = None) -> None:
        """Fire-and-forget: states arrive on the state keys (with `publish="batch"`, on `P/states`, one
        message per request), errors on the error keys."""
        groups: dict[int, list[dict[str, Any]]] = {}
        for m in moves:
            lb = self._push_route.get(m.id)
            if lb is None:
                lb = self._push_route[m.id] = self.landblock_of(m.id)
            groups.setdefault(lb, []).append(m.to_wire())
        bodies = []
        for lb, items in groups.items():
            body: dict[str, Any] = {"move": items[0]} if len(items) == 1 else {"moves": items}
            if publish is not None:
                body["publish"] = publish
            payload = _pack(body)
            if len(payload) > MAX_PAYLOAD:
                # the service would refuse it; and a put this large may be dropped on the way by Zenoh's
                # congestion control (DROP, the default for puts) without anyone hearing of it
                raise ServiceError(ErrorKind.TOO_LARGE, f"push of {len(payload)} bytes exceeds {MAX_PAYLOAD}; "
                                   "send fewer moves per push")
            bodies.append((lb, payload))
        for lb, payload in bodies:  # all checked first: nothing of a refused push is sent
            self.session.put(self.keys.push(lb), payload)

    # -- subscriptions -------------------------------------------------------------------
    def subscribe(self, callback: Callable[[MoverState], None], mover_id: int | None = None) -> Subscription:
        """Call `callback` with every state published for `mover_id` (or every mover)."""
        key = self.keys.state(mover_id if mover_id is not None else "*")

        def on_sample(sample: zenoh.Sample) -> None:
            try:
                st = MoverState.from_wire(_unpack(sample.payload.to_bytes())["state"])
            except Exception:
                log.warning("unreadable state on %s", sample.key_expr)
                return
            self._learn(st)
            callback(st)

        return Subscription([self.session.declare_subscriber(key, on_sample)])

    def subscribe_batches(self, callback: Callable[[list[MoverState]], None]) -> Subscription:
        """Call `callback` with the States of every request sent with `publish="batch"`, one list per request."""

        def on_sample(sample: zenoh.Sample) -> None:
            try:
                states = [MoverState.from_wire(m) for m in _unpack(sample.payload.to_bytes())["states"]]
            except Exception:
                log.warning("unreadable states on %s", sample.key_expr)
                return
            for st in states:
                self._learn(st)
            callback(states)

        return Subscription([self.session.declare_subscriber(self.keys.states, on_sample)])

    def subscribe_errors(self, callback: Callable[[int | None, ServiceError], None],
                         mover_id: int | None = None) -> Subscription:
        """Errors of fire-and-forget moves: `callback(mover_id or None, error)`."""

        def on_sample(sample: zenoh.Sample) -> None:
            try:
                msg = _unpack(sample.payload.to_bytes())
                callback(msg.get("id"), ServiceError.from_wire(msg["error"]))
            except Exception:
                log.warning("unreadable error message on %s", sample.key_expr)

        subs = [self.session.declare_subscriber(self.keys.obj_error(mover_id if mover_id is not None else "*"), on_sample)]
        if mover_id is None:
            subs.append(self.session.declare_subscriber(self.keys.errors, on_sample))
        return Subscription(subs)

    # -- landblocks, health, stats -------------------------------------------------------------
    def load_landblock(self, lb: int, timeout: float | None = None) -> bool:
        """Load a landblock on its owner; True when it was loaded already."""
        return bool(self._request(self.keys.lb(lb, "load"), {}, timeout).get("already"))

    def unload_landblock(self, lb: int, timeout: float | None = None) -> None:
        self._request(self.keys.lb(lb, "unload"), {}, timeout)

    def landblocks(self, timeout: float | None = None) -> list[InstanceInfo]:
        """Every instance's owned and loaded landblocks."""
        return self._all(self.keys.landblocks, timeout)

    def health(self, timeout: float | None = None) -> list[InstanceInfo]:
        return self._all(self.keys.health, timeout)

    def stats(self, timeout: float | None = None) -> list[InstanceInfo]:
        return self._all(self.keys.stats, timeout)

    def wait_ready(self, instances: int = 1, timeout: float = 10.0) -> list[InstanceInfo]:
        """Block until `instances` instances answer on the health key."""
        import time

        deadline = time.monotonic() + timeout
        while True:
            found = [h for h in self.health(timeout=1.0) if h.get("status") == "ok"]
            if len(found) >= instances:
                return found
            if time.monotonic() >= deadline:
                raise RequestTimeout(f"{len(found)} of {instances} service instance(s) ready after {timeout} s")
            time.sleep(0.05)

