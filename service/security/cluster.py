"""Which sessions may do what instances do: Zenoh's TLS and access control, configured for a cluster.

Clients reach an instance over plain links (tcp, ...) and need no
credentials. Instances of one cluster reach each other over TLS links with
client certificates (mutual TLS) signed by the cluster's own CA. Zenoh's
access control then refuses, on every link that is not TLS, what only an
instance may do:

- query `P/lb/*/handover` (put a mover into an instance),
- declare a queryable under `P/` (answer in an instance's name),
- put on `P/obj/**`, `P/states`, `P/errors` (publish States or errors).

Zenoh matches a rule's key expression against a message's by inclusion, so
a wildcard query such as `P/lb/XXYY/*` is not caught by the hand-over rule;
the service therefore answers hand-overs on their literal key only
(service/bus/node.py). An instance started without a cluster file takes no
hand-over at all (it does not declare the key). An `access_control` block
of a `--zenoh-config` file is kept, ours added to it.

The cluster file (`acphys serve --cluster FILE`) is JSON:

    {"ca": "ca.pem", "cert": "instance.pem", "key": "instance-key.pem",
     "listen": ["tls/0.0.0.0:7448"], "connect": ["tls/other-host:7448"]}

Relative paths are read from the file's directory. `listen` is where the
other instances connect; `connect`, the other instances' TLS endpoints.
With accounts (`--users`) it also names `"password"`: a file whose first
line is the password the instances log in to each other with.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import zenoh

__all__ = [
    "ClusterConfig", "ClusterConfigError", "PLAIN_LINK_PROTOCOLS", "access_control", "merged_access_control", "apply_security",
    "add_security_arguments", "security_setup",
]

#: Zenoh's link protocols other than TLS: sessions on these are never taken for an instance.
PLAIN_LINK_PROTOCOLS = ("tcp", "udp", "ws", "quic", "unixsock-stream", "unixpipe", "serial", "vsock")


class ClusterConfigError(ValueError):
    """A cluster file that cannot be used (missing, unreadable, a field wrong or absent)."""


@dataclass(frozen=True, slots=True)
class ClusterConfig:
    ca: Path  # the cluster's CA certificate (PEM): the only issuer instances trust
    cert: Path  # this instance's certificate (PEM), signed by `ca`
    key: Path  # its private key (PEM)
    listen: list[str] = field(default_factory=list)  # TLS endpoints the other instances connect to
    connect: list[str] = field(default_factory=list)  # the other instances' TLS endpoints
    #: with accounts (service/security/accounts.py): a file whose first line is the password the cluster's instances
    #: log in to each other with (as INSTANCE_USER)
    password: Path | None = None

    def instance_password(self) -> str:
        """The instances' password (ClusterConfigError without one, or when it cannot be read)."""
        if self.password is None:
            raise ClusterConfigError("the cluster file names no 'password' file, which --users needs (the instances "
                                     "log in to each other)")
        try:
            lines = self.password.read_text(encoding="utf-8").splitlines()
        except (OSError, UnicodeDecodeError) as e:
            raise ClusterConfigError(f"password file {self.password}: {e}") from None
        if not lines or not lines[0]:
            raise ClusterConfigError(f"password file {self.password}: the first line is empty")
        return lines[0]

    @classmethod
    def load(cls, path: str | Path) -> ClusterConfig:
        path = Path(path)
        try:
            raw = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as e:
            raise ClusterConfigError(f"cluster file {path}: {e}") from None
        if not isinstance(raw, dict):
            raise ClusterConfigError(f"cluster file {path}: expected a JSON object")
        base = path.parent

        def file(name: str) -> Path:
            value = raw.get(name)
            if not isinstance(value, str) or not value:
                raise ClusterConfigError(f"cluster file {path}: {name!r} must name a PEM file")
            p = base / value
            if not p.is_file():
                raise ClusterConfigError(f"cluster file {path}: {name} {p} does not exist")
            return p

        def endpoints(name: str) -> list[str]:
            value = raw.get(name, [])
            if not isinstance(value, list) or not all(isinstance(e, str) for e in value):
                raise ClusterConfigError(f"cluster file {path}: {name!r} must be a list of endpoints")
            bad = [e for e in value if not e.startswith("tls/")]
            if bad:
                raise ClusterConfigError(f"cluster file {path}: {name} endpoints must be tls/...: {bad}")
            return list(value)

        cfg = cls(file("ca"), file("cert"), file("key"), endpoints("listen"), endpoints("connect"),
                  file("password") if "password" in raw else None)
        if not cfg.listen and not cfg.connect:
            raise ClusterConfigError(f"cluster file {path}: give 'listen' or 'connect' TLS endpoints (or both)")
        return cfg


