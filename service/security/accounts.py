"""Accounts: each client's movers are its own, enforced by Zenoh's authentication and access control.

`acphys serve --users FILE` names the users in Zenoh's own user/password
dictionary (one `user:password` per line, the file Zenoh's `usrpwd`
authentication reads). Then:

- every session must authenticate with one of those users (Zenoh refuses
  the link otherwise);
- a user's keys are `P/u/<user>/...`: the whole protocol, moved under that
  prefix, served by a tenant of its own (its own movers, ids, States,
  statistics) over the one shared world, so movers of all users still
  collide with each other;
- Zenoh's access control, default deny, lets a user's session ask for
  its own operations only (`P/u/<user>/lb/*/<op>` but the hand-over, and
  the per-instance keys), subscribe within `P/u/<user>/**`, and lets the
  service send it replies, States and declarations on that space only.
  Another user's keys are unreachable: their queryables are never declared
  to it, and what it sends there is dropped on arrival.
- The instances of a cluster (`--cluster`, whose file then names a
  `password` file) log in to each other as INSTANCE_USER over their TLS
  links; behind `serve --workers` the router checks the logins and carries
  the access control, and the workers log in to it the same way, with a
  password made at start.

Load and unload change the world every user shares (and a scene file's
landblock, once unloaded, cannot come back): only the users named with
`--admin` may send them; the others are answered `forbidden`.

The user is never read from a message: a queryable cannot learn who
authenticated, and a message's source information is whatever the sender
wrote. The key a request arrives on is the proof, because the access
control only lets the user's own session send on it.
"""

from __future__ import annotations

import argparse
import json
import os
import secrets
import shutil
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import zenoh

from service.protocol import LB_OPS
from service.protocol.wire import check_user_name, user_prefix

__all__ = [
    "Accounts", "AccountsError", "INSTANCE_USER", "accounts_access_control", "apply_accounts",
    "new_instance_password", "no_logins_file", "write_private", "add_accounts_arguments",
]

#: The operations a user's session may ask for, each on its own key in the user's space: every per-landblock
#: operation but the hand-over (instance to instance), the push, and the per-instance keys. A query on any
#: other key of the space, a wildcard over the operation (`lb/XXYY/*`) included, is dropped.
_CLIENT_LB_OPS = tuple(op for op in LB_OPS if op != "handover")
_CLIENT_INSTANCE_KEYS = ("health", "stats", "landblocks")
#: What the service may send a user's session, on that user's space only (its queryables and subscribers
#: must be declared to the session for Zenoh to route the session's requests to them at all).
_USER_EGRESS = ["reply", "put", "delete", "declare_queryable", "declare_subscriber"]
#: The user name the instances of a cluster log in to each other with, and the processes of `serve
#: --workers` to its router (service/scaleout/workers.py): a name no users file may hold (`check_user_name` refuses
#: the `@`).
INSTANCE_USER = "@instance"


class AccountsError(ValueError):
    """A users file that cannot be used (missing, unreadable, a line or a name wrong, no user at all)."""


@dataclass(frozen=True, slots=True)
class Accounts:
    path: Path  # Zenoh's usrpwd dictionary file: `user:password` per line
    users: tuple[str, ...]  # the user names, in the file's order
    #: the users who may load and unload landblocks (`--admin`)
    admins: tuple[str, ...] = ()

    @classmethod
    def load(cls, path: str | Path, admins: Sequence[str] = ()) -> Accounts:
        """Read the user names of a dictionary file (Zenoh reads the passwords itself); `admins` must be
        some of them."""
        path = Path(path)
        try:
            lines = path.read_text(encoding="utf-8").splitlines()
        except (OSError, UnicodeDecodeError) as e:
            raise AccountsError(f"users file {path}: {e}") from None
        users: list[str] = []
        for number, line in enumerate(lines, 1):
            if not line.strip():
                continue
            name, sep, password = line.partition(":")
            if not sep or not password:
                raise AccountsError(f"users file {path}, line {number}: expected user:password")
            try:
                check_user_name(name)
            except ValueError as e:
                raise AccountsError(f"users file {path}, line {number}: {e}") from None
            if name in users:
                raise AccountsError(f"users file {path}, line {number}: user {name!r} given twice")
            users.append(name)
        if not users:
            raise AccountsError(f"users file {path}: no user")
        for name in admins:
            if name not in users:
                raise AccountsError(f"--admin {name!r}: not a user of the users file {path}")
        return cls(path.resolve(), tuple(users), tuple(dict.fromkeys(admins)))

    @classmethod
    def from_args(cls, args: argparse.Namespace) -> Accounts | None:
        """`--users FILE` and `--admin USER ...` read (None without `--users`); AccountsError for `--admin`
        without `--users`."""
        admins = getattr(args, "admin", None) or []
        if not getattr(args, "users", None):
            if admins:
                raise AccountsError("--admin needs --users (without accounts every client may load and unload)")
            return None
        return cls.load(args.users, admins)

    def is_admin(self, user: str) -> bool:
        """Whether `user` may load and unload landblocks."""
        return user in self.admins


