"""Moves in the client library: Client.move / step / send, the batches move_many, move_many_maps and
move_batch, and the fire-and-forget push (docs/protocol.md, "Move request", "Batches", "Transport").

A move goes to the landblock key of the landblock the client last saw its mover in (`Client.landblock_of`);
the service's `moved` / `wrong_landblock` answer says where the mover went, and the move is sent there again.
A batch groups its moves by landblock and sends every landblock's request before it reads any reply, so
that the instances serving them work at the same time; each mover's moves keep their order. A push keeps
one route per mover (the old owner forwards after a hand-over), so that its moves cannot overtake each other.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import zenoh

from engine.geometry import Position, Vec3
from service.protocol.wire import MAX_PAYLOAD, ErrorKind, Keys

from clients.batch import BatchResults, move_batch
from clients.errors import AcphysError, ServiceError
from clients.request_channel import FirstReplies, PendingRequest, gather_state, pack_move_request, pack_request
from clients.types import Move, MoverState, item_result

__all__ = ["MoveCalls", "REDIRECTS", "MAX_REDIRECTS"]

#: Error kinds that say "ask again at landblock `landblock`".
REDIRECTS = (ErrorKind.MOVED, ErrorKind.WRONG_LANDBLOCK)
#: how many redirects a request follows before the last answer stands
MAX_REDIRECTS = 4


class MoveCalls:
    """The moves, mixed into `Client` (which gives them its session and keys, the landblocks it has seen
    movers in, and its request plumbing): call them on a Client."""

    session: zenoh.Session
    keys: Keys
    timeout: float
    user: str | None
    known_landblocks: dict[int, int]
    _tried: str
    _lb_keys: dict[tuple[int, str], zenoh.KeyExpr]
    _push_route: dict[int, int]
    _learn: Callable[[MoverState], MoverState]
    _lb_key: Callable[[int, str], zenoh.KeyExpr]
    _lb_request: Callable[..., dict[str, Any]]
    _lb_ask: Callable[..., Any]
    _get_state: Callable[..., MoverState | dict[str, Any]]
    landblock_of: Callable[[int], int]
    send_request: Callable[..., PendingRequest]
    receive_reply: Callable[[PendingRequest], dict[str, Any]]

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
        # Move's fields by position (id, to, offset, motion, dt, velocity, tag): keywords cost more per call
        return self.send(Move(mover_id, to, offset, None, None, velocity, tag), timeout)

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
        return self.send(Move(mover_id, None, None, motion, dt, None, tag), timeout)  # by position, as `move`

    def send(self, move: Move, timeout: float | None = None) -> MoverState:
        """Send one `Move` (a transition or a physics step, as `move` and `step`) and return the mover's
        State after it. Raises as `move` and `step` do."""
        # The usual case in as few calls as it takes: the landblock known, its key parsed, the reply a State
        # in the service's shape. Anything else goes the general way (`landblock_of`'s find, `_lb_key`,
        # `_lb_ask` with its redirects and the settle retry), reading the replies already gathered first.
        mover_id = move.id
        lb = self.known_landblocks.get(mover_id)
        if lb is None:
            lb = self.landblock_of(mover_id)
        payload = pack_move_request(move.to_wire())
        key = self._lb_keys.get((lb, "move"))
        got = gather_state(self.session, self._lb_key(lb, "move") if key is None else key, payload,
                           self.timeout if timeout is None else timeout)
        if isinstance(got, list):
            got = self._lb_ask(lb, "move", payload, mover_id, timeout,
                               FirstReplies(got, self._get_state, self._tried, self.user is not None))
            if type(got) is not MoverState:
                got = MoverState.from_wire(got["state"])
        self.known_landblocks[got.id] = (got.result.position.cell_id >> 16) & 0xFFFF  # `_learn`, written out
        return got

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
        for attempt in range(MAX_REDIRECTS + 1):
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
                    if isinstance(err_map, dict) and err_map.get("kind") in REDIRECTS and isinstance(target, int) \
                            and attempt < MAX_REDIRECTS:
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
            self.session.put(self._lb_key(lb, "push"), payload)  # declared once, as a request's key
