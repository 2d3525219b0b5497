"""ServiceNode: the service on the Zenoh bus.

Zenoh callbacks decode a request; the engine work then runs either right
there, when the engine is idle and nothing is queued (no thread hand-off:
the common case of a lightly loaded instance), or on the engine thread,
through the bounded queue. One lock serialises the engine, and a request
runs in the callback only when every queued job has finished, so requests
are still applied in arrival order. An instance that owns only some
landblocks always queues its moves (a move may need a hand-over, which
waits on another instance while serving hand-overs sent to this one).
Health, stats and the landblock list are answered straight from the
callback (they read snapshots and counters), so they work even when the
move queue is full. A long request (a big batch, a landblock load) is
always queued, so the callback thread goes back to taking requests (they
queue behind it, and a shutdown still answers them).
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass, field
from typing import Any, cast
from collections.abc import Callable

import zenoh

from service.column_moves import push_columns, reply_message, run_columns
from service.protocol.column_request import column_count, is_column_request, parse_column_request
from service.capabilities import capabilities
from service.core import ServiceCore
from service.protocol.errors import ProtocolError
from service import heap
from service.protocol.frames import pack
from service.bus.jobqueue import JobQueue
from service.bus.key_landblocks import KeyLandblocks
from service.bus.lb_queryable import QueryHandler, landblock_queryable
from service.bus.route_keys import RouteKeys
from service.protocol.messages import HEALTH, LANDBLOCK_LIST, STATS
from service.ownership import Ownership
from service.bus.publication import ZenohBus
from service.bus.request_log import ERRORS, LoggedQuery, log_request, requests_logged
from service.bus.single_move import move_handler, submit_single
from service.protocol.move_structs import plain_single_move
from service.protocol.requests import (
    ItemError,
    decode_envelope,
    parse_moves,
    parse_single_move,
)
from service.stats import ServiceStats
from service.bus.dispatch import OPERATIONS, Operation, Work
from service.protocol import BATCH_FIELDS, LB_OPS
from service.queries import DEFAULT_PATH_WORK
from service.protocol.wire import MAX_PAYLOAD, ErrorKind, Keys, lb_hex

__all__ = ["NodeOptions", "ServiceNode"]

log = logging.getLogger("acphys.service")


@dataclass(slots=True)
class NodeOptions:
    prefix: str = "acphys"
    ownership: Ownership = field(default_factory=Ownership)
    queue_capacity: int = 1024  # requests waiting for the engine before `busy`
    handover_timeout: float = 2.0  # seconds to wait for a hand-over's answer
    publish_states: bool = True
    #: publish a move's State only while some subscriber's key expression meets `P/obj/*/state` (Zenoh's
    #: matching status, read once per request); False publishes every State whoever listens
    skip_unwatched_states: bool = True
    #: the graph building one path query may do before it answers `building` (engine World.path's `work`):
    #: a path into land whose graph is not built yet holds the engine thread, and everyone's moves, this long
    path_work: int = DEFAULT_PATH_WORK
    #: run a request in the Zenoh callback when the engine is idle (see the module's docstring)
    inline: bool = True
    #: the largest batch run in a callback (~10 ms of the interpreted engine); larger ones are queued
    inline_max_moves: int = 128
    #: zenoh-python's unstable `indirect=False`: callbacks on Zenoh's own network threads instead of a Python
    #: thread per queryable. Measured no faster here (docs/performance.md), and a long callback would stall
    #: Zenoh's network thread, so off by default
    direct_callbacks: bool = False
    #: where this instance answers health, stats and the landblock list: the public prefix (None), or a worker's
    #: private prefix that only its parent (`serve --workers`, service/scaleout/workers.py) queries
    info_prefix: str | None = None
    #: serve `P/lb/XXYY/handover` (only in a cluster whose instances authenticate: service/security/cluster.py);
    #: off, the instance takes no hand-over at all
    accept_handovers: bool = False
    #: answer `load` and `unload` (which change the world every tenant shares); off, they are refused with
    #: `forbidden`: a user of `serve --users` who is not one of its `--admin` users (service/security/accounts.py)
    world_admin: bool = True
    #: at shutdown, keep the keys declared until no request has arrived for this long (seconds), so every
    #: request Zenoh has already delivered gets its answer (see `shutdown`)
    drain_quiet: float = 0.5
    #: this process serves and nothing else (the CLI's `serve`): tune the garbage collector for a long-lived
    #: world (service/heap.py); off for a node started inside another program, such as a test run
    tune_heap: bool = False
    #: called with the core (engine lock held) after a hand-over is taken and before it is answered: the
    #: state file is written there, so the sender never forgets a mover this instance could still lose
    on_handover_in: Callable[[ServiceCore], None] | None = None

    @property
    def keys(self) -> Keys:
        return Keys(self.prefix)


class ServiceNode:
    """Open with `start()`, stop with `shutdown()` (finishes queued work first)."""

    def __init__(self, world: Any, config: zenoh.Config, options: NodeOptions | None = None, *,
                 shared_with: ServiceNode | None = None) -> None:
        """`shared_with`: a node this one is a tenant of (service/security/accounts.py): it serves its own prefix and
        movers over the same world, through that node's session, engine thread, queue and engine lock, so
        requests to both run one at a time in arrival order. Start the host first, shut it down last."""
        self.options = options or NodeOptions()
        self.keys = self.options.keys
        self.config = config
        self.world = world
        self.stats = ServiceStats()
        self._host = shared_with
        #: every node of this world (the host's list, shared): a landblock load or unload concerns them all
        self.tenants: list[ServiceNode] = shared_with.tenants if shared_with is not None else []
        self.tenants.append(self)
        self.queue: JobQueue = shared_with.queue if shared_with is not None else JobQueue(self.options.queue_capacity)
        #: this node's lane of the queue: a tenant's requests wait in a lane of their own (service/bus/jobqueue.py)
        self._lane = self.queue.new_lane() if shared_with is not None else 0
        self.session: zenoh.Session | None = None
        self.core: ServiceCore | None = None
        self._declared: list[Any] = []
        self._thread: threading.Thread | None = None
        self._draining = False
        # held while the core runs (engine thread or a callback)
        self._engine_lock: threading.Lock = shared_with._engine_lock if shared_with is not None else threading.Lock()
        self._inline = self.options.inline and self.options.ownership.everything
        #: the landblock of a request key, read once per key (service/bus/key_landblocks.py)
        self._key_lbs = KeyLandblocks(self.keys)
        self._key_lb: Callable[[str, str], int | None] = self._key_lbs.landblock
        #: the literal keys declared on the session (requests' and States'), so that Zenoh keeps their routes (set at start)
        self._route_keys: RouteKeys | None = None
        self.bus: ZenohBus | None = None  # what the core puts on the bus (service/bus/publication.py)
        self._last_arrival = time.monotonic()  # when a callback last took a request (shutdown waits for quiet)

    # -- lifecycle ------------------------------------------------------------
    def start(self, restore: Callable[[ServiceCore], None] | None = None) -> None:
        """Open the session and declare the keys; `restore` (e.g. movers from a state file) runs on the new
        core before any key is declared, so no request sees the instance half restored."""
        if self._host is None:
            self.session = zenoh.open(self.config)
        else:
            self.session = self._host.session
            if self.session is None:
                raise RuntimeError("start the host node before its tenants")
        instance = str(self.session.zid())
        o = self.options
        if not o.direct_callbacks:  # keys are declared from Python's threads only (service/bus/route_keys.py)
            self._route_keys = RouteKeys(self.session)
            self._key_lbs.learned = self._route_keys.learn
        self.bus = ZenohBus(self.session, self.keys, self, publish_states=o.publish_states,
                            skip_unwatched_states=o.skip_unwatched_states, handover_timeout=o.handover_timeout,
                            route_keys=self._route_keys)
        self.core = ServiceCore(self.world, self.bus, ownership=o.ownership, instance=instance, stats=self.stats)
        self.core.foreign_movers_in = self._foreign_movers_in
        self.core.world_changed = self._tenants_read_snapshots
        if restore is not None:
            restore(self.core)
        if self._host is None:
            self._thread = threading.Thread(target=self._engine_loop, name="acphys-engine", daemon=True)
            self._thread.start()
        s = self.session
        for part in self.options.ownership.key_parts():
            # one queryable for all of the part's operations (service/bus/lb_queryable.py); its handlers stamp
            # `_last_arrival` themselves (no wrapper call per request)
            handler = zenoh.handlers.Callback(self.lb_queryable(part), indirect=not self.options.direct_callbacks)
            self._declared.append(s.declare_queryable(self.keys.lb(part, "*"), handler))
            self._declared.append(s.declare_subscriber(self.keys.push(part), self._callback(self._on_push)))
        info = Keys(self.options.info_prefix) if self.options.info_prefix else self.keys
        self._declared.append(s.declare_queryable(info.health, self._callback(self._on_health)))
        self._declared.append(s.declare_queryable(info.stats, self._callback(self._on_stats)))
        self._declared.append(s.declare_queryable(info.landblocks, self._callback(self._on_landblocks)))
        if self.options.tune_heap and self._host is None:
            heap.tune()
            heap.settle()
        log.info("acphys service %s up; owns %s under %s/", instance, self.options.ownership.to_text(), self.keys.prefix)

    @property
    def instance(self) -> str:
        return self.core.instance if self.core else "?"

    def shutdown(self, timeout: float = 30.0) -> None:
        """Answer every request already received (its result, or `shutting_down` for those arriving from
        now on), then undeclare and close.

        The keys stay declared until no request has arrived for `drain_quiet` seconds: undeclaring drops
        whatever Zenoh has received but not yet handed to a callback, unanswered."""
        self._draining = True
        self.queue.close()  # from here on a request is refused with `shutting_down`
        deadline = time.monotonic() + timeout
        thread = self._thread if self._host is None else self._host._thread
        if thread is not None:
            thread.join(timeout)
        if self._engine_lock.acquire(timeout=max(0.0, deadline - time.monotonic())):
            self._engine_lock.release()  # a request running in a callback has finished
        while time.monotonic() < deadline and time.monotonic() - self._last_arrival < self.options.drain_quiet:
            time.sleep(0.05)
        for d in self._declared:
            try:
                d.undeclare()
            except Exception:  # already gone with the session: nothing to undo
                pass
        self._declared.clear()
        if self.bus is not None:
            self.bus.close()  # publishes nothing from here on: the State keys may go
        if self._route_keys is not None:
            self._key_lbs.learned = None
            self._route_keys.close()
            self._route_keys = None
        if self.session is not None and self._host is None:
            self.session.close()  # a tenant's session is its host's, closed by it
        self.session = None

    def _callback(self, fn: Callable[[Any], None]) -> Any:
        """`fn` as a Zenoh callback that first stamps `_last_arrival` (what shutdown waits on)."""
        def arrived(query_or_sample: Any) -> None:
            self._last_arrival = time.monotonic()
            fn(query_or_sample)

        return zenoh.handlers.Callback(arrived, indirect=not self.options.direct_callbacks)

    def snapshot(self, what: Callable[[ServiceCore], Any], timeout: float = 30.0) -> Any:
        """`what(core)` run between two requests (the engine lock held): a consistent view of the movers."""
        core = self.core
        if core is None:
            return None
        if not self._engine_lock.acquire(timeout=timeout):
            raise TimeoutError("the engine stayed busy")
        try:
            return what(core)
        finally:
            self._engine_lock.release()

    def _engine_loop(self) -> None:
        while True:
            job = self.queue.get()
            if job is None:
                return
            with self._engine_lock:
                self._run_job(job)

    def _run_job(self, job: Callable[[], None]) -> None:
        """Run a job taken from the queue (the caller holds the engine lock)."""
        try:
            job()
        except Exception:  # a job must never take the engine thread down
            log.exception("engine job failed")
            self.stats.error(ErrorKind.INTERNAL)
        finally:
            self.queue.task_done()

    def _submit(self, job: Callable[[], None], small: bool) -> bool:
        """Run `job` now when it is `small` and the engine is idle, else queue it; False when refused
        (queue full or closed). A long job is queued so the callback thread is not held up by it."""
        if small and self._inline and self.queue.idle and not self.queue.closed and self._engine_lock.acquire(blocking=False):
            try:
                run_now = self.queue.idle  # nothing was queued meanwhile: nothing to overtake
                if run_now:
                    try:
                        job()
                    except Exception:  # never let it reach zenoh's thread
                        log.exception("engine job failed")
                        self.stats.error(ErrorKind.INTERNAL)
            finally:
                self._engine_lock.release()
            if run_now:
                return True
        return self.queue.offer(job, self._lane)

    def world_changed(self, answer: dict[str, Any]) -> dict[str, Any]:
        """After a landblock load or unload (the engine lock held): the heap settled again, when tuned."""
        if self.options.tune_heap and not answer.get("already"):
            heap.settle()
        return answer

    def _tenants_read_snapshots(self, changed: ServiceCore) -> None:
        """The other tenants' cores read the shared world's snapshots again (the engine lock held)."""
        for node in self.tenants:
            if node.core is not None and node.core is not changed:
                node.core.read_snapshots()

    def _foreign_movers_in(self, lb: int) -> int:
        """Movers of the other tenants in landblock `lb` (the engine lock held)."""
        return sum(1 for node in self.tenants if node is not self and node.core is not None
                   for r in node.core.movers.values() if r.last.position.landblock == lb)

    # -- replies ----------------------------------------------------------------
    def _reply_ok(self, query: zenoh.Query, content: dict[str, Any] | bytes) -> None:
        """Reply with `content` (a map, or a message already packed)."""
        try:
            query.reply(query.key_expr, content if isinstance(content, bytes) else pack(content))
        finally:
            query.drop()

    def _reply_err(self, query: zenoh.Query, err: ProtocolError) -> None:
        self.stats.error(err.kind)
        key = str(query.key_expr)
        ERRORS.error(err.kind, key.rsplit("/", 1)[-1], key, err.message, path=err.path)
        try:
            query.reply_err(pack({"error": err.to_wire()}))
        finally:
            query.drop()

    def _refuse(self, query: zenoh.Query) -> None:
        if self.queue.closed:
            self._reply_err(query, ProtocolError(ErrorKind.SHUTTING_DOWN, "the service is shutting down"))
        else:
            self._reply_err(
                query, ProtocolError(ErrorKind.BUSY, f"the service's queue is full ({self.queue.capacity}); retry later")
            )

    @staticmethod
    def _payload(query_or_sample: Any) -> bytes | None:
        """The payload's bytes; `too_large` by its length alone, before it is copied out of Zenoh's buffer
        (copying a flood of 20-60 MB payloads only to refuse them left the process 150 MB larger)."""
        p = query_or_sample.payload
        if p is None:
            return None
        size = len(p)
        if size > MAX_PAYLOAD:
            raise ProtocolError(ErrorKind.TOO_LARGE, f"payload of {size} bytes exceeds {MAX_PAYLOAD}")
        return p.to_bytes()

    # -- per-landblock queries -----------------------------------------------------
    def lb_queryable(self, part: str) -> Callable[[zenoh.Query], None]:
        """The callback of the queryable on `P/lb/<part>/*`: every per-landblock operation this instance serves
        (the hand-over only in a cluster), each query handed to its operation's handler."""
        ops = [op for op in LB_OPS if op != "handover" or self.options.accept_handovers]
        return landblock_queryable({op: self._query_handler(op) for op in ops},
                                   {op: self.keys.lb(part, op) for op in ops})

    def _query_handler(self, op: str) -> QueryHandler:
        """`op`'s handler: the query with its key expression and the key's text (read once, by the caller)."""
        operation = OPERATIONS[op]  # looked up once per handler, not per request
        world_op = operation.changes_world
        forbidden = world_op and not self.options.world_admin
        moves = op == "move"

        def handler(query: zenoh.Query, key_expr: zenoh.KeyExpr, key: str) -> None:
            received = self._last_arrival = time.monotonic()  # stamped here: see `_callback`
            self.stats.request(op)
            logged = None
            if requests_logged():  # the DEBUG line, written when the query is answered
                logged = LoggedQuery(query, op, received)
                query = cast(zenoh.Query, logged)
            try:
                lb = self._key_lb(key, op)
                if forbidden:
                    raise ProtocolError(ErrorKind.FORBIDDEN, f"{op} changes the world every user shares: only "
                                        "the service's --admin users may send it")
                payload = self._payload(query)
                if moves:  # one move as clients send it, read straight from the bytes (else None: the map's path)
                    plain = plain_single_move(payload) if payload else None
                    if plain is not None:
                        if logged is not None:
                            logged.items = 1
                        submit_single(self, query, key_expr, plain[0], plain[1], received)
                        return
                msg = decode_envelope(payload, allow_empty=world_op)
                if logged is not None:
                    logged.items = _item_count(operation, msg)
                if moves and "move" in msg and "moves" not in msg and not is_column_request(msg):
                    # one move with more in its map (or a fault to name): run straight to its reply
                    item, batch_mode = parse_single_move(msg)
                    submit_single(self, query, key_expr, item, batch_mode, received)
                    return
                work, small = self._prepare(operation, lb, msg, received)
            except ProtocolError as e:
                self._reply_err(query, e)
                return
            except Exception as e:  # decoding must never kill the callback thread
                log.exception("decoding %s failed", op)
                self._reply_err(query, ProtocolError(ErrorKind.INTERNAL, f"internal error: {e}"))
                return

            def job() -> None:
                try:
                    content = work()
                    if op == "handover" and self.options.on_handover_in is not None and self.core is not None:
                        self.options.on_handover_in(self.core)
                except ProtocolError as e:
                    self._reply_err(query, e)
                    return
                except Exception as e:
                    log.exception("%s failed", op)
                    self._reply_err(query, ProtocolError(ErrorKind.INTERNAL, f"internal error (a fault in the service, logged there): {str(e) or 'no message'}"))
                    return
                self._reply_ok(query, content)

            if op == "handover":
                # never `busy`, and served even while this instance waits on its own hand-over
                if not self.queue.offer_priority(job):
                    self._refuse(query)
            elif not self._submit(job, small):
                self._refuse(query)

        return move_handler(self, handler) if moves else handler

    def _prepare(self, operation: Operation, lb: int | None, msg: dict[str, Any],
                 received: float) -> tuple[Work, bool]:
        """Decode on the callback thread (service/bus/dispatch.py). The closure returned runs with the engine
        lock held; the flag says whether it is short enough to run in the callback."""
        work = operation.prepare(self, lb, msg, received)
        inline = operation.inline
        return work, inline == "always" or (inline == "small" and operation.count(msg) <= self.options.inline_max_moves)

    def query_item_errors(self, op: str, lb: int | None, content: dict[str, Any]) -> dict[str, Any]:
        """A query batch's reply, its failed items logged (a WARNING each, as every error answered is):
        `{"error": ...}` in the map form's list, the `errors` of the column form."""
        failed = [(i, item["error"]) for i, item in enumerate(content.get(BATCH_FIELDS[op]) or ())
                  if isinstance(item, dict) and "error" in item]
        failed += [(e["index"], e["error"]) for e in content.get("errors") or ()]
        if failed:
            key = self.keys.lb(lb_hex(lb) if lb is not None else "*", op)
            for index, err in failed:
                ERRORS.error(str(err.get("kind")), op, key, str(err.get("message")), item=index, path=err.get("path"))
        return content

    def item_error(self, op: str, lb: int | None, err: ProtocolError, index: int, mover_id: int | None) -> None:
        """The WARNING line of one failed item of a batch (service/bus/request_log.py)."""
        key = self.keys.lb(lb_hex(lb) if lb is not None else "*", op)
        ERRORS.error(err.kind, op, key, err.message, item=index, id=mover_id, path=err.path)

    def column_work(self, msg: dict[str, Any], received: float, lb: int | None) -> Callable[[], bytes]:
        """A column request (docs/protocol.md, "Column batches"): checked here, run by the closure."""
        core, bus = self.core, self.bus
        assert core is not None and bus is not None
        req = parse_column_request(msg)

        def run() -> bytes:
            out, packed = run_columns(core, req, received)
            for i, mid, err in out.errors:
                self.stats.error(err.kind)
                self.item_error("move", lb, err, i, mid)
            if packed:
                bus.publish_batch(packed)
            return reply_message(out)

        return run

    def _on_push_columns(self, msg: dict[str, Any], received: float) -> None:
        core = self.core
        assert core is not None
        req = parse_column_request(msg)  # ProtocolError: answered on P/errors by the caller
        if not self._submit(lambda: push_columns(core, req, received), req.n <= self.options.inline_max_moves):
            kind = ErrorKind.SHUTTING_DOWN if self.queue.closed else ErrorKind.BUSY
            for mid in req.arrays["id"].tolist():
                self.stats.error(kind)
                err = ProtocolError(kind, "the service's queue is full; this move was dropped" if kind == ErrorKind.BUSY
                                    else "the service is shutting down; this move was dropped")
                self._bus().publish_error(mid, ItemError(err, mid).to_wire())

    # -- fire-and-forget ---------------------------------------------------------
    def _on_push(self, sample: zenoh.Sample) -> None:
        received = time.monotonic()
        self.stats.request("push")
        logged = requests_logged()
        try:
            # the queries' rule for keys: a put on `P/lb/A9B4/*` or `P/lb/**` reaches this subscriber too,
            # but names no operation, so nothing runs (docs/protocol.md, "Key expressions")
            self._key_lb(str(sample.key_expr), "push")
            msg = decode_envelope(self._payload(sample))
            if is_column_request(msg):
                self._on_push_columns(msg, received)
                if logged:
                    log_request("push", str(sample.key_expr), column_count(msg), "accepted", received)
                return
            batch = parse_moves(msg)
        except ProtocolError as e:
            self.stats.error(e.kind)
            ERRORS.error(e.kind, "push", str(sample.key_expr), e.message, path=e.path)
            self._bus().put(self.keys.errors, {"key": str(sample.key_expr), "error": e.to_wire()})
            if logged:
                log_request("push", str(sample.key_expr), None, e.kind, received)
            return
        except Exception as e:
            log.exception("decoding a push failed")
            ERRORS.error(ErrorKind.INTERNAL, "push", str(sample.key_expr), str(e))
            self._bus().put(self.keys.errors, {"key": str(sample.key_expr), "error": {"kind": ErrorKind.INTERNAL, "message": str(e)}})
            return
        if logged:  # what happens to each move is published (its State, or an error on its key)
            log_request("push", str(sample.key_expr), len(batch.items), "accepted", received)
        raw = [msg["move"]] if batch.single else list(msg["moves"])
        core = self.core
        assert core is not None
        if not self._submit(lambda: core.push(batch, raw, received), len(raw) <= self.options.inline_max_moves):
            kind = ErrorKind.SHUTTING_DOWN if self.queue.closed else ErrorKind.BUSY
            for item in batch.items:
                self.stats.error(kind)
                err = ProtocolError(kind, "the service's queue is full; this move was dropped" if kind == ErrorKind.BUSY
                                    else "the service is shutting down; this move was dropped")
                self._bus().publish_error(item.id, ItemError(err, item.id, item.tag).to_wire())

    # -- per-instance queries (answered on the callback thread) -------------------------
    def _instance_request(self, query: zenoh.Query, op: str) -> bool:
        """Count and check a health/stats/landblocks request: an empty payload or a valid envelope (`v` 1);
        anything else is answered with its error here (False)."""
        self.stats.request(op)
        try:
            decode_envelope(self._payload(query), allow_empty=True)
        except ProtocolError as e:
            self._reply_err(query, e)
            return False
        return True

    def _on_health(self, query: zenoh.Query) -> None:
        if not self._instance_request(query, "health"):
            return
        core = self.core
        self._reply_ok(query, HEALTH.written({
            "instance": self.instance,
            "status": "draining" if self._draining else "ok",
            **capabilities(),
            "uptime_s": time.monotonic() - self.stats.started,
            "queue_depth": self.queue.depth(self._lane),
            "queue_capacity": self.queue.capacity,
            "movers": len(core.movers) if core else 0,
            "workers": 1,
        }))

    def _on_stats(self, query: zenoh.Query) -> None:
        if not self._instance_request(query, "stats"):
            return
        core = self.core
        snap = self.stats.snapshot()
        snap["cache"] = {**snap.pop("landblock_cache"), **(core.engine_cache if core else {})}
        self._reply_ok(query, STATS.written({
            "instance": self.instance,
            **snap,
            "loaded_landblocks": list(core.loaded) if core else [],
            "movers": len(core.movers) if core else 0,
            "queue_depth": self.queue.depth(self._lane),
            "queue_capacity": self.queue.capacity,
            "workers": 1,
        }))

    def _on_landblocks(self, query: zenoh.Query) -> None:
        if not self._instance_request(query, "landblocks"):
            return
        core = self.core
        assert core is not None
        self._reply_ok(query, LANDBLOCK_LIST.written({
            "instance": self.instance,
            "owned": self.options.ownership.to_wire(),
            "loaded": list(core.loaded),
        }))

    def _bus(self) -> ZenohBus:
        assert self.bus is not None, "the node is not started"
        return self.bus

    # -- HandoverWait (the bus waits on a hand-over's answer on the engine thread) --------
    def wake(self) -> None:
        self.queue.put_priority(lambda: None)

    def serve_until(self, done: threading.Event, deadline: float) -> None:
        while not done.is_set() and time.monotonic() < deadline:
            job = self.queue.get_priority(timeout=max(0.0, deadline - time.monotonic()))
            if job is not None:
                self._run_job(job)  # on the engine thread, which holds the engine lock


def _item_count(operation: Operation, msg: dict[str, Any]) -> int | None:
    """How many items a request holds, for its DEBUG line (1 for an operation on one mover or landblock;
    None when the request is too malformed to tell: its error follows)."""
    try:
        return operation.count(msg)
    except Exception:
        return None
