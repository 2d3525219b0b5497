"""A Zenoh router in a Python process: `acphys router --listen ENDPOINT`.

A zenoh-python session opened in **router** mode is a full Zenoh router
(the same routing code as `zenohd`): instances and clients connect to it
in client or peer mode and it routes every key between them. `acphys
serve --workers N` opens one of these in front of its worker processes;
`acphys router` runs one on its own, for a deployment across machines.

A router carries the service's access-control rules (service/security/cluster.py)
for its prefix, so what only instances may do is refused to clients where
they enter; with a cluster file it also listens (and connects) on the
cluster's TLS endpoints, where the instances reach it with their
certificates. A router without one relays no hand-over at all.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
from collections.abc import Callable

import zenoh

from service.security.accounts import Accounts, apply_accounts, no_logins_file
from service.logs import add_log_arguments, configure_logging
from service.security.cluster import ClusterConfig, apply_security
from service.command import stop_on_signals
from service.protocol.wire import DEFAULT_PREFIX
from service.bus.zconfig import DEFAULT_ENDPOINT, make_config, zenoh_reason

__all__ = ["add_router_arguments", "router_config", "run_router"]

log = logging.getLogger("acphys.router")


def router_config(listen: list[str] | None, connect: list[str] | None = None, config_file: str | None = None,
                  multicast: bool | None = None, *, prefix: str = DEFAULT_PREFIX,
                  cluster: ClusterConfig | None = None, accounts: Accounts | None = None,
                  instance_password: str | None = None) -> tuple[zenoh.Config, Callable[[], None]]:
    """A zenoh.Config for a router: the service's defaults (loopback, no multicast) in router mode, with
    the access-control rules of `prefix` and, given a cluster, its TLS links; and what to call once the
    session is open. With `accounts` (service/security/accounts.py) it checks the users' logins and keeps each user
    to its own keys, the instances logging in with `instance_password` (the cluster file's, unless given).

    A router that is the only way between its clients must not be bypassed: peers that reach it
    are not told to connect to each other (gossip off), so every message takes Zenoh's routes through it.
    """
    cfg = make_config(config_file=config_file, listen=listen, connect=connect, mode="router", multicast=multicast)
    if not config_file:
        cfg.insert_json5("scouting/gossip/enabled", json.dumps(False))
    apply_security(cfg, prefix, cluster)
    if accounts is None:
        return cfg, no_logins_file
    if instance_password is None:
        if cluster is None:
            raise ValueError("a router with --users needs --cluster (its instances log in with the cluster's password)")
        instance_password = cluster.instance_password()
    return cfg, apply_accounts(cfg, prefix, accounts, instance_password=instance_password)


def add_router_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--listen", metavar="ENDPOINT", action="append",
                   help=f"endpoint to listen on (repeatable; default {DEFAULT_ENDPOINT} unless --zenoh-config)")
    p.add_argument("--connect", metavar="ENDPOINT", action="append", help="another router to connect to (repeatable)")
    p.add_argument("--zenoh-config", metavar="FILE", help="zenoh JSON5 config file (its mode is set to router)")
    p.add_argument("--cluster", metavar="FILE",
                   help="cluster file (as `acphys serve --cluster`): instances reach the router over mutual TLS on its "
                        "`listen` endpoints; without one the router relays no hand-over")
    p.add_argument("--prefix", default=DEFAULT_PREFIX, help="the service's key prefix (default %(default)s)")
    p.add_argument("--users", metavar="FILE",
                   help="the instances' users file (as `acphys serve --users`): clients log in here and reach their "
                        "own keys only; needs --cluster with a 'password' file")
    add_log_arguments(p)


def run_router(args: argparse.Namespace) -> int:
    """Run a router until SIGINT/SIGTERM; 0 on a clean stop, 2 when it cannot start."""
    configure_logging(args.log_level, getattr(args, "log_format", "text"))
    listen = args.listen
    if listen is None and not args.zenoh_config:
        listen = [DEFAULT_ENDPOINT]
    stop = stop_on_signals(log, "stopping the router")
    try:
        cluster = ClusterConfig.load(args.cluster) if args.cluster else None
        accounts = Accounts.load(args.users) if args.users else None
        cfg, forget_logins = router_config(listen, args.connect, args.zenoh_config, prefix=args.prefix,
                                           cluster=cluster, accounts=accounts)
        try:
            session = zenoh.open(cfg)
        finally:
            forget_logins()
    except Exception as e:
        print(f"acphys router: cannot start: {zenoh_reason(e)}", file=sys.stderr)
        return 2
    print(f"acphys router ready: {session.zid()}, listening on {', '.join(listen or ['(config file)'])}", flush=True)
    while not stop.wait(0.5):
        pass
    session.close()
    log.info("router stopped")
    return 0
