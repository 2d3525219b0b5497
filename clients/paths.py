"""Paths in the client library: Client.path and Client.paths (docs/protocol.md, "Paths").

A path query asks the service for a way a walker can really walk from a start to a goal: found on a
navigation graph whose every edge the client's own transition walked, and proven by walking it with the
walker's shape before it is answered (engine.navigation; README.md, "Paths"). The answer is the engine's
own `engine.navigation.results.PathResult` (also `engine.PathResult`).

The walker is a shape (`engine.MoverSpec`, with the start given) or a registered mover's id (which starts
where it stands). A query goes to the landblock key of its start: a MoverSpec walker's `start`, or the
landblock the client believes the mover is in (`Client.landblock_of`: the last State it saw of it, or a
`find` when it has seen none); the service's `wrong_landblock` / `moved` answer corrects a stale belief
and is followed. Like every spatial query it is read-only: no mover changes, a walker mover's `seq`
included.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, cast

from engine.geometry import Position
from engine import DEFAULT_NAV, MoverSpec, PathResult
from service.protocol.errors import ProtocolError
from service.protocol import BATCH_FIELDS, MAX_PATH_BATCH, read_answer, write_answer, write_query
from service.protocol.wire import ErrorKind

from clients.errors import ServiceError
from clients.types import MoverState

__all__ = ["PathQueries", "Followed", "MAX_PATHS_PER_REQUEST", "path_answer_map"]

#: the walk a path's guarantee is about (docs/protocol.md, "Paths"): moves of at most this many metres
#: toward the next waypoint, until within ARRIVAL of it
STRIDE = DEFAULT_NAV.stride
ARRIVAL = DEFAULT_NAV.arrival_tolerance


@dataclass(frozen=True, slots=True)
class Followed:
    """How a `Client.follow` went: how many waypoints after the first the mover reached (all of them:
    `len(waypoints) - 1`), the moves it sent, and the mover's State after the last one."""

    reached: int
    moves: int
    state: MoverState

    def arrived(self, waypoints: Sequence[Position]) -> bool:
        """Whether it reached every waypoint, the goal last."""
        return self.reached == len(waypoints) - 1

#: most paths one batch request may hold (docs/protocol.md, "Paths"): `paths` splits longer lists
MAX_PATHS_PER_REQUEST = MAX_PATH_BATCH
_OP = "path"
_BATCH = BATCH_FIELDS[_OP]
#: how many times a path answered "building" is asked again before that answer is returned: each ask
#: builds up to the service's `--path-work` more of the graph (10,000 placements and walks by default, a
#: landblock's graph being about 60,000), so 100 asks cover the graphs of more than a dozen landblocks
MAX_BUILDING_ASKS = 100


def _path_item(walker: MoverSpec | int, start: Position | None, goal: Position, max_distance: float | None,
               budget: int | None, avoid_movers: bool) -> dict[str, Any]:
    """One path query's wire map (protocol.md, "Paths"): the walker, `from` for a MoverSpec, `to` and the
    options that differ from the defaults."""
    spec = walker if isinstance(walker, MoverSpec) else None
    return write_query(_OP, mover=spec, id=None if spec is not None else walker, from_=start, to=goal,
                       max_distance=max_distance, budget=budget, avoid_movers=True if avoid_movers else None)


def read_path_answer(wire: Any) -> PathResult:
    """A path answer map as a PathResult (waypoints as Positions with their cells); ServiceError
    `malformed` for a map that is not one."""
    try:
        result: PathResult = read_answer(_OP, wire)
    except (AttributeError, KeyError, TypeError, ValueError, ProtocolError) as e:
        raise ServiceError(ErrorKind.MALFORMED, f"unreadable path answer: {e}") from None
    return result


def path_answer_map(result: PathResult) -> dict[str, Any]:
    """A PathResult as its answer map, as docs/protocol.md gives it (what `acphys path --json` prints)."""
    answer: dict[str, Any] = write_answer(_OP, result)
    return answer


def _check_walker(walker: MoverSpec | int, start: Position | None, where: str) -> None:
    """ValueError / TypeError for a walker and start that cannot make a query (before anything is sent)."""
    if isinstance(walker, MoverSpec):
        if start is None:
            raise ValueError(f"{where}: a MoverSpec walker needs a start (the position it starts from)")
    elif isinstance(walker, int) and not isinstance(walker, bool):
        if not 0 < walker < 2**64:
            raise ValueError(f"{where}: a mover id is an unsigned 64-bit id above 0, not {walker}")
        if start is not None:
            raise ValueError(f"{where}: a registered mover {walker:X} starts where it stands: give start None")
    else:
        raise TypeError(f"{where}: the walker is a MoverSpec or a registered mover's id, not {type(walker).__name__}")


def _building(answer: PathResult | ServiceError | None) -> bool:
    return isinstance(answer, PathResult) and answer.reason == "building"


