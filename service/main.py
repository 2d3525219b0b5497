"""Running the service: command-line options, signals, clean exit.

`acphys serve` (clients/__main__.py) and `python -m service` both end up in
`serve()`. SIGINT and SIGTERM stop taking requests, finish what is queued,
undeclare and exit 0. `--workers N` (N > 1) hands over to service/scaleout/workers.py,
which runs this same entry point in N worker processes behind a router.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Callable
from dataclasses import replace
from typing import Any

from service.logs import add_log_arguments, configure_logging
from service.bus.request_log import ERRORS
from service.security.accounts import Accounts, add_accounts_arguments, apply_accounts, no_logins_file
from service.bus.node import NodeOptions, ServiceNode
from service.queries import DEFAULT_PATH_WORK
from service.persistence.lifecycle import Persistence, add_state_arguments
from service.security.cluster import add_security_arguments, security_setup
from service.persistence.state_layout import regroup_state
from service.command import positive_int, stop_on_signals
from service.ownership import Ownership
from service.protocol.wire import DEFAULT_PREFIX, user_prefix
from service.scaleout.workers import DEFAULT_WORKER_RESTARTS
from service.bus.zconfig import DEFAULT_ENDPOINT, bound_messages, make_config, zenoh_reason

__all__ = ["add_serve_arguments", "serve", "main"]

log = logging.getLogger("acphys.service")


def add_serve_arguments(p: argparse.ArgumentParser) -> None:
    src = p.add_mutually_exclusive_group()
    src.add_argument("--scene", metavar="FILE", help="acphys-scene/1 JSON file to serve")
    src.add_argument("--dat-dir", metavar="DIR", help="directory with client_cell_1.dat and client_portal.dat")
    z = p.add_argument_group("zenoh")
    z.add_argument("--listen", metavar="ENDPOINT", action="append",
                   help=f"endpoint to listen on (repeatable; default {DEFAULT_ENDPOINT} unless --zenoh-config)")
    z.add_argument("--connect", metavar="ENDPOINT", action="append", help="endpoint to connect to (repeatable)")
    z.add_argument("--zenoh-config", metavar="FILE", help="zenoh JSON5 config file (replaces the loopback defaults)")
    z.add_argument("--mode", choices=("peer", "client", "router"), help="zenoh mode (default peer)")
    z.add_argument("--multicast-scouting", action="store_true", default=None,
                   help="discover peers by UDP multicast (off by default)")
    p.add_argument("--prefix", default=DEFAULT_PREFIX, help="key expression prefix (default %(default)s)")
    p.add_argument("--own", metavar="LANDBLOCKS", default="*",
                   help="landblocks this instance owns: * or XXYY,XXYY,... (default: all)")
    p.add_argument("--queue", type=int, default=1024, metavar="N", help="queued requests before 'busy' (default %(default)s)")
    p.add_argument("--handover-timeout", type=float, default=2.0, metavar="S",
                   help="seconds to wait for another instance to take a mover crossing into its landblock "
                        "(default %(default)s)")
    p.add_argument("--path-work", type=positive_int, default=DEFAULT_PATH_WORK, metavar="N",
                   help="graph building one path query may do before it answers 'building' (placements and walks; "
                        "about 20 us each on the compiled engine): bounds how long a path into land whose "
                        "navigation graph is not built yet holds up everyone's moves (default %(default)s)")
    add_log_arguments(p)
    p.add_argument("--workers", default="1", metavar="N",
                   help="engine processes behind one router (service/scaleout/workers.py): a count or 'auto' (the CPUs); "
                        "default 1, one process")
    p.add_argument("--worker-restarts", type=int, default=DEFAULT_WORKER_RESTARTS, metavar="N",
                   help="with --workers: times a worker that dies is started again (0: never; default %(default)s)")
    # set by `--workers` on the processes it starts (service/scaleout/workers.py); not for people
    p.add_argument("--worker-info", metavar="PREFIX", help=argparse.SUPPRESS)
    p.add_argument("--worker-parent", type=int, metavar="PID", help=argparse.SUPPRESS)
    add_security_arguments(p)
    add_accounts_arguments(p)
    add_state_arguments(p)


def serve(args: argparse.Namespace, world: Any = None) -> int:
    """Run until SIGINT/SIGTERM; 0 on a clean stop, 2 when the world cannot be opened."""
    configure_logging(args.log_level, getattr(args, "log_format", "text"))
    from service.scaleout.workers import attach_worker, die_with_parent, serve_workers, worker_count

    try:
        workers = worker_count(getattr(args, "workers", None))
    except argparse.ArgumentTypeError as e:
        print(f"acphys serve: {e}", file=sys.stderr)
        return 2
    if workers > 1 and world is None:
        return serve_workers(args, workers)
    worker_info = getattr(args, "worker_info", None)
    if worker_info and args.worker_parent is not None:
        die_with_parent(args.worker_parent)  # a worker of `--workers` goes with its parent, even one killed
    if world is None:
        from service.world_source import open_world

        try:
            world = open_world(scene=args.scene, dat_dir=args.dat_dir)
        except Exception as e:
            print(f"acphys serve: cannot open the world: {e}", file=sys.stderr)
            return 2
    listen = args.listen
    if worker_info and listen is None:
        listen = []  # a worker only connects to its parent's router
    if listen is None and not args.zenoh_config:
        listen = [DEFAULT_ENDPOINT]
    forget_logins: Callable[[], None] = no_logins_file
    try:
        config = make_config(
            config_file=args.zenoh_config, listen=listen, connect=args.connect, mode=args.mode,
            multicast=args.multicast_scouting,
        )
        bound_messages(config, args.zenoh_config)
        ownership = Ownership.parse(args.own)
        accounts = Accounts.from_args(args)
        cluster = security_setup(config, args)
        if accounts is not None:
            # the instances of a cluster (a `--workers` worker too) log in to each other with its password
            password = cluster.instance_password() if cluster is not None else None
            forget_logins = apply_accounts(config, args.prefix, accounts, instance_password=password)
        # with accounts, one tenant per user over the one world (service/security/accounts.py), each with its own state
        # file; the first tenant is the host
        users: list[str | None] = list(accounts.users) if accounts is not None else [None]
        if getattr(args, "state", None) and not worker_info:
            # movers saved by a `--workers N` run come back to this single process (service/persistence/state_layout.py)
            for user in users:
                regroup_state(args.state, 1, [ownership], user=user, discard_bad=args.state_discard_bad)
        persistences = [Persistence.from_args(args, user) for user in users]
    except Exception as e:
        forget_logins()
        print(f"acphys serve: bad configuration: {zenoh_reason(e)}", file=sys.stderr)
        return 2
    options = NodeOptions(
        prefix=args.prefix, ownership=ownership, queue_capacity=args.queue, handover_timeout=args.handover_timeout,
        info_prefix=worker_info, accept_handovers=cluster is not None, tune_heap=True, path_work=args.path_work,
    )
    stop = stop_on_signals(log, "shutting down")
    nodes: list[ServiceNode] = []
    for user, persistence in zip(users, persistences):
        info = f"{worker_info}/u/{user}" if worker_info and user is not None else worker_info
        tenant = replace(options, prefix=user_prefix(args.prefix, user) if user is not None else args.prefix,
                         info_prefix=info, on_handover_in=persistence.save_locked if persistence.path else None,
                         world_admin=accounts is None or user is not None and accounts.is_admin(user))
        nodes.append(ServiceNode(world, config, tenant, shared_with=nodes[0] if nodes else None))
    node = nodes[0]
    try:
        for n, persistence in zip(nodes, persistences):
            n.start(restore=persistence.restorer(n))
    except Exception as e:
        print(f"acphys serve: cannot start: {zenoh_reason(e)}", file=sys.stderr)
        _shutdown(nodes)
        return 2
    finally:
        forget_logins()  # the session has read its copy of the logins (or is not to be)
    detach = [attach_worker(n) for n in nodes] if worker_info else []
    named = f"; users {', '.join(accounts.users)} under {args.prefix}/u/USER" if accounts is not None else ""
    print(f"acphys service ready: instance {node.instance}, listening on {', '.join(listen or ['(config file)'])}"
          f"{named}", flush=True)
    where = (f"listening on {', '.join(listen)}" if listen else "a worker behind its parent's router" if worker_info
             else "on the config file's endpoints")
    log.info("started: instance %s, %s, owning %s, %d mover(s)%s", node.instance, where,
             ownership.to_text(), sum(len(n.core.movers) for n in nodes if n.core is not None), named)
    while not stop.wait(persistences[0].tick):
        for n, persistence in zip(nodes, persistences):
            persistence.maybe_save(n)
        ERRORS.flush()  # how many error lines the rate limit held back (service/bus/request_log.py)
    for undo in detach:
        undo()
    _shutdown(nodes)
    saved = [persistence.save(n) for n, persistence in zip(nodes, persistences)]  # every file, even after a failure
    ERRORS.flush(everything=True)
    log.info("stopped")
    if not all(saved):
        return 1  # some movers could not be written: say so rather than exit as if they were
    return 0


def _shutdown(nodes: list[ServiceNode]) -> None:
    """Tenants first: they borrow the host's (the first node's) session, which its own shutdown closes."""
    for n in reversed(nodes):
        n.shutdown()


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m service", description="Run the acphys physics service on Zenoh.")
    add_serve_arguments(p)
    args = p.parse_args(argv)
    if args.scene is None and args.dat_dir is None:
        p.error("give --scene or --dat-dir (`acphys serve` serves the built-in demo world by default)")
    return serve(args)
