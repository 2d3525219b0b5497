"""`acphys serve --workers N`: N engine processes behind one service face.

The parent process holds no mover and runs no physics. It opens a Zenoh
session in **router** mode (a real Zenoh router, service/bus/router.py)
listening on the public endpoint(s) and on a private loopback TLS
endpoint, and starts N workers, each an ordinary `python -m service` in
client mode connected to the private endpoint and owning a share of the
landblocks. The workers are a cluster (service/security/cluster.py): they reach the
router over mutual TLS with certificates of a throwaway CA the parent makes
at start (service/security/certificates.py; or the `--cluster` file's, when one is
given, whose `listen`/`connect` endpoints the router then serves too), so
hand-overs pass between them while the router refuses them to clients
(Ownership.split: contiguous runs of a scene's landblocks, or X stripes of
a dat directory's map). Zenoh's routing sends each landblock's keys to its
worker; a mover crossing between workers is handed over exactly as between
separate instances (core.ServiceCore._hand_over).

Workers answer health, stats and the landblock list under private keys,
`P/@workers/<parent id>/<index>/...` (a `@` chunk is verbatim in Zenoh:
no wildcard such as `P/**` reaches it), and the parent answers the public
`P/health`, `P/stats` and `P/landblocks` once for the whole service
(service/scaleout/aggregate.py). It watches the workers: one that dies is logged,
Health says `degraded`, and the parent starts it again with the same
landblocks (after 0.5 s, doubling with each restart up to 30 s; at most
`--worker-restarts` times, default 5; its movers come back from its
`--state` file when there is one). SIGINT/SIGTERM to the parent stops every
worker (each finishes its queue), then the router.

With `--users` (service/security/accounts.py) the router checks every login and
carries the users' access control; each worker logs in to it as the
internal user INSTANCE_USER (a password made at start, in the private
directory beside the certificates, named by the workers' cluster file)
and runs one tenant per user, whose private keys are
`P/@workers/<parent id>/<index>/u/<user>/...`; the parent answers each
user's `P/u/<user>/health`, `stats` and `landblocks`.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import logging
import os
import re
import signal
import socket
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from collections.abc import Callable

import msgpack
import zenoh

from service.security.accounts import Accounts, new_instance_password, write_private
from service.scaleout.aggregate import WorkerView, merge_health, merge_landblocks, merge_stats
from service.protocol.errors import ProtocolError
from service.protocol.frames import pack
from service.protocol.messages import HEALTH, LANDBLOCK_LIST, STATS
from service.ownership import Ownership
from service.capabilities import capabilities
from service.security.certificates import INSTANCE_CN, make_certificates
from service.bus.request_log import ERRORS, log_request, requests_logged
from service.bus.router import router_config
from service.security.cluster import ClusterConfig
from service.persistence.state_layout import regroup_state, worker_state_path
from service.stats import ServiceStats
from service.command import positive_int, stop_on_signals
from service.protocol.wire import ErrorKind, Keys, user_prefix
from service.bus.zconfig import DEFAULT_ENDPOINT, zenoh_reason

__all__ = ["worker_count", "serve_workers", "attach_worker", "die_with_parent", "WorkerSupervisor"]

log = logging.getLogger("acphys.workers")

#: seconds for a worker to print its ready line (it loads the whole world first)
WORKER_START_TIMEOUT = 120.0
#: how many times a worker that dies is started again, by default (`--worker-restarts`)
DEFAULT_WORKER_RESTARTS = 5
#: seconds between a worker's death and its restart: the first, and the most (each restart doubles it, so
#: that a worker dying at every start does not spin the machine)
RESTART_DELAY_FIRST = 0.5
RESTART_DELAY_MAX = 30.0
#: seconds a worker gets to finish its queue after SIGTERM before it is killed
WORKER_STOP_TIMEOUT = 30.0
#: seconds the parent waits for the workers' answers to a health query (they answer off the engine thread, in
#: well under a millisecond when idle), and to a stats or landblocks query (stats carry the latency samples)
HEALTH_TIMEOUT = 0.5
INFO_TIMEOUT = 2.0
_READY = re.compile(r"acphys service ready: instance (\S+),")
_PACKAGE_ROOT = Path(__file__).resolve().parents[2]
_PR_SET_PDEATHSIG = 1


def restart_delay(restarts: int) -> float:
    """Seconds to wait before restarting a worker that has already been restarted `restarts` times."""
    return min(RESTART_DELAY_MAX, RESTART_DELAY_FIRST * 2.0 ** restarts)


def worker_count(text: str | int | None) -> int:
    """`--workers`: a positive count, or `auto` for the CPUs this process may run on."""
    if text is None:
        return 1
    if isinstance(text, str) and text.strip().lower() == "auto":
        try:
            return len(os.sched_getaffinity(0))
        except AttributeError:  # not Linux
            return os.cpu_count() or 1
    try:
        return positive_int(str(text))
    except argparse.ArgumentTypeError as e:
        raise argparse.ArgumentTypeError(f"--workers takes a positive count or 'auto': {e}") from None


def private_prefix(prefix: str, parent: str) -> str:
    return f"{prefix}/@workers/{parent}"


def scene_landblocks(scene: str) -> list[int]:
    """The landblock ids an acphys-scene/1 file holds (read without building the world)."""
    with open(scene, encoding="utf-8") as f:
        data = json.load(f)
    try:
        return [int(str(lb["id"]), 16) for lb in data["landblocks"]]
    except (KeyError, TypeError, ValueError) as e:
        raise ValueError(f"{scene}: no readable landblock list ({e})") from None


def _free_loopback_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


# -- the worker's side -------------------------------------------------------------------------
def attach_worker(node: Any) -> Callable[[], None]:
    """In a worker, after `node.start()`: answer the parent's latency-sample query beside the node's private
    health/stats. Returns what undoes it (call before `node.shutdown()`)."""
    assert node.session is not None and node.options.info_prefix
    key = f"{node.options.info_prefix}/samples"

    def on_samples(query: zenoh.Query) -> None:
        try:
            query.reply(query.key_expr, pack({"instance": node.instance, **node.stats.samples()}))
        finally:
            query.drop()

    queryable = node.session.declare_queryable(key, on_samples)

    def detach() -> None:
        try:
            queryable.undeclare()
        except Exception:  # the session is already closed: nothing to undo
            pass

    return detach


def die_with_parent(parent_pid: int) -> None:
    """Ask Linux for SIGTERM when the parent goes (a parent killed by SIGKILL leaves no orphan worker)."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
    except (OSError, AttributeError):  # not Linux: the parent's own shutdown still stops the workers
        return
    if os.getppid() != parent_pid:  # the parent went before prctl took effect
        os.kill(os.getpid(), signal.SIGTERM)