class PathQueries:
    """The path queries, mixed into `Client` (which gives them `_lb_request` and `landblock_of`, `get` and
    `move`): call them on a Client."""

    _lb_request: Callable[..., dict[str, Any]]
    landblock_of: Callable[..., int]
    get: Callable[..., tuple[MoverState, Any]]
    move: Callable[..., MoverState]

    def _start_landblock(self, walker: MoverSpec | int, start: Position | None) -> int:
        """The landblock whose key a query of `walker` from `start` goes to."""
        if isinstance(walker, MoverSpec):
            assert start is not None
            return start.landblock
        return self.landblock_of(walker)

    def _ask_one(self, op: str, lb: int, item: dict[str, Any], mover_id: int | None, timeout: float | None,
                 keep_asking: bool) -> PathResult:
        """One path-answered query (`path`, `random_point`) on landblock `lb`'s key, asked again while it is
        answered "building" (at most MAX_BUILDING_ASKS times) when `keep_asking`."""
        for _ in range(MAX_BUILDING_ASKS if keep_asking else 1):
            result = read_path_answer(self._lb_request(lb, op, {"v": 1, op: item}, mover_id, timeout=timeout)[op])
            if result.reason != "building":
                break
        return result

    def path(self, walker: MoverSpec | int, start: Position | None, goal: Position, *,
             max_distance: float | None = None, budget: int | None = None, avoid_movers: bool = False,
             timeout: float | None = None, keep_asking: bool = True) -> PathResult:
        """A path `walker` can walk from `start` to `goal` (World.path, on the service): a `PathResult`.

        `walker`: a `MoverSpec` (the shape and step heights of what will walk), with `start` the Position
        it starts from; or a registered mover's id, with `start` None: it starts where it stands. The
        query goes to the start's landblock: for an id, the landblock the client last saw the mover in
        (`landblock_of`, which asks every instance when it has seen none; `locate` tells it), and a
        `wrong_landblock` or `moved` answer is followed. `goal`: where to go. `max_distance`: the longest
        path wanted, metres (above 0, at most 49,152); `budget`: graph nodes the search may expand
        (1 .. 100,000; None: the service's 10,000); `avoid_movers`: the movers standing now are obstacles
        (by default other movers are not).

        The answer: `found`; `waypoints`, Positions from where the walker starts (a MoverSpec walker: where
        it is placed at `start`, as a new object entering the world) to the goal as it stands there, each
        with the cell it lies in; `length` in metres (the straight legs summed); `expanded` (graph nodes
        searched); when not found, `reason` ("unreachable", "budget", "not_loaded": the start's or the
        goal's landblock is not loaded on the instance asked, "start_invalid", "goal_invalid") and
        `detail` in words. A path is found only within the land of the one instance asked.

        The guarantee (docs/protocol.md, "Paths"): walking the waypoints in turn with moves of at most
        3 m straight toward the next waypoint, until within 0.25 m of it (at most ceil(leg / 3) + 3 moves
        a leg), the walker reaches every waypoint within 0.25 m, standing on walkable ground in the
        waypoint's cell, the goal last; it holds while the world stays as it was (no landblock loaded or
        unloaded, and no mover in the way unless `avoid_movers`). Nothing changes: no mover moves, the
        walker's `seq` included.

        The first path that reaches a landblock builds that landblock's graph for the walker's size
        (about a second of the service's time per landblock, the interpreted engine's many times more). The
        service does it in shares (`acphys serve --path-work`), answering "building" after each so that
        everyone's moves go on meanwhile; with `keep_asking` (the default) this method asks again, up to
        MAX_BUILDING_ASKS times, and returns the first other answer. `timeout` is per request (seconds;
        None: the client's).

        Raises ValueError for a MoverSpec without `start`, an id with a `start`, or an id that is not a
        uint64 above 0 (TypeError for a walker of neither kind); ServiceError: `unknown_mover` (no such
        mover), `bad_value` (an option out of range, a bad MoverSpec), `non_finite`, `unknown_cell`;
        NoServiceError (no instance owns the start's landblock), RequestTimeout."""
        _check_walker(walker, start, "path")
        item = _path_item(walker, start, goal, max_distance, budget, avoid_movers)
        mover_id = None if isinstance(walker, MoverSpec) else walker
        return self._ask_one(_OP, self._start_landblock(walker, start), item, mover_id, timeout, keep_asking)

    def paths(self, walker: MoverSpec | int, pairs: Sequence[tuple[Position | None, Position]], *,
              max_distance: float | None = None, budget: int | None = None, avoid_movers: bool = False,
              timeout: float | None = None, keep_asking: bool = True) -> list[PathResult | ServiceError]:
        """`path` of one walker for each (start, goal) pair, in order: one entry per pair, its PathResult
        or a ServiceError for a pair the service refused alone. A not-found path is a PathResult with
        `found` False, not an error.

        `walker` and each pair's start as `path`'s: a MoverSpec with every start given (they may lie in
        different landblocks), or a registered mover's id with every start None (every path then starts
        where the mover stands). `max_distance`, `budget` and `avoid_movers` apply to every pair.

        One batch request per start landblock, of at most 64 paths each (a longer share is split into
        several requests, sent one after the other); the answers are put back in the pairs' order.
        Raises ValueError / TypeError as `path` does, naming the pair; ServiceError when a request is
        refused whole (a field error, whose path indexes that request's share of the pairs); NoServiceError,
        RequestTimeout. `timeout` is per request; `keep_asking` as `path`'s, for the pairs answered
        "building"."""
        for i, (start, _goal) in enumerate(pairs):
            _check_walker(walker, start, f"paths[{i}]")
        out: list[PathResult | ServiceError | None] = [None] * len(pairs)
        by_lb: dict[int, list[int]] = {}
        for i, (start, _goal) in enumerate(pairs):
            by_lb.setdefault(self._start_landblock(walker, start), []).append(i)
        mover_id = None if isinstance(walker, MoverSpec) else walker
        for _ in range(MAX_BUILDING_ASKS if keep_asking else 1):
            for lb, idx in by_lb.items():
                for k in range(0, len(idx), MAX_PATHS_PER_REQUEST):
                    share = idx[k:k + MAX_PATHS_PER_REQUEST]
                    items = [_path_item(walker, pairs[i][0], pairs[i][1], max_distance, budget, avoid_movers)
                             for i in share]
                    reply = self._lb_request(lb, _OP, {"v": 1, _BATCH: items}, mover_id, timeout=timeout)
                    answers = reply.get(_BATCH)
                    if not isinstance(answers, list) or len(answers) != len(share):
                        raise ServiceError(ErrorKind.MALFORMED, f"a paths reply of {len(share)} items does not match the request")
                    for i, a in zip(share, answers, strict=True):
                        out[i] = (ServiceError.from_wire(a["error"]) if isinstance(a, dict) and "error" in a
                                  else read_path_answer(a))
            # the pairs answered "building" are asked again, the others kept
            by_lb = {lb: still for lb, idx in by_lb.items() if (still := [i for i in idx if _building(out[i])])}
            if not by_lb:
                break
        return cast(list[PathResult | ServiceError], out)  # every pair answered above

    def random_point(self, walker: MoverSpec | int, near: Position | None, radius: float, *, seed: int | None = None,
                     budget: int | None = None, avoid_movers: bool = False, timeout: float | None = None,
                     keep_asking: bool = True) -> PathResult:
        """A random point the walker can walk to within `radius` metres (horizontally, above 0 and at most
        1,000) of `near`, and the path there (World.random_point, on the service): the wandering query of
        a creature's AI. The answer is a PathResult whose last waypoint is the point, kept by the same
        guarantee as `path`'s. `seed` makes the choice repeatable (None: the service's choice).

        The walker is a MoverSpec with `near` given, or a registered mover's id with `near` None (it
        wanders from where it stands). Raises as `path` does; `keep_asking` and `timeout` as `path`'s."""
        _check_walker(walker, near, "random_point")
        spec = walker if isinstance(walker, MoverSpec) else None
        item = write_query("random_point", mover=spec, id=None if spec is not None else walker, near=near, radius=radius,
                           seed=seed, budget=budget, avoid_movers=True if avoid_movers else None)
        mover_id = None if isinstance(walker, MoverSpec) else walker
        return self._ask_one("random_point", self._start_landblock(walker, near), item, mover_id, timeout, keep_asking)

    def follow(self, mover_id: int, waypoints: Sequence[Position], *, timeout: float | None = None) -> Followed:
        """Walk registered mover `mover_id`, standing at `waypoints[0]`, along a path's waypoints, as the
        path's guarantee says (docs/protocol.md, "Paths"): toward each waypoint in turn, moves of at most
        3 m straight at it (the last aimed exactly at it), each from where the mover stands and in the
        frame of its cell, until within 0.25 m, at most ceil(leg / 3) + 3 moves a leg. A leg that does not
        arrive stops the walk (the world changed since the path was asked: a mover in the way, a landblock
        unloaded): `Followed.reached` says how far it got. Each move is a `Client.move`, published as any
        other; the client library's own moves, so the mover's `seq` counts them.

        Raises as `move` does (ServiceError, NoServiceError, RequestTimeout); `timeout` is per move."""
        state = self.get(mover_id, timeout=timeout)[0]
        moves = 0
        for reached, waypoint in enumerate(waypoints[1:]):
            here = state.position
            for _ in range(math.ceil(here.get_offset(waypoint).length() / STRIDE) + 3):
                offset = here.get_offset(waypoint)
                distance = offset.length()
                if distance <= ARRIVAL:
                    break
                step = offset if distance <= STRIDE else offset * (STRIDE / distance)
                state = self.move(mover_id, Position(here.cell_id, here.frame.with_origin(here.frame.origin + step)),
                             timeout=timeout)
                moves += 1
                here = state.position
            if here.get_offset(waypoint).length() > ARRIVAL:
                return Followed(reached, moves, state)
        return Followed(max(0, len(waypoints) - 1), moves, state)
