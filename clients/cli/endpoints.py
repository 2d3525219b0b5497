"""Zenoh endpoints and key prefixes as the command line takes them: checked before any session opens.

Zenoh refuses a malformed `--listen` with a message of its own build (a Rust source path included), and
takes a `--connect` without a port, or with port 99999, without a word: the session just never reaches
anything. `listen_endpoint` and `connect_endpoint` are argparse types that refuse such an endpoint up
front, naming what is wrong and showing the right form.

An endpoint is `PROTOCOL/ADDRESS[?METADATA][#CONFIG]`. The protocols are those the zenoh-python wheel
opens a link with (tcp, udp, tls, quic, ws and unixsock-stream); for all but the last the address is
HOST:PORT, an IPv6 host in brackets.

A `--prefix` is the first chunks of every key of one service: a Zenoh key expression without
wildcards (`*`, `$`) or the characters Zenoh forbids (`?`, `#`), and with no empty chunk.
"""

from __future__ import annotations

import argparse
import re

from service.bus.zconfig import DEFAULT_ENDPOINT

__all__ = ["EndpointError", "ENDPOINT_FORM", "check_endpoint", "connect_endpoint", "listen_endpoint", "host_port",
           "key_prefix", "tcp_port"]

#: the form, with an example, that every refusal shows
ENDPOINT_FORM = f"PROTOCOL/HOST:PORT, e.g. {DEFAULT_ENDPOINT}"
#: protocols whose address is HOST:PORT
_IP_PROTOCOLS = ("tcp", "udp", "tls", "quic", "ws")
#: protocols whose address is a file system path
_PATH_PROTOCOLS = ("unixsock-stream",)
_MAX_PORT = 65535
_HOSTNAME = re.compile(r"^[A-Za-z0-9]([A-Za-z0-9.-]*[A-Za-z0-9])?$")
_IPV6 = re.compile(r"^\[[0-9A-Fa-f:.%a-zA-Z]+\]$")


class EndpointError(ValueError):
    """An endpoint the command line refuses; the message says why and shows the right form."""


def host_port(address: str) -> tuple[str, str] | None:
    """HOST and PORT of `HOST:PORT` (`[::1]:7447` too), or None when there is no `:PORT`."""
    if address.startswith("["):
        end = address.find("]")
        if end < 0 or address[end + 1:end + 2] != ":":
            return None
        return address[:end + 1], address[end + 2:]
    host, sep, port = address.rpartition(":")
    if not sep:
        return None
    return host, port


def check_endpoint(text: str, *, listen: bool) -> str:
    """`text` when it is an endpoint Zenoh can open (port 0, any free port, only to listen); else EndpointError."""
    where = "to listen on" if listen else "to connect to"
    protocol, slash, rest = text.partition("/")
    if not slash or not protocol or not rest:
        raise EndpointError(f"{text!r} is not an endpoint {where}: write {ENDPOINT_FORM}")
    if protocol not in _IP_PROTOCOLS + _PATH_PROTOCOLS:
        known = ", ".join(_IP_PROTOCOLS + _PATH_PROTOCOLS)
        raise EndpointError(f"{text!r}: {protocol!r} is not a protocol Zenoh speaks here ({known}); "
                            f"write {ENDPOINT_FORM}")
    address = re.split(r"[?#]", rest, maxsplit=1)[0]
    if protocol in _PATH_PROTOCOLS:
        if not address:
            raise EndpointError(f"{text!r} names no socket file: write {protocol}/PATH")
        return text
    parts = host_port(address)
    if parts is None:
        raise EndpointError(f"{text!r} has no port: write {ENDPOINT_FORM}")
    host, port = parts
    if not (_HOSTNAME.match(host) or _IPV6.match(host)):
        raise EndpointError(f"{text!r}: {host!r} is not a host name or IP address: write {ENDPOINT_FORM}")
    if not port.isdigit() or not (0 if listen else 1) <= int(port) <= _MAX_PORT:
        low = 0 if listen else 1
        raise EndpointError(f"{text!r}: port {port!r} is not a number from {low} to {_MAX_PORT}: write {ENDPOINT_FORM}")
    return text


def listen_endpoint(text: str) -> str:
    """argparse type of `--listen`."""
    try:
        return check_endpoint(text, listen=True)
    except EndpointError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def connect_endpoint(text: str) -> str:
    """argparse type of `--connect`."""
    try:
        return check_endpoint(text, listen=False)
    except EndpointError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def key_prefix(text: str) -> str:
    """argparse type of `--prefix`: chunks separated by `/`, none empty, no wildcard or forbidden character."""
    bad = sorted(set(text) & set("*$?#"))
    if not text or "" in text.split("/") or bad:
        why = f"no {' '.join(bad)}" if bad else "no empty chunk, no leading or trailing /"
        raise argparse.ArgumentTypeError(f"{text!r} is not a key prefix ({why}): write chunks separated by /, "
                                         "e.g. acphys or acphys/test")
    return text


def tcp_port(text: str) -> int:
    """argparse type of a TCP port to listen on (`view --port`): 0 (any free one) to 65535."""
    if not text.isdigit() or int(text) > _MAX_PORT:
        raise argparse.ArgumentTypeError(f"{text!r} is not a port: a number from 0 to {_MAX_PORT}")
    return int(text)