# -- the parent's side -------------------------------------------------------------------------
@dataclass(slots=True)
class WorkerProcess:
    index: int
    ownership: Ownership
    argv: list[str]
    proc: subprocess.Popen[str] | None = None
    instance: str | None = None
    ready: threading.Event = field(default_factory=threading.Event)
    died: bool = False  # exited while the service was running (at least once)
    output: deque[str] = field(default_factory=lambda: deque(maxlen=50))  # its latest stdout lines, for errors
    #: times it was started again after dying
    restarts: int = 0
    #: when its death was noticed (monotonic), until it is started again
    down_since: float | None = None

    def view(self) -> WorkerView:
        code = self.proc.poll() if self.proc is not None else None
        return WorkerView(self.index, self.ownership, self.proc.pid if self.proc else None,
                          self.proc is not None and code is None, self.instance, code, self.restarts)


class WorkerSupervisor:
    """The parent: a router, N worker processes, and the service's one health/stats/landblocks face."""

    def __init__(self, args: argparse.Namespace, count: int) -> None:
        self.args = args
        self.keys = Keys(args.prefix)
        self.wanted = count
        self.stats = ServiceStats()
        self.session: zenoh.Session | None = None
        self.instance = "?"
        self.workers: list[WorkerProcess] = []
        self.draining = False
        self._declared: list[Any] = []
        self._private_endpoint = ""
        self._cluster_dir: Path | None = None  # the throwaway certificates and the workers' cluster file
        self._worker_cluster: Path | None = None
        self.listen: list[str] | None = None
        #: `--users` (service/security/accounts.py): the users, and the password the workers log in to the router with
        self.accounts: Accounts | None = None
        self._instance_password: str | None = None
        #: the face's request counters, per key space (a user's, or None: the public prefix)
        self._face_stats: dict[str | None, ServiceStats] = {}
        #: how many times a dead worker is started again
        self.restart_limit: int = getattr(args, "worker_restarts", DEFAULT_WORKER_RESTARTS)
        self._env: dict[str, str] = {}

    # -- planning -------------------------------------------------------------------------------
    def plan(self) -> list[Ownership]:
        """Each worker's landblocks: the `--own` given (default all) split into contiguous parts."""
        own = Ownership.parse(self.args.own)
        known: list[int] = []
        if own.everything and self.args.scene is not None:
            known = scene_landblocks(self.args.scene)
        parts = own.split(self.wanted, known)
        if len(parts) < self.wanted:
            log.warning("%d workers asked for, but only %d share(s) of landblocks to give: starting %d",
                        self.wanted, len(parts), len(parts))
        return parts

    def _worker_argv(self, index: int, ownership: Ownership) -> list[str]:
        a = self.args
        argv = [sys.executable, "-m", "service"]
        argv += ["--scene", a.scene] if a.scene is not None else ["--dat-dir", a.dat_dir]
        argv += ["--own", ownership.to_text(), "--mode", "client", "--cluster", str(self._worker_cluster),
                 "--prefix", a.prefix, "--queue", str(a.queue), "--handover-timeout", str(a.handover_timeout),
                 "--path-work", str(a.path_work),
                 "--log-level", a.log_level, "--log-format", getattr(a, "log_format", "text"),
                 "--worker-info", f"{private_prefix(a.prefix, self.instance)}/{index}", "--worker-parent", str(os.getpid())]
        if self.accounts is not None:
            argv += ["--users", str(self.accounts.path)]
            for admin in self.accounts.admins:
                argv += ["--admin", admin]
        if getattr(a, "state", None):
            # each worker keeps its own movers: one file per worker of this split (regroup_state, at start,
            # has put every saved mover in the file of its landblock's worker)
            argv += ["--state", worker_state_path(a.state, index, self.wanted),
                     "--state-interval", str(a.state_interval),
                     "--state-sync", getattr(a, "state_sync", None) or "every-second"]
            if a.state_discard_bad:
                argv.append("--state-discard-bad")
        return argv

    def _cluster(self, private: str) -> ClusterConfig:
        """The router's cluster (its private TLS endpoint for the workers, plus a `--cluster` file's
        endpoints), and the workers' cluster file, connecting to `private`."""
        given = ClusterConfig.load(self.args.cluster) if getattr(self.args, "cluster", None) else None
        if self._cluster_dir is None:
            self._cluster_dir = Path(tempfile.mkdtemp(prefix="acphys-workers-"))
            if given is None:
                make_certificates(self._cluster_dir)
        d = self._cluster_dir
        if given is not None:
            ca, cert, key = given.ca.resolve(), given.cert.resolve(), given.key.resolve()
        else:
            ca, cert, key = d / "ca.pem", d / f"{INSTANCE_CN}.pem", d / f"{INSTANCE_CN}-key.pem"
        worker: dict[str, Any] = {"ca": str(ca), "cert": str(cert), "key": str(key), "connect": [private]}
        if self.accounts is not None:
            # the workers log in to the router with the `--cluster` file's password (other instances use it
            # too), else one of this start's, beside the certificates
            if self._instance_password is None:
                self._instance_password = given.instance_password() if given is not None else new_instance_password()
            secret = d / "instance-password.txt"
            write_private(secret, self._instance_password + "\n")
            worker["password"] = str(secret)
        self._worker_cluster = d / "worker.json"
        self._worker_cluster.write_text(json.dumps(worker))
        return ClusterConfig(ca, cert, key, [private, *(given.listen if given else [])],
                             list(given.connect) if given else [])

    # -- lifecycle ------------------------------------------------------------------------------
    def start(self) -> None:
        """Open the router, start the workers, wait until each serves through the router, answer the face."""
        parts = self.plan()
        a = self.args
        self.accounts = Accounts.from_args(a)
        if a.zenoh_config and not a.listen:
            # the workers' private endpoint is added to the listen list, which then replaces the file's
            raise ValueError("--workers with --zenoh-config needs --listen too (the workers' private endpoint joins it)")
        self.listen = a.listen or [DEFAULT_ENDPOINT]
        if getattr(a, "state", None):
            # movers saved under another worker count (or split) go to the files of this one's workers
            for user in self._spaces():
                regroup_state(a.state, self.wanted, parts, user=user, discard_bad=a.state_discard_bad)
        for attempt in range(5):  # the free port may be taken between finding and binding it
            self._private_endpoint = f"tls/127.0.0.1:{_free_loopback_port()}"
            try:
                cluster = self._cluster(self._private_endpoint)
                cfg, forget_logins = router_config(list(self.listen), a.connect, a.zenoh_config, a.multicast_scouting,
                                                   prefix=a.prefix, cluster=cluster, accounts=self.accounts,
                                                   instance_password=self._instance_password)
                try:
                    self.session = zenoh.open(cfg)
                finally:
                    forget_logins()
                break
            except Exception:
                if attempt == 4:
                    raise
        assert self.session is not None
        self.instance = str(self.session.zid())
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join([str(_PACKAGE_ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
        env["PYTHONUNBUFFERED"] = "1"
        self._env = env
        for index, ownership in enumerate(parts):
            w = WorkerProcess(index, ownership, self._worker_argv(index, ownership))
            self._spawn(w)
            self.workers.append(w)
        deadline = time.monotonic() + WORKER_START_TIMEOUT
        for w in self.workers:
            while not w.ready.wait(0.05):
                assert w.proc is not None
                if w.proc.poll() is not None or time.monotonic() > deadline:
                    raise RuntimeError(f"worker {w.index} did not start (exit code {w.proc.poll()})"
                                       + "".join(w.output))
        self._wait_routed(deadline)
        s = self.session
        # one face per key space: the public prefix, or with accounts each user's (answered from that user's
        # tenants in the workers). Indirect: each answer waits on a query to the workers, which must not hold
        # up Zenoh's own threads
        for user in self._spaces():
            keys = Keys(user_prefix(a.prefix, user)) if user is not None else self.keys
            self._face_stats[user] = ServiceStats()
            self._declared += [
                s.declare_queryable(key, zenoh.handlers.Callback(self._answer(op, build, user), indirect=True))
                for key, op, build in (
                    (keys.health, "health", lambda u=user: HEALTH.written(self._health(u))),
                    (keys.stats, "stats", lambda u=user: STATS.written(self._stats(u))),
                    (keys.landblocks, "landblocks", lambda u=user: LANDBLOCK_LIST.written(self._landblocks(u))))
            ]
        for w in self.workers:
            log.info("worker %d: pid %d, instance %s, owns %s", w.index, w.proc.pid if w.proc else -1, w.instance,
                     w.ownership.to_text())

    def _spawn(self, w: WorkerProcess) -> None:
        """Start the worker's process (again, after it died) and the thread reading its output."""
        # a session of its own: a terminal's Ctrl-C reaches the parent only, which stops the workers in order
        proc = subprocess.Popen(w.argv, stdout=subprocess.PIPE, stderr=None, text=True, env=self._env,
                                start_new_session=True)
        w.proc, w.ready = proc, threading.Event()
        threading.Thread(target=self._pump, args=(w, proc, w.ready), name=f"acphys-worker-{w.index}-out",
                         daemon=True).start()

    def _pump(self, w: WorkerProcess, proc: subprocess.Popen[str], ready: threading.Event) -> None:
        """Read a worker process's stdout: its ready line (kept to ourselves), the rest shown with its index."""
        assert proc.stdout is not None
        for line in proc.stdout:
            m = _READY.search(line)
            if m and not ready.is_set():
                w.instance = m.group(1)
                ready.set()
                continue
            w.output.append(line)
            print(f"[worker {w.index}] {line}", end="", flush=True)

    def _wait_routed(self, deadline: float) -> None:
        """Until every worker answers its private health through the router (its keys are declared there)."""
        want = {w.index for w in self.workers}
        while True:
            got = set(self._ask("health", self._spaces()[0]))
            if want <= got:
                return
            if time.monotonic() > deadline:
                raise RuntimeError(f"workers {sorted(want - got)} do not answer through the router")
            time.sleep(0.05)

    def watch(self, now: float | None = None) -> None:
        """Log a worker that has exited while the service runs, and start it again when its delay is up
        (called periodically)."""
        now = time.monotonic() if now is None else now
        for w in self.workers:
            if self.draining or w.proc is None or w.proc.poll() is None:
                continue
            if w.down_since is None:  # just noticed
                w.died, w.down_since = True, now
                log.error("worker %d (pid %d, instance %s) died with exit code %s; landblocks %s are not served",
                          w.index, w.proc.pid, w.instance, w.proc.returncode, w.ownership.to_text())
                if w.restarts < self.restart_limit:
                    log.warning("worker %d: starting it again in %.1f s (restart %d of at most %d)", w.index,
                                restart_delay(w.restarts), w.restarts + 1, self.restart_limit)
                else:
                    log.error("worker %d: not started again (--worker-restarts %d used up)", w.index, self.restart_limit)
            if w.restarts < self.restart_limit and now - w.down_since >= restart_delay(w.restarts):
                w.restarts += 1
                w.down_since = None
                self._spawn(w)
                log.info("worker %d started again: pid %d", w.index, w.proc.pid)

    def shutdown(self) -> int:
        """Stop every worker (SIGTERM: each answers its queue), then the router; 0 when all went cleanly."""
        self.draining = True
        clean = True
        for w in self.workers:
            if w.proc is not None and w.proc.poll() is None:
                w.proc.send_signal(signal.SIGTERM)
        for w in self.workers:
            if w.proc is None:
                continue
            try:
                code = w.proc.wait(WORKER_STOP_TIMEOUT)
            except subprocess.TimeoutExpired:
                log.error("worker %d (pid %d) did not stop in %.0f s: killed", w.index, w.proc.pid, WORKER_STOP_TIMEOUT)
                w.proc.kill()
                code = w.proc.wait(10)
            if code != 0 or w.died:
                clean = False
                log.error("worker %d exited with code %s%s", w.index, code, " (it had died)" if w.died else "")
        for d in self._declared:
            try:
                d.undeclare()
            except Exception:  # gone with the session
                pass
        self._declared.clear()
        if self.session is not None:
            self.session.close()
            self.session = None
        if self._cluster_dir is not None:
            shutil.rmtree(self._cluster_dir, ignore_errors=True)
            self._cluster_dir = None
        return 0 if clean else 1

    # -- the service's face -----------------------------------------------------------------------
    def _spaces(self) -> list[str | None]:
        """The key spaces the workers serve: each user's with accounts, else the public prefix (None)."""
        return list(self.accounts.users) if self.accounts is not None else [None]

    def _ask(self, what: str, user: str | None = None) -> dict[int, dict[str, Any]]:
        """Every worker's answer on its private `what` key (of `user`'s tenant, with accounts), by worker index
        (those that answered)."""
        session = self.session
        if session is None:
            return {}
        out: dict[int, dict[str, Any]] = {}
        by_instance = {w.instance: w.index for w in self.workers}
        prefix = private_prefix(self.keys.prefix, self.instance)
        try:
            key = f"{prefix}/*/u/{user}/{what}" if user is not None else f"{prefix}/*/{what}"
            replies = session.get(key, target=zenoh.QueryTarget.ALL,
                                  consolidation=zenoh.ConsolidationMode.NONE,
                                  timeout=HEALTH_TIMEOUT if what == "health" else INFO_TIMEOUT)
            for r in replies:
                if r.ok is None:
                    continue
                msg = msgpack.unpackb(r.ok.payload.to_bytes(), raw=False, strict_map_key=False)
                # a reply comes on the query's key (a wildcard): the worker's instance id says whose it is
                index = by_instance.get(msg.get("instance")) if isinstance(msg, dict) else None
                if index is not None:
                    out[index] = msg
        except Exception:  # the session is closing, or a reply is unreadable: answer with what came
            log.debug("asking the workers for %s failed", what, exc_info=True)
        return out

    def _base(self) -> dict[str, Any]:
        return {"instance": self.instance, **capabilities(), "uptime_s": time.monotonic() - self.stats.started}

    def _views(self) -> list[WorkerView]:
        return [w.view() for w in self.workers]

    def _health(self, user: str | None = None) -> dict[str, Any]:
        return merge_health(self._base(), self._ask("health", user), self._views(), self.draining)

    def _stats(self, user: str | None = None) -> dict[str, Any]:
        replies, samples = self._ask("stats", user), self._ask("samples", user)
        snap = self._face_stats.get(user, self.stats).snapshot()
        parent = {"requests": snap["requests"], "errors": snap["errors"]}
        return merge_stats(self._base(), parent, replies, samples, self._views(), self.draining)

    def _landblocks(self, user: str | None = None) -> dict[str, Any]:
        own = Ownership.parse(self.args.own)
        return merge_landblocks({"instance": self.instance, "owned": own.to_wire()}, self._ask("landblocks", user),
                                self._views())

    def _answer(self, op: str, build: Callable[[], dict[str, Any]],
                user: str | None = None) -> Callable[[zenoh.Query], None]:
        stats = self._face_stats.get(user, self.stats)

        def handler(query: zenoh.Query) -> None:
            received = time.monotonic()
            stats.request(op)
            result = "ok"
            try:  # the payload is not read, as a single instance does not read it
                query.reply(query.key_expr, pack(build()))
            except Exception as e:  # never let it reach zenoh's thread
                log.exception("answering %s failed", op)
                stats.error(ErrorKind.INTERNAL)
                result = ErrorKind.INTERNAL
                ERRORS.error(result, op, str(query.key_expr), f"internal error: {e}")
                query.reply_err(pack({"error": ProtocolError(ErrorKind.INTERNAL, f"internal error: {e}").to_wire()}))
            finally:
                if requests_logged():
                    log_request(op, str(query.key_expr), None, result, received)
                query.drop()

        return handler


def serve_workers(args: argparse.Namespace, count: int) -> int:
    """`serve --workers N` (N > 1): run until SIGINT/SIGTERM; 0 on a clean stop, 1 when a worker
    failed, 2 when the service cannot start."""
    if args.mode not in (None, "router"):
        print("acphys serve: --workers runs a Zenoh router in front of the workers; --mode must be router or absent",
              file=sys.stderr)
        return 2
    if getattr(args, "worker_restarts", 0) < 0:
        print("acphys serve: --worker-restarts must be 0 or more", file=sys.stderr)
        return 2
    stop = stop_on_signals(log, "stopping the workers")
    sup = WorkerSupervisor(args, count)
    try:
        sup.start()
    except Exception as e:
        print(f"acphys serve: cannot start the workers: {zenoh_reason(e)}", file=sys.stderr)
        sup.shutdown()
        return 2
    named = f"; users {', '.join(sup.accounts.users)} under {args.prefix}/u/USER" if sup.accounts is not None else ""
    print(f"acphys service ready: instance {sup.instance}, listening on {', '.join(sup.listen or ['(config file)'])}, "
          f"{len(sup.workers)} workers{named}", flush=True)
    log.info("started: instance %s, listening on %s, %d workers", sup.instance, ", ".join(sup.listen or []),
             len(sup.workers))
    while not stop.wait(0.2):
        sup.watch()
        ERRORS.flush()
    code = sup.shutdown()
    ERRORS.flush(everything=True)
    log.info("stopped (exit status %d)", code)
    return code
