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
- Zenoh's access control, default deny, lets a user's session send
  queries, puts and subscriptions on `P/u/<user>/**` only, and lets the
  service send it replies, States and declarations on that space only.
  Another user's keys are unreachable: their queryables are never declared
  to it, and what it sends there is dropped on arrival.

The user is never read from a message: a queryable cannot learn who
authenticated, and a message's source information is whatever the sender
wrote. The key a request arrives on is the proof, because the access
control only lets the user's own session send on it.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import zenoh

from .wire import check_user_name, user_prefix

__all__ = ["Accounts", "AccountsError", "accounts_access_control", "apply_accounts", "add_accounts_arguments"]

#: What a user's session may send the service, on its own space only.
_USER_INGRESS = ["query", "put", "delete", "declare_subscriber"]
#: What the service may send a user's session, on that user's space only (its queryables and subscribers
#: must be declared to the session for Zenoh to route the session's requests to them at all).
_USER_EGRESS = ["reply", "put", "delete", "declare_queryable", "declare_subscriber"]


class AccountsError(ValueError):
    """A users file that cannot be used (missing, unreadable, a line or a name wrong, no user at all)."""


@dataclass(frozen=True, slots=True)
class Accounts:
    path: Path  # Zenoh's usrpwd dictionary file: `user:password` per line
    users: tuple[str, ...]  # the user names, in the file's order

    @classmethod
    def load(cls, path: str | Path) -> Accounts:
        """Read the user names of a dictionary file (Zenoh reads the passwords itself)."""
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
        return cls(path.resolve(), tuple(users))


def accounts_access_control(prefix: str, users: tuple[str, ...]) -> dict[str, Any]:
    """The `access_control` block: default deny; each user's session reaches its own space only."""
    rules: list[dict[str, Any]] = []
    subjects: list[dict[str, Any]] = []
    policies: list[dict[str, Any]] = []
    for user in users:
        space = [f"{user_prefix(prefix, user)}/**"]
        rules.append({"id": f"user-{user}-in", "permission": "allow", "flows": ["ingress"],
                      "messages": _USER_INGRESS, "key_exprs": space})
        rules.append({"id": f"user-{user}-out", "permission": "allow", "flows": ["egress"],
                      "messages": _USER_EGRESS, "key_exprs": space})
        subjects.append({"id": f"user-{user}", "usernames": [user]})
        policies.append({"id": f"user-{user}", "subjects": [f"user-{user}"],
                         "rules": [f"user-{user}-in", f"user-{user}-out"]})
    return {"enabled": True, "default_permission": "deny", "rules": rules, "subjects": subjects, "policies": policies}


def apply_accounts(cfg: zenoh.Config, prefix: str, accounts: Accounts) -> None:
    """Require a user of `accounts` on every link of `cfg`'s session and put the users' access control in it.

    An `access_control` block that a `--zenoh-config` file enables keeps its rules, subjects and policies;
    the default stays deny."""
    cfg.insert_json5("transport/auth/usrpwd/dictionary_file", json.dumps(str(accounts.path)))
    ours = accounts_access_control(prefix, accounts.users)
    theirs = json.loads(cfg.get_json("access_control") or "null")
    if isinstance(theirs, dict) and theirs.get("enabled"):
        for part in ("rules", "subjects", "policies"):
            ours[part] = list(theirs.get(part) or []) + ours[part]
    cfg.insert_json5("access_control", json.dumps(ours))


def add_accounts_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--users", metavar="FILE",
                   help="Zenoh user:password file: every client must log in as one of its users, and reaches "
                        "its own movers only, under PREFIX/u/USER (docs/protocol.md, 'Accounts')")
