"""The client's request plumbing, below clients/client.py and clients/batch.py, which both use it.

A request goes out in two halves so that a batch can put every landblock's request on the bus before it
waits for any reply (the instances, or `--workers`' engines, serving them then work at the same time):
`RequestChannel.send_request` returns a `PendingRequest` at once, `RequestChannel.receive_reply` waits
for its reply map or raises what the reply says. `RequestChannel` is what a batch needs of a client
(`Client` is one): the keys, the landblock each mover was last seen in, and those two halves.
`send_query` and `read_reply` are the halves themselves, on a Zenoh session; `pack_request` and
`unpack_message` the msgpack form of every message (docs/protocol.md, "Messages").

A single move (`Client.move`, `Client.step`) takes a shorter way, as it runs once per call and its
reply is always a State: `pack_move_request` packs it, `ask_state` sends it and reads the State
straight into a MoverState (clients/state_reply.py), with the same bytes, answers and errors. `Client.send`
calls its first half, `gather_state`, itself, and hands any other answer to the general routine with
`FirstReplies`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

import msgpack
import msgspec
import zenoh

from service.protocol.wire import PROTOCOL_VERSION, ErrorKind, Keys

from clients.errors import NoServiceError, RequestTimeout, ServiceError
from clients.state_reply import decode_state_reply

if TYPE_CHECKING:
    from clients.types import MoverState

__all__ = ["PendingRequest", "RequestChannel", "pack_request", "pack_move_request", "unpack_message",
           "send_query", "send_payload", "read_reply", "reply_map", "ask_state", "gather_state",
           "FirstReplies"]


def pack_request(content: dict[str, Any]) -> bytes:
    """A request's payload: `content` with the protocol version, in msgpack."""
    return msgpack.packb({"v": PROTOCOL_VERSION, **content}, use_bin_type=True)


#: shared by threads: msgspec encodes holding the GIL throughout (no hook of ours runs)
_encode = msgspec.msgpack.Encoder().encode
#: the types of a Move map's own values (`tag`, `dt`; `id` an int) that msgspec and msgpack pack alike (msgspec
#: would also pack a set, a Decimal or a UUID, which msgpack refuses); its vectors are floats (Move.to_wire's,
#: or the engine's Vec3 and Quat)
_PLAIN_TAGS = frozenset((type(None), int, str))
_PLAIN_DTS = frozenset((type(None), int, float))


def pack_move_request(move_map: dict[str, Any]) -> bytes:
    """`pack_request({"move": move_map})`'s bytes, by msgspec when the map's own values are plain ones
    (the bytes of both libraries then agree, tests/clients/test_client_move_path.py); else, or when
    msgspec refuses a value (a subclass of int or str), by msgpack as any request, with its errors.
    msgspec packs the map in about half msgpack's time, as it builds no Packer."""
    get = move_map.get
    if type(get("id")) is int and type(get("tag")) in _PLAIN_TAGS and type(get("dt")) in _PLAIN_DTS:
        try:
            return _encode({"v": PROTOCOL_VERSION, "move": move_map})
        except (TypeError, OverflowError):
            pass
    return pack_request({"move": move_map})


def unpack_message(data: bytes) -> Any:
    """A reply's or a publication's payload, read from msgpack (integer map keys kept)."""
    return msgpack.unpackb(data, raw=False, strict_map_key=False)


@dataclass(slots=True)
class PendingRequest:
    """A request on its way (`RequestChannel.send_request`): the key it went to, Zenoh's receiver of its
    replies, and the seconds it may take."""

    key: str | zenoh.KeyExpr
    replies: Any
    timeout: float


def send_query(session: zenoh.Session, key: str | zenoh.KeyExpr, content: dict[str, Any],
               timeout: float) -> PendingRequest:
    """Put one request to the instance serving `key` on the bus and return at once (Zenoh gathers its
    reply meanwhile)."""
    return send_payload(session, key, pack_request(content), timeout)


def send_payload(session: zenoh.Session, key: str | zenoh.KeyExpr, payload: bytes, timeout: float) -> PendingRequest:
    """`send_query` of a request already packed."""
    return PendingRequest(key, session.get(key, payload=payload, timeout=timeout), timeout)