def access_control(prefix: str) -> dict[str, Any]:
    """The `access_control` block: what sessions on plain links may not do under `prefix` (with accounts,
    service/security/accounts.py adds its own rules and makes the default deny)."""
    return {
        "enabled": True,
        "default_permission": "allow",
        "rules": [
            {"id": "instance-queries", "permission": "deny", "flows": ["ingress"], "messages": ["query"],
             "key_exprs": [f"{prefix}/lb/*/handover"]},
            {"id": "instance-queryables", "permission": "deny", "flows": ["ingress"],
             "messages": ["declare_queryable"], "key_exprs": [f"{prefix}/**"]},
            {"id": "instance-publications", "permission": "deny", "flows": ["ingress"], "messages": ["put", "delete"],
             "key_exprs": [f"{prefix}/obj/**", f"{prefix}/states", f"{prefix}/errors"]},
        ],
        "subjects": [{"id": "plain-links", "link_protocols": list(PLAIN_LINK_PROTOCOLS)}],
        "policies": [{"id": "clients", "subjects": ["plain-links"],
                      "rules": ["instance-queries", "instance-queryables", "instance-publications"]}],
    }


def merged_access_control(cfg: zenoh.Config, prefix: str) -> dict[str, Any]:
    """Ours, added to an `access_control` block the config (a `--zenoh-config` file) already enables: its
    rules, subjects, policies and default permission stay."""
    ours = access_control(prefix)
    theirs = json.loads(cfg.get_json("access_control") or "null")
    if not isinstance(theirs, dict) or not theirs.get("enabled"):
        return ours
    merged = dict(theirs)
    for part in ("rules", "subjects", "policies"):
        merged[part] = list(theirs.get(part) or []) + ours[part]
    return merged


def apply_security(cfg: zenoh.Config, prefix: str, cluster: ClusterConfig | None) -> None:
    """Put the access-control block in `cfg`, and with a cluster its TLS links and endpoints."""
    cfg.insert_json5("access_control", json.dumps(merged_access_control(cfg, prefix)))
    if cluster is None:
        return
    cfg.insert_json5("transport/link/tls", json.dumps({
        "root_ca_certificate": str(cluster.ca),
        "listen_certificate": str(cluster.cert),
        "listen_private_key": str(cluster.key),
        "connect_certificate": str(cluster.cert),
        "connect_private_key": str(cluster.key),
        "enable_mtls": True,  # a TLS peer must show a certificate of the cluster's CA
        # instances are named by the CA, not by host name (loopback and containers have none that fits)
        "verify_name_on_connect": False,
    }))
    listen = _list(cfg, "listen/endpoints")
    connect = _list(cfg, "connect/endpoints")
    cfg.insert_json5("listen/endpoints", json.dumps(listen + [e for e in cluster.listen if e not in listen]))
    cfg.insert_json5("connect/endpoints", json.dumps(connect + [e for e in cluster.connect if e not in connect]))
    # reach other instances only through the TLS endpoints given: an instance that connected to another's
    # plain endpoint (learnt by gossip) would be taken for a client there, and its hand-overs refused
    cfg.insert_json5("scouting/gossip/autoconnect", json.dumps({"router": [], "peer": []}))


def _list(cfg: zenoh.Config, path: str) -> list[str]:
    value = json.loads(cfg.get_json(path))
    if isinstance(value, dict):  # zenoh's per-mode form {"peer": [...], ...}: keep it simple, take all
        return [e for v in value.values() if isinstance(v, list) for e in v]
    return list(value or [])


def add_security_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--cluster", metavar="FILE",
                   help="cluster file (JSON: ca, cert, key, listen, connect): join other instances over mutual "
                        "TLS and take hand-overs from them only (default: no hand-overs)")


def security_setup(cfg: zenoh.Config, args: argparse.Namespace) -> ClusterConfig | None:
    """Apply `--cluster` (or none) and the access-control rules to `cfg`; the cluster read."""
    cluster = ClusterConfig.load(args.cluster) if getattr(args, "cluster", None) else None
    apply_security(cfg, args.prefix, cluster)
    return cluster
