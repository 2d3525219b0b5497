"""The synchronous client: talk to acphys service instances over Zenoh.

    with Client() as c:                       # tcp/127.0.0.1:7447, loopback
        st = c.register(spec, Position.at(0xA9B40001, Vec3(10, 10, 52)))
        st = c.move(st.id, offset=(1, 0, 0))

docs/client.md is the guide to every public call (generated from these
docstrings by `python3 -m clients.docgen`); docs/protocol.md the wire
protocol underneath.

The client remembers which landblock each mover it has seen is in (from
every state it receives) and sends that mover's requests to that
landblock's key; when the service answers that a mover was handed over to
another instance, it follows and retries.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import zenoh

from engine.geometry import Plane, Position, Vec3
from engine import MoverSpec
from service.protocol.codec import encode_mover_spec
from service.protocol.messages import REGISTER, RegisterRequest
from service.protocol.wire import DEFAULT_PREFIX, MAX_PAYLOAD, ErrorKind, Keys, user_prefix
from service.bus.zconfig import DEFAULT_ENDPOINT, make_config

from clients.batch import BatchResults, move_batch
from clients.paths import PathQueries
from clients.request_channel import PendingRequest, pack_request, read_reply, send_query, unpack_message
from clients.spatial import SpatialQueries
from clients.errors import AcphysError, NoServiceError, RequestTimeout, ServiceError
from clients.types import InstanceInfo, Move, MoverState, item_result

__all__ = ["Client", "Subscription"]

log = logging.getLogger("acphys.client")

#: Error kinds that say "ask again at landblock `landblock`".
_REDIRECTS = (ErrorKind.MOVED, ErrorKind.WRONG_LANDBLOCK)
_MAX_REDIRECTS = 4
#: most per-landblock request keys kept parsed (`Client._lb_key`)
_KEY_CACHE = 4096
#: Seconds a new peer session takes to meet every instance of a cluster. It connects to one endpoint and
#: meets the other instances through Zenoh's gossip, whose queryables it learns about 0.1 s after opening
#: (measured on loopback); a query sent sooner reaches only the instances met so far (`acphys stats` listed
#: one instance of two in half the tries). A query to every instance (health, stats, landblocks) waits until
#: the client is this old (so does `find`), and a request to one landblock that nobody answered is sent again
#: then.
SETTLE_S = 0.5


_encode_register = REGISTER.encode_fn()


class Subscription:
    """A live subscription, as `Client.subscribe`, `subscribe_batches` and `subscribe_errors` return it.

    Its callback keeps being called (on a Zenoh thread) until `close()`, or the end of a `with` block:

        with client.subscribe(print, mover_id):
            client.move(mover_id, offset=(1, 0, 0))
    """

    def __init__(self, subscribers: list[Any]) -> None:
        self._subs = subscribers

    def close(self) -> None:
        """Stop the callbacks (undeclare the Zenoh subscribers). Safe to call twice, and after the client
        closed; raises nothing."""
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


class Client(SpatialQueries, PathQueries):
    """A connection to the acphys service: register movers, move them, ask the spatial queries and paths,
    watch States.

    One Zenoh session (opened here, or the `session=` given) reaches every instance of a service, however
    many share its landblocks: each request goes to the key of the landblock it concerns, and the client
    follows a mover that was handed over to another instance by itself (`moved`, `wrong_landblock`).
    Use it as a context manager, or call `close()`.

    Units and ids, as in docs/protocol.md ("Common values"):

    - a place is an `engine.Position`: a cell id and an origin. Cell ids are 32-bit, written in hex,
      `0xXXYYIIII`: landblock XXYY (the high 16 bits), cell index IIII (outdoor cells 0x0001..0x0040,
      indoor EnvCells 0x0100..0xFFFD). `Position.at(0xA9B4000B, Vec3(40.0, 50.0, 42.8))`.
    - origins are landblock-local metres: x east and y north from the landblock's south-west corner
      (0 .. 192 m), z the absolute height; orientations are unit quaternions (w, x, y, z), identity
      facing north. A landblock, as methods take and return it, is the 16-bit 0xXXYY.
    - offsets, motions and other vectors are metres (velocities metres per second), durations seconds;
      `timeout` arguments are seconds to wait for an answer (None: the client's `timeout`).
    - mover ids are unsigned 64-bit integers (the service assigns ids of 2^32 and above).

    Errors (clients.errors; all are `AcphysError`):

    - `ServiceError`: the service refused the request; `kind` is the error kind of docs/protocol.md
      ("Errors": `unknown_mover`, `bad_value`, `non_finite`, `landblock_not_loaded`, ...), `path` the
      offending field, `details` the whole error map. Nothing is changed by a refused request.
    - `BusyError` (a ServiceError of kind `busy`): the instance's queue was full and nothing ran; retry.
    - `NoServiceError`: no instance answered: none running at the endpoint, another `prefix`, or no
      instance owns the landblock.
    - `RequestTimeout` (also a `TimeoutError`): an instance took the request but did not answer within
      the timeout.

    Batch calls (`move_many`, `move_batch`, `sights`, the `*_columns` queries, ...) report a failed item
    in its place and go on with the others. `user` and `password` log in to a service run with accounts.
    The attributes `session` (the Zenoh session), `keys` (the key expressions under the prefix), `user`
    and `timeout` may be read. Threads may share one client for requests (`AsyncClient` runs each
    call on a thread of its own over one).
    """

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

        `connect`: Zenoh endpoints, such as `["tcp/127.0.0.1:7447"]`; `config_file`: a Zenoh JSON5 config
        file instead (`connect` given with it applies on top). `prefix`: the service's key prefix (`acphys`
        by default; a service started with `--prefix` needs the same). `timeout`: seconds each request may
        wait for its answer unless the call says otherwise. `session`: an open Zenoh session to use
        instead of opening one (then `close()` leaves it open).

        `user` and `password`: log in to a service run with accounts (`acphys serve --users`); the client then
        speaks under `prefix/u/user`, where that user's movers are (docs/protocol.md, "Accounts").

        Nothing is asked of the service here: a wrong endpoint or prefix shows at the first request, as
        `NoServiceError` (`wait_ready` checks at once). Raises ValueError for a user name that cannot be
        one, and Zenoh's own error (`zenoh.ZError`) when Zenoh refuses the configuration (an endpoint
        not of the form `tcp/HOST:PORT`, a config file it cannot read)."""
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
        #: where the client looked, for a NoServiceError to say
        self._tried = (f"connected {'by ' + config_file if config_file else 'to ' + ', '.join(connect or [])}"
                       if not (session is not None and not self._own_session) else "on the session given")
        self._tried += f", prefix '{prefix}'" + (f", user '{user}'" if user is not None else "")
        self._opened = time.monotonic()  # a young session may not have met every instance yet (SETTLE_S)
        #: mover id -> the landblock (0xXXYY) the client last saw it in: what `landblock_of` reads, every State
        #: received updates, and a batch records where its movers ended (clients/request_channel.py)
        self.known_landblocks: dict[int, int] = {}
        # fire-and-forget keeps one route per mover: the old owner forwards after a hand-over,
        # in order, where switching keys mid-stream could overtake moves still in flight
        self._push_route: dict[int, int] = {}
        self._lock = threading.Lock()
        # per-landblock request keys as parsed key expressions: Zenoh parses a string key on every get
        self._lb_keys: dict[tuple[int, str], zenoh.KeyExpr] = {}

    # -- lifecycle ------------------------------------------------------------------
    def close(self) -> None:
        """Close the Zenoh session the client opened (not one given as `session=`); its subscriptions end
        with it. Safe to call twice."""
        if self._own_session and not self.session.is_closed():
            self.session.close()

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *_: object) -> None:
        self.close()

    # -- plumbing -------------------------------------------------------------------
    def _learn(self, st: MoverState) -> MoverState:
        self.known_landblocks[st.id] = st.landblock
        return st

    def locate(self, mover_id: int, landblock: int) -> None:
        """Tell the client that mover `mover_id` is in landblock `landblock` (0xXXYY), for a mover it has
        not seen (e.g. registered by another client): its requests then go to that landblock's key at
        once, without `find` asking every instance. Asks nothing of the service; a wrong landblock is
        corrected by the service's `moved` / `wrong_landblock` answer, which the client follows."""
        self.known_landblocks[mover_id] = landblock

    def landblock_of(self, mover_id: int) -> int:
        """The landblock (0xXXYY) mover `mover_id` is in, as last seen in any State the client received;
        asks every instance (`find`) when it has not been seen. Raises what `find` raises."""
        lb = self.known_landblocks.get(mover_id)
        if lb is None:
            lb = self.find(mover_id).landblock
        return lb

    def find(self, mover_id: int, timeout: float | None = None) -> MoverState:
        """Ask every instance for mover `mover_id` (a `get` on every landblock key) and return its
        current State; the client remembers its landblock. Raises ServiceError (`unknown_mover`) when the
        instances answer that they hold no such mover, NoServiceError when no instance answers at all;
        `timeout` in seconds. A client younger than half a second first waits until it is that old (SETTLE_S): a new session
        meets a cluster's other instances some 0.1 s after it connects, and would miss their answers."""
        errors: list[ServiceError] = []
        self._settle()
        for r in self._replies_of_all(self.keys.lb("*", "get"), {"id": mover_id}, timeout):
            if r.ok is not None:
                msg = unpack_message(r.ok.payload.to_bytes())
                return self._learn(MoverState.from_wire(msg["state"]))
            try:
                errors.append(ServiceError.from_wire(unpack_message(r.err.payload.to_bytes())["error"]))
            except Exception:
                continue
        for e in errors:
            if e.kind == ErrorKind.MOVED and isinstance(e.details.get("landblock"), int):
                self.known_landblocks[mover_id] = e.details["landblock"]
                return self.get(mover_id, timeout)[0]
        if errors:
            raise errors[0]
        raise NoServiceError(f"no service instance answers for mover {mover_id:X} ({self._tried})")

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
        return list(self.session.get(key, payload=pack_request(content), timeout=self.timeout if timeout is None else timeout,
                                     target=zenoh.QueryTarget.ALL, consolidation=zenoh.ConsolidationMode.NONE))

    def send_request(self, key: str | zenoh.KeyExpr, content: dict[str, Any],
                     timeout: float | None = None) -> PendingRequest:
        """Plumbing: put one request to the instance serving `key` on the bus and return at once (Zenoh
        gathers its reply meanwhile): a batch sends every landblock's request before it reads any reply,
        so that the instances (or `--workers`' engines) serving them work at the same time."""
        return send_query(self.session, key, content, self.timeout if timeout is None else timeout)

    def receive_reply(self, pending: PendingRequest) -> dict[str, Any]:
        """Plumbing: the reply map of a request `send_request` sent (waiting for it), or the AcphysError
        it says."""
        return read_reply(pending, self._tried, self.user is not None)

    def _request(self, key: str | zenoh.KeyExpr, content: dict[str, Any], timeout: float | None = None) -> dict[str, Any]:
        """One request to the instance serving `key`: its reply map, or an exception."""
        try:
            return self.receive_reply(self.send_request(key, content, timeout))
        except NoServiceError:
            # nobody had it (so sending again repeats nothing); a young session may not have met the instance
            # serving `key` yet (SETTLE_S): once it has, ask again
            if not self._settle():
                raise
            return self.receive_reply(self.send_request(key, content, timeout))

    def _settle(self) -> bool:
        """Wait until the session is SETTLE_S old (it has met every instance); whether it had to wait."""
        wait = self._opened + SETTLE_S - time.monotonic()
        if wait <= 0:
            return False
        time.sleep(wait)
        return True

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
                    self.known_landblocks[mover_id] = lb
        return self._request(self.keys.lb(lb, op), content, timeout)

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
        """Add a mover of shape `spec` at `position` and return its first State (seq 0, `NoTransition`).

        `position`: a cell id (hex, `0xXXYYIIII`) and a landblock-local origin in metres; the request goes
        to that landblock's owner. The mover's id is `mover_id` (an unsigned 64-bit id > 0, such as an
        object's guid) or one the service assigns (>= 2^32): read it as the State's `id`.

        It starts in contact with `contact_plane` (in the frame of `contact_plane_cell`'s landblock,
        default `position`'s cell) when `spec.state` holds `Contact` (and `OnWalkable` to stand on it);
        `Client.place`'s answer gives a position and plane to start from. `sliding_normal`: a unit
        horizontal vector it starts sliding along (or (0, 0, 0), as a State may give it);
        `water_contact`: it starts in water. Nothing is placed or dropped: it stays where it is put
        until moved (docs/protocol.md, "Register").

        Raises ServiceError: `duplicate_mover` (the id is taken), `unknown_cell`, `landblock_not_loaded`,
        `bad_value` / `non_finite` / `wrong_type` naming the field (values outside docs/protocol.md's
        "Limits on values"); NoServiceError when no instance owns the landblock; RequestTimeout."""
        content = _encode_register(RegisterRequest(mover_id, spec, position, contact_plane, contact_plane_cell,
                                                   sliding_normal, water_contact or None))
        reply = self._lb_request(position.landblock, "register", content, timeout=timeout)
        return self._learn(MoverState.from_wire(reply["state"]))

    def update(self, mover_id: int, spec: MoverSpec, timeout: float | None = None) -> MoverState:
        """Give mover `mover_id` a new shape and flags `spec`, keeping its position and contact state; its
        State. Raises ServiceError (`unknown_mover`, or a field error naming the part of `spec` refused),
        NoServiceError, RequestTimeout."""
        reply = self._lb_request(self.landblock_of(mover_id), "update",
                                 {"id": mover_id, "mover": encode_mover_spec(spec)}, mover_id, timeout)
        return self._learn(MoverState.from_wire(reply["state"]))

    def remove(self, mover_id: int, timeout: float | None = None) -> None:
        """Remove mover `mover_id` from the world; the client forgets where it was. Raises ServiceError
        (`unknown_mover` when no instance holds it), NoServiceError, RequestTimeout."""
        self._lb_request(self.landblock_of(mover_id), "remove", {"id": mover_id}, mover_id, timeout)
        self.known_landblocks.pop(mover_id, None)
        self._push_route.pop(mover_id, None)

    def get(self, mover_id: int, timeout: float | None = None) -> tuple[MoverState, dict[str, Any]]:
        """Mover `mover_id`'s current State and its spec as registered or last updated (the MoverSpec as
        its wire map: docs/protocol.md, "MoverSpec"). Changes nothing. Raises ServiceError
        (`unknown_mover`), NoServiceError, RequestTimeout."""
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
        """One transition of mover `mover_id` toward `to`, or toward its current origin plus `offset`;
        its State after it.

        `to`: a Position (its cell id names the frame of its origin; the transition finds the real cell);
        `offset`: metres in the landblock frame (x east, y north, z up), same cell and orientation.
        Exactly one of them. `velocity`: metres per second the mover has while this move is resolved (what
        contact checks and collision responses see; at most 1000 m/s). `tag`: an int or a string of at
        most 256 characters, echoed in the State. A move that finds no position answers `ok` False with
        the mover where it was; that is a State, not an error (docs/protocol.md, "Move request").

        Raises ServiceError: `missing_field` / `bad_value` for neither or both of `to` and `offset`,
        `unknown_mover`, `bad_value` (a target outside docs/protocol.md's "Limits on values": the path
        names the target's axis), `non_finite`, `no_owner` (the move would leave every instance's
        landblocks; it is taken back); NoServiceError, RequestTimeout."""
        return self.send(Move(mover_id, to=to, offset=offset, velocity=velocity, tag=tag), timeout)

    def step(self, mover_id: int, motion: Vec3 | tuple[float, float, float], dt: float, *,
             tag: int | str | None = None, timeout: float | None = None) -> MoverState:
        """One physics step of mover `mover_id` over `dt` seconds; its State after it.

        `motion`: the mover's own motion over `dt`, in metres, in its own frame (y forward, x right,
        z up): walking north at 4 m/s with identity orientation is `(0, 0.8, 0)` per 0.2 s step. It acts
        only while the mover stands on walkable ground; velocity, gravity and friction act always
        (UpdateObjectInternal, then the transition). `dt`: more than 0, at most 2 s. As the client spends
        a frame: time under 1/30 s is held with its motion until later steps bring enough (that step
        answers `NoTransition`), longer time runs as steps of at most 0.2 s. In the air own motion does
        nothing, and the first step of a mover at rest there only gives it its velocity under gravity
        (`NoTransition`): it falls from the next step on.

        Raises ServiceError: `unknown_mover`, `bad_value` (`dt` out of range, a motion component beyond
        384 m), `non_finite`, `no_owner`; NoServiceError, RequestTimeout."""
        return self.send(Move(mover_id, motion=motion, dt=dt, tag=tag), timeout)

    def send(self, move: Move, timeout: float | None = None) -> MoverState:
        """Send one `Move` (a transition or a physics step, as `move` and `step`) and return the mover's
        State after it. Raises as `move` and `step` do."""
        lb = self.landblock_of(move.id)
        reply = self._lb_request(lb, "move", {"move": move.to_wire()}, move.id, timeout)
        return self._learn(MoverState.from_wire(reply["state"]))

    def move_many(self, moves: Sequence[Move], timeout: float | None = None,
                  publish: str | None = None) -> list[MoverState | AcphysError]:
        """A batch: one request per landblock (all sent before any reply is read), each mover's moves in order.

        `moves`: `Move`s (transitions or physics steps, mixed as wanted), at most 4096 per landblock.
        Returns one entry per move, in order: its State, or the error for that move alone (a
        ServiceError such as `unknown_mover` for the item; NoServiceError or RequestTimeout for every
        move of a landblock whose request went unanswered). A failed move does not stop the others, and
        no AcphysError is raised: look at each entry. A mover handed over meanwhile is followed.
        `publish="batch"`: the service publishes each request's States as one message on
        `P/states` (see `subscribe_batches`) instead of one per mover on its state key
        (None or "each": one per mover).
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
                sent.append((idx, self.send_request(self._lb_key(lb, "move"), body, timeout)))
            for idx, pending_request in sent:
                try:
                    reply = self.receive_reply(pending_request)
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
                where = self.known_landblocks
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

        `ids` (n,) mover ids and exactly one of: `offsets` (n, 3) metres in the landblock frame;
        `targets` (n, 3) landblock-local origins in metres, with optional `cells` (n,) cell ids (0: the
        mover's current cell) and `orientations` (n, 4) w x y z (all zeros: the current one); `motions`
        (n, 3) metres of own motion in each mover's frame with `dt` (n,) seconds or one number (as
        `step`). `velocities` (n, 3) metres per second goes with offsets or targets. Each item is the
        `move` or `step` it stands for, answered bit for bit as that would be.

        One request per landblock, all sent before any reply is read (the instances serving them work
        at the same time); a mover handed over meanwhile is followed.
        `publish`: "each" (default), "batch" or "columns" (one columnar message on
        `P/state_columns`). Returns a `BatchResults`: one row per move in the moves' order; a failed
        move's row holds the missing values and its error (ServiceError, NoServiceError,
        RequestTimeout) is in `errors` by index: no AcphysError is raised. ValueError for arguments of
        the wrong shape or combination. Needs an instance whose Health lists "columns" in
        `move_forms`.
        """
        return move_batch(self, ids, offsets, targets, motions, dt, cells=cells, orientations=orientations,
                          velocities=velocities, publish=publish, timeout=timeout)

    def push(self, moves: Sequence[Move], publish: str | None = None) -> None:
        """Fire-and-forget: put `moves` on the bus without waiting for any answer.

        States arrive on the state keys (`subscribe`; with `publish="batch"`, on `P/states`, one
        message per request: `subscribe_batches`), errors on the error keys (`subscribe_errors`); a
        mover's moves keep their order. One put per landblock. Raises ServiceError (`too_large`) when
        a landblock's share is over 4 MiB, and then nothing of the push is sent; `landblock_of`'s
        errors for a mover the client has not seen. A put nobody serves is lost without a word
        (docs/protocol.md, "Transport")."""
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
            payload = pack_request(body)
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
        """Call `callback` with every State published for `mover_id` (or for every mover, when None).

        The service publishes a State after every resolved move (request-reply and fire-and-forget,
        with the default `publish`) and register, in `seq` order per mover. The callback runs on a
        Zenoh thread: keep it short, and hand the State to your own thread (a queue) for real work. A
        subscription receives what is published after its declaration reached the service, which takes
        a moment; a gap in a mover's `seq` means a State was missed. Returns the `Subscription`:
        `close()` it, or use it in a `with` block. Unreadable messages are logged and skipped."""
        key = self.keys.state(mover_id if mover_id is not None else "*")

        def on_sample(sample: zenoh.Sample) -> None:
            try:
                st = MoverState.from_wire(unpack_message(sample.payload.to_bytes())["state"])
            except Exception:
                log.warning("unreadable state on %s", sample.key_expr)
                return
            self._learn(st)
            callback(st)

        return Subscription([self.session.declare_subscriber(key, on_sample)])

    def subscribe_batches(self, callback: Callable[[list[MoverState]], None]) -> Subscription:
        """Call `callback` with the States of every request sent with `publish="batch"`, one list per
        request (in the request's order; failed moves have none), on a Zenoh thread. Returns the
        `Subscription`."""

        def on_sample(sample: zenoh.Sample) -> None:
            try:
                states = [MoverState.from_wire(m) for m in unpack_message(sample.payload.to_bytes())["states"]]
            except Exception:
                log.warning("unreadable states on %s", sample.key_expr)
                return
            for st in states:
                self._learn(st)
            callback(states)

        return Subscription([self.session.declare_subscriber(self.keys.states, on_sample)])

    def subscribe_errors(self, callback: Callable[[int | None, ServiceError], None],
                         mover_id: int | None = None) -> Subscription:
        """Errors of fire-and-forget moves (`push`): `callback(mover_id or None, error)` with the error as
        a ServiceError, on a Zenoh thread. With `mover_id`, that mover's errors; without, every mover's
        and those no mover can be named for (a push that could not be read). Returns the
        `Subscription`."""

        def on_sample(sample: zenoh.Sample) -> None:
            try:
                msg = unpack_message(sample.payload.to_bytes())
                callback(msg.get("id"), ServiceError.from_wire(msg["error"]))
            except Exception:
                log.warning("unreadable error message on %s", sample.key_expr)

        subs = [self.session.declare_subscriber(self.keys.obj_error(mover_id if mover_id is not None else "*"), on_sample)]
        if mover_id is None:
            subs.append(self.session.declare_subscriber(self.keys.errors, on_sample))
        return Subscription(subs)

    # -- landblocks, health, stats -------------------------------------------------------------
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

