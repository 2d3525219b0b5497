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

This file holds the connection, that routing (`landblock_of`, `find`, the request plumbing) and the
movers' register / update / remove / get. The rest of `Client` is mixed in, a concept a file: the moves
(clients/moves.py), the subscriptions (clients/subscriptions.py), the calls to the instances (landblocks,
health, stats: clients/instances.py), the spatial queries (clients/spatial.py) and the paths
(clients/paths.py).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import zenoh

from engine.geometry import Plane, Position, Vec3
from engine import MoverSpec
from service.protocol.codec import encode_mover_spec
from service.protocol.messages import REGISTER, RegisterRequest
from service.protocol.wire import DEFAULT_PREFIX, ErrorKind, Keys, user_prefix
from service.bus.zconfig import DEFAULT_ENDPOINT, make_config

from clients.instances import InstanceCalls
from clients.moves import MAX_REDIRECTS, REDIRECTS, MoveCalls
from clients.paths import PathQueries
from clients.request_channel import (PendingRequest, ask_state, pack_request, read_reply, send_payload, send_query,
                                     unpack_message)
from clients.spatial import SpatialQueries
from clients.subscriptions import Subscription, SubscriptionCalls
from clients.errors import NoServiceError, ServiceError
from clients.types import MoverState

__all__ = ["Client", "Subscription"]

#: most per-landblock request keys kept declared (`Client._lb_key`): each holds about 2 KB of the session's
#: routing tables while kept; a client asks a few landblocks' keys, a bot crossing the world a few hundred
_KEY_CACHE = 4096
#: Seconds a new peer session takes to meet every instance of a cluster. It connects to one endpoint and
#: meets the other instances through Zenoh's gossip, whose queryables it learns about 0.1 s after opening
#: (measured on loopback); a query sent sooner reaches only the instances met so far (`acphys stats` listed
#: one instance of two in half the tries). A query to every instance (health, stats, landblocks) waits until
#: the client is this old (so does `find`), and a request to one landblock that nobody answered is sent again
#: then.
SETTLE_S = 0.5


_encode_register = REGISTER.encode_fn()


class Client(MoveCalls, SubscriptionCalls, InstanceCalls, SpatialQueries, PathQueries):
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
        # per-landblock request keys, declared on the session (`_lb_key`)
        self._lb_keys: dict[tuple[int, str], zenoh.KeyExpr] = {}

    # -- lifecycle ------------------------------------------------------------------
    def close(self) -> None:
        """Close the Zenoh session the client opened (not one given as `session=`); its subscriptions end
        with it. Safe to call twice. The request keys it declared on a session given to it are let go."""
        self._lb_keys.clear()  # a dropped declared key is undeclared
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
        """`P/lb/XXYY/op`, declared on the session the first time it is asked for (else parsed, when the
        session refuses: closed, say).

        Why declared: Zenoh keeps a declared key's routes cached, as for the service's own keys
        (service/bus/route_keys.py), instead of matching the key against every declaration again. Callgrind, a query from one Zenoh session to another's
        wildcard queryable over loopback (both sessions counted, the service's side already declaring the
        key): 217,000 instructions a round trip with the key parsed, 198,000 with it declared. A key
        dropped from the cache is undeclared with it."""
        key = self._lb_keys.get((lb, op))
        if key is None:
            if len(self._lb_keys) >= _KEY_CACHE:
                self._lb_keys.clear()
            text = self.keys.lb(lb, op)
            try:
                key = self.session.declare_keyexpr(text)
            except zenoh.ZError:
                key = zenoh.KeyExpr(text)
            self._lb_keys[lb, op] = key
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
        return self._ask(key, pack_request(content), timeout, self._get_reply)  # type: ignore[no-any-return]

    def _ask(self, key: str | zenoh.KeyExpr, payload: bytes, timeout: float | None,
             get: Callable[[str | zenoh.KeyExpr, bytes, float], Any]) -> Any:
        """One packed request to the instance serving `key`, sent and its reply read by `get`
        (`_get_reply` or `_get_state`): what `get` returns, or an exception."""
        seconds = self.timeout if timeout is None else timeout
        try:
            return get(key, payload, seconds)
        except NoServiceError:
            # nobody had it (so sending again repeats nothing); a young session may not have met the instance
            # serving `key` yet (SETTLE_S): once it has, ask again
            if not self._settle():
                raise
            return get(key, payload, seconds)

    def _get_reply(self, key: str | zenoh.KeyExpr, payload: bytes, seconds: float) -> dict[str, Any]:
        """A `get` for `_ask`: the reply map (`send_request`, then `receive_reply`, of a packed request)."""
        return self.receive_reply(send_payload(self.session, key, payload, seconds))

    def _get_state(self, key: str | zenoh.KeyExpr, payload: bytes, seconds: float) -> MoverState | dict[str, Any]:
        """A `get` for `_ask` of a request answered with a State: the MoverState, or the reply map when it
        is not in the service's usual shape (clients/request_channel.py, ask_state)."""
        return ask_state(self.session, key, payload, seconds, self._tried, self.user is not None)

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
        return self._lb_ask(lb, op, pack_request(content), mover_id, timeout,  # type: ignore[no-any-return]
                            self._get_reply)

    def _lb_ask(self, lb: int, op: str, payload: bytes, mover_id: int | None, timeout: float | None,
                get: Callable[[str | zenoh.KeyExpr, bytes, float], Any]) -> Any:
        """`_lb_request` of a packed request, sent and its reply read by `get` (as `_ask`)."""
        for _ in range(MAX_REDIRECTS):
            key = self._lb_keys.get((lb, op))  # `_lb_key`'s cache read here: one call fewer on every move
            try:
                return self._ask(self._lb_key(lb, op) if key is None else key, payload, timeout, get)
            except ServiceError as e:
                target = e.details.get("landblock")
                if e.kind not in REDIRECTS or not isinstance(target, int) or target == lb:
                    raise
                lb = target
                if mover_id is not None:
                    self.known_landblocks[mover_id] = lb
        return self._ask(self.keys.lb(lb, op), payload, timeout, get)

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
