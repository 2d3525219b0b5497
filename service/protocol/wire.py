"""The wire protocol's constants: version, key expressions, error kinds.

Everything a client in another language must agree on lives here (and in
docs/protocol.md, which is its prose twin). No zenoh, msgpack or engine
imports: the client library and the service both read this module.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

__all__ = [
    "PROTOCOL_VERSION",
    "DEFAULT_PREFIX",
    "DEFAULT_PORT",
    "MAX_PAYLOAD",
    "MAX_BATCH",
    "ErrorKind",
    "Keys",
    "lb_hex",
    "parse_lb_hex",
    "obj_hex",
    "parse_obj_hex",
    "USER_NAME",
    "check_user_name",
    "user_prefix",
]

#: The value of the "v" field of every message this code sends and accepts.
PROTOCOL_VERSION = 1
DEFAULT_PREFIX = "acphys"
#: Where `acphys serve` listens (and clients connect) when told nothing.
DEFAULT_PORT = 7447
#: Largest payload the service decodes; bigger ones get a `too_large` error.
MAX_PAYLOAD = 4 * 1024 * 1024
#: Most moves in one batch.
MAX_BATCH = 4096


class ErrorKind:
    """The `kind` strings of error messages (docs/protocol.md, "Errors")."""

    MALFORMED = "malformed"  # not msgpack, or not a map at the top
    TOO_LARGE = "too_large"  # payload or batch over the limits
    UNSUPPORTED_VERSION = "unsupported_version"
    MISSING_FIELD = "missing_field"
    WRONG_TYPE = "wrong_type"
    BAD_VALUE = "bad_value"  # right type, unacceptable value (range, flag name, ...)
    NON_FINITE = "non_finite"  # NaN or infinity in a number
    UNKNOWN_MOVER = "unknown_mover"
    DUPLICATE_MOVER = "duplicate_mover"
    WRONG_LANDBLOCK = "wrong_landblock"  # sent to a landblock key that does not hold the mover
    MOVED = "moved"  # handed over to another landblock's owner; see `landblock`
    UNKNOWN_CELL = "unknown_cell"
    LANDBLOCK_NOT_LOADED = "landblock_not_loaded"
    LANDBLOCK_UNAVAILABLE = "landblock_unavailable"  # cannot be loaded from the source
    LANDBLOCK_IN_USE = "landblock_in_use"  # unload refused: movers are in it
    FORBIDDEN = "forbidden"  # with accounts: load or unload by a user who is not an admin
    NO_OWNER = "no_owner"  # a move crossed into a landblock no instance owns
    BUSY = "busy"  # the service's queue is full: retry later
    SHUTTING_DOWN = "shutting_down"
    ENGINE_ERROR = "engine_error"  # the engine refused the input for another reason
    INTERNAL = "internal"  # a bug in the service; it keeps running

    ALL = (
        MALFORMED, TOO_LARGE, UNSUPPORTED_VERSION, MISSING_FIELD, WRONG_TYPE, BAD_VALUE,
        NON_FINITE, UNKNOWN_MOVER, DUPLICATE_MOVER, WRONG_LANDBLOCK, MOVED, UNKNOWN_CELL,
        LANDBLOCK_NOT_LOADED, LANDBLOCK_UNAVAILABLE, LANDBLOCK_IN_USE, FORBIDDEN, NO_OWNER, BUSY,
        SHUTTING_DOWN, ENGINE_ERROR, INTERNAL,
    )


def lb_hex(lb: int) -> str:
    """Landblock id as it appears in key expressions: four upper-case hex digits."""
    return f"{lb & 0xFFFF:04X}"


_UPPER_HEX = frozenset("0123456789ABCDEF")


def parse_lb_hex(text: str) -> int:
    """A landblock id from its key form: exactly four upper-case hex digits (`a9b4` is refused, so each
    landblock has one key)."""
    if len(text) != 4 or not _UPPER_HEX.issuperset(text):
        raise ValueError(f"landblock {text!r} is not four upper-case hex digits")
    return int(text, 16)


def obj_hex(mover_id: int) -> str:
    """Mover id as it appears in key expressions: upper-case hex, no leading zeros."""
    return f"{mover_id:X}"


def parse_obj_hex(text: str) -> int:
    return int(text, 16)


#: A user name of a service run with accounts (`acphys serve --users`): it becomes a key chunk, so no
#: wildcard, separator or verbatim (`@`) character.
USER_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")


def check_user_name(name: str) -> str:
    """`name` when it can be a user of accounts mode, else ValueError saying what a name may hold."""
    if not USER_NAME.fullmatch(name):
        raise ValueError(f"user name {name!r}: 1 to 64 of A-Z a-z 0-9 _ . -, starting with a letter or digit")
    return name


def user_prefix(prefix: str, user: str) -> str:
    """Where a user's keys live on a service run with accounts: `P/u/<user>` (docs/protocol.md, "Accounts")."""
    return f"{prefix}/u/{check_user_name(user)}"


class _UnderPrefix:
    """A key directly under the deployment's prefix, named as the Keys attribute it is read as
    (`keys.health`: `P/health`)."""

    __slots__ = ("name",)

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def __get__(self, keys: Keys, owner: type | None = None) -> str:
        return f"{keys.prefix}/{self.name}"


@dataclass(frozen=True, slots=True)
class Keys:
    """Every key expression of one deployment (all under `prefix`)."""

    prefix: str = DEFAULT_PREFIX

    # -- per landblock: served by the instance that owns the landblock --
    def lb(self, lb: int | str, op: str) -> str:
        part = lb if isinstance(lb, str) else lb_hex(lb)
        return f"{self.prefix}/lb/{part}/{op}"

    def move(self, lb: int | str) -> str:
        return self.lb(lb, "move")

    def push(self, lb: int | str) -> str:
        return self.lb(lb, "push")

    # -- per object: published by the service --
    def obj(self, mover_id: int | str, what: str) -> str:
        part = mover_id if isinstance(mover_id, str) else obj_hex(mover_id)
        return f"{self.prefix}/obj/{part}/{what}"

    def state(self, mover_id: int | str) -> str:
        return self.obj(mover_id, "state")

    #: where the States of a request sent with `"publish": "batch"` go, as one message
    states = _UnderPrefix()
    #: where the results of a column request sent with `"publish": "columns"` go, as columns
    state_columns = _UnderPrefix()

    def obj_error(self, mover_id: int | str) -> str:
        return self.obj(mover_id, "error")

    # -- per instance: every instance answers --
    landblocks = _UnderPrefix()
    health = _UnderPrefix()
    stats = _UnderPrefix()
    #: errors of fire-and-forget messages that name no (valid) object
    errors = _UnderPrefix()
