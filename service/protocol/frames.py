"""Whole messages from States packed once.

A move's State is packed once (msgpack) and the same bytes go into its
publication (`{"v", "state"}`) and into the reply, single (`{"v", "state"}`)
or batch (`{"v", "results": [...]}`): the messages are put together from
bytes instead of packing the State again. Given the State's bytes, the
message's bytes are exactly what `msgpack.packb({"v": 1, ...})` gives.
"""

from __future__ import annotations

from typing import Any

import msgpack

from service.protocol.wire import PROTOCOL_VERSION

__all__ = ["STATE_HEAD", "pack", "state_message", "results_message", "states_message", "array_header"]

_V = msgpack.packb("v") + msgpack.packb(PROTOCOL_VERSION)
#: `{"v": 1, "state": ` packed: a State's bytes after it make the whole message
STATE_HEAD = b"\x82" + _V + msgpack.packb("state")
_RESULTS_HEAD = b"\x82" + _V + msgpack.packb("results")
_STATES_HEAD = b"\x82" + _V + msgpack.packb("states")


def pack(content: dict[str, Any]) -> bytes:
    """A message: `content` with `"v"` first."""
    return msgpack.packb({"v": PROTOCOL_VERSION, **content}, use_bin_type=True)


def state_message(packed_state: bytes) -> bytes:
    """`{"v": 1, "state": State}` from the packed State."""
    return STATE_HEAD + packed_state


def array_header(n: int) -> bytes:
    """The msgpack header of an array of `n` items."""
    if n < 16:
        return bytes((0x90 | n,))
    if n < 1 << 16:
        return b"\xdc" + n.to_bytes(2, "big")
    return b"\xdd" + n.to_bytes(4, "big")


def results_message(packed_entries: list[bytes]) -> bytes:
    """`{"v": 1, "results": [...]}` from the packed entries."""
    return _RESULTS_HEAD + array_header(len(packed_entries)) + b"".join(packed_entries)


def states_message(packed_states: list[bytes]) -> bytes:
    """`{"v": 1, "states": [...]}` from the packed States (one request's, published on `P/states`)."""
    return _STATES_HEAD + array_header(len(packed_states)) + b"".join(packed_states)