def read_reply(pending: PendingRequest, tried: str, logged_in: bool) -> dict[str, Any]:
    """The reply map of `pending` (waiting for it), or the exception it says: NoServiceError when nobody
    answered (naming `tried`, where the client looked, and the login a service with accounts needs unless
    `logged_in`), RequestTimeout, or the service's ServiceError."""
    return reply_map(list(pending.replies), pending.key, pending.timeout, tried, logged_in)


def ask_state(session: zenoh.Session, key: str | zenoh.KeyExpr, payload: bytes, timeout: float, tried: str,
              logged_in: bool) -> MoverState | dict[str, Any]:
    """One request answered with a State (a move, a step), sent and its reply read: the MoverState when the
    reply is one in the shape the service writes (clients/state_reply.py), else what `read_reply` returns
    or raises (the caller reads the map's State itself, as before)."""
    got = gather_state(session, key, payload, timeout)
    return reply_map(got, key, timeout, tried, logged_in) if isinstance(got, list) else got


def gather_state(session: zenoh.Session, key: str | zenoh.KeyExpr, payload: bytes,
                 timeout: float) -> MoverState | list[Any]:
    """`ask_state`'s request sent and its replies gathered: the MoverState when the first reply is a State in
    the shape the service writes, else the list of replies, for `reply_map` (or `FirstReplies`) to read.

    A State is returned as soon as it comes, without waiting for the query's end (Zenoh's final message,
    which follows the reply): only the first reply is ever read, and waiting for the end cost a second wake-up
    of this thread, a few µs of every move. Anything else waits for the end, and gives every reply."""
    replies = iter(session.get(key, payload=payload, timeout=timeout))
    first = next(replies, None)
    if first is None:  # the query ended with no reply
        return []
    ok = first.ok
    if ok is not None:
        st = decode_state_reply(ok.payload.to_bytes())
        if st is not None:
            return st
    return [first, *replies]


class FirstReplies:
    """A `get` for `Client._ask` (as `Client._get_state`) whose first call reads replies `gather_state` has
    already gathered instead of asking again; later calls (after a redirect, or the settle wait) ask by
    `get`. It lets a move that was sent on the short path fall back to the general routine, which then
    follows redirects and retries as it does for any request, without sending the move twice."""

    __slots__ = ("replies", "get", "tried", "logged_in")

    def __init__(self, replies: list[Any], get: Callable[[str | zenoh.KeyExpr, bytes, float], Any], tried: str,
                 logged_in: bool) -> None:
        self.replies: list[Any] | None = replies
        self.get = get
        self.tried = tried
        self.logged_in = logged_in

    def __call__(self, key: str | zenoh.KeyExpr, payload: bytes, seconds: float) -> Any:
        replies = self.replies
        if replies is None:
            return self.get(key, payload, seconds)
        self.replies = None
        return reply_map(replies, key, seconds, self.tried, self.logged_in)


def reply_map(replies: list[Any], key: str | zenoh.KeyExpr, timeout: float, tried: str,
              logged_in: bool) -> dict[str, Any]:
    """`read_reply` of the replies already gathered for the request to `key`."""
    if not replies:
        hint = "" if logged_in else "; a service run with accounts also needs user= and password="
        raise NoServiceError(f"no service answers on {key} ({tried}{hint})")
    r = replies[0]
    if r.ok is not None:
        msg = unpack_message(r.ok.payload.to_bytes())
        if not isinstance(msg, dict):
            raise ServiceError(ErrorKind.MALFORMED, f"unreadable reply on {key}")
        return msg
    raw = r.err.payload.to_bytes()
    try:
        err = unpack_message(raw)["error"]
    except Exception:
        text = raw.decode("utf-8", "replace")
        if "timeout" in text.lower():
            raise RequestTimeout(f"no answer on {key} within {timeout} s") from None
        raise ServiceError(ErrorKind.MALFORMED, f"unreadable error reply on {key}: {text}") from None
    raise ServiceError.from_wire(err)


class RequestChannel(Protocol):
    """What a batch needs of a client (`Client` is one): its keys, the landblock each mover was last seen
    in, and a request's two halves."""

    @property
    def keys(self) -> Keys: ...

    #: mover id -> the landblock (0xXXYY) it was last seen in; a batch updates it with where its movers ended
    known_landblocks: dict[int, int]

    def landblock_of(self, mover_id: int) -> int: ...

    def send_request(self, key: str | zenoh.KeyExpr, content: dict[str, Any],
                     timeout: float | None = None) -> PendingRequest: ...

    def receive_reply(self, pending: PendingRequest) -> dict[str, Any]: ...