def accounts_access_control(prefix: str, users: tuple[str, ...], *, instances: bool = False) -> dict[str, Any]:
    """The `access_control` block: default deny; each user's session reaches its own space only. `instances`:
    the sessions on TLS links (the other instances of a cluster, a `--workers` router's engine processes,
    which log in as INSTANCE_USER) may do anything."""
    rules: list[dict[str, Any]] = []
    subjects: list[dict[str, Any]] = []
    policies: list[dict[str, Any]] = []
    for user in users:
        space = user_prefix(prefix, user)
        asks = [f"{space}/lb/*/{op}" for op in (*_CLIENT_LB_OPS, "push")]
        asks += [f"{space}/{key}" for key in _CLIENT_INSTANCE_KEYS]
        rules.append({"id": f"user-{user}-ask", "permission": "allow", "flows": ["ingress"],
                      "messages": ["query", "put", "delete"], "key_exprs": asks})
        # a subscription receives only what the egress rule lets through: any in its own space will do
        rules.append({"id": f"user-{user}-listen", "permission": "allow", "flows": ["ingress"],
                      "messages": ["declare_subscriber"], "key_exprs": [f"{space}/**"]})
        rules.append({"id": f"user-{user}-out", "permission": "allow", "flows": ["egress"],
                      "messages": _USER_EGRESS, "key_exprs": [f"{space}/**"]})
        subjects.append({"id": f"user-{user}", "usernames": [user]})
        policies.append({"id": f"user-{user}", "subjects": [f"user-{user}"],
                         "rules": [f"user-{user}-ask", f"user-{user}-listen", f"user-{user}-out"]})
    if instances:
        rules.append({"id": "instances", "permission": "allow", "flows": ["ingress", "egress"],
                      "messages": ["put", "delete", "declare_subscriber", "query", "reply", "declare_queryable",
                                   "liveliness_token", "declare_liveliness_subscriber", "liveliness_query"],
                      # `@workers` is a verbatim chunk, which `**` does not match (service/scaleout/workers.py)
                      "key_exprs": ["**", f"{prefix}/@workers/**"]})
        # any TLS link: its mutual TLS proved an instance of the cluster (service/security/cluster.py). Not the user
        # name as well: only the side that connects logs in, so the other side would not know the link's user
        subjects.append({"id": "instances", "link_protocols": ["tls"]})
        policies.append({"id": "instances", "subjects": ["instances"], "rules": ["instances"]})
    return {"enabled": True, "default_permission": "deny", "rules": rules, "subjects": subjects, "policies": policies}


def apply_accounts(cfg: zenoh.Config, prefix: str, accounts: Accounts, *,
                   instance_password: str | None = None) -> Callable[[], None]:
    """Require a user of `accounts` on every link of `cfg`'s session and put the users' access control in it.

    `instance_password`: this session is an instance of a cluster (or a `--workers` router or worker), whose
    instances log in to each other as INSTANCE_USER with it; they may do anything on their TLS links. The
    logins are then checked against a copy of the users file with INSTANCE_USER's line added, in a private
    temporary directory: call what this returns once the session is open (Zenoh reads the file at open) to
    remove it. An `access_control` block that the config already enables (a `--zenoh-config` file's, the
    cluster rules of service/security/cluster.py) keeps its rules, subjects and policies; the default becomes deny."""
    dictionary, forget = accounts.path, no_logins_file
    if instance_password is not None:
        directory = Path(tempfile.mkdtemp(prefix="acphys-logins-"))  # mode 0700
        dictionary = directory / "logins.txt"
        write_private(dictionary, accounts.path.read_text(encoding="utf-8").rstrip("\n") + "\n"
                      + f"{INSTANCE_USER}:{instance_password}\n")

        def forget() -> None:
            shutil.rmtree(directory, ignore_errors=True)

        cfg.insert_json5("transport/auth/usrpwd/user", json.dumps(INSTANCE_USER))
        cfg.insert_json5("transport/auth/usrpwd/password", json.dumps(instance_password))
    cfg.insert_json5("transport/auth/usrpwd/dictionary_file", json.dumps(str(dictionary)))
    ours = accounts_access_control(prefix, accounts.users, instances=instance_password is not None)
    theirs = json.loads(cfg.get_json("access_control") or "null")
    if isinstance(theirs, dict) and theirs.get("enabled"):
        for part in ("rules", "subjects", "policies"):
            ours[part] = list(theirs.get(part) or []) + ours[part]
    cfg.insert_json5("access_control", json.dumps(ours))
    return forget


def no_logins_file() -> None:
    """What `apply_accounts` returns when it wrote no temporary logins file: nothing to remove."""


def write_private(path: Path, text: str) -> None:
    """Write `text` to `path`, readable by this user only from the moment the file exists (passwords)."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        f.write(text)


def new_instance_password() -> str:
    """A password for the instances of one `serve --workers` (made at each start, never shown)."""
    return secrets.token_hex(24)


def add_accounts_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--users", metavar="FILE",
                   help="Zenoh user:password file: every client must log in as one of its users, and reaches "
                        "its own movers only, under PREFIX/u/USER (docs/protocol.md, 'Accounts')")
    p.add_argument("--admin", metavar="USER", action="append", default=[],
                   help="with --users: a user who may load and unload landblocks (the world every user "
                        "shares); repeat for several. The other users are refused with 'forbidden'")
