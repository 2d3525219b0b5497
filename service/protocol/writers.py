"""Writing the queries onto the wire: the service writes answers, the client writes requests.

Both work from the declarations of service/protocol/queries.py, so what one side writes the other reads.
"""

from __future__ import annotations

from typing import Any

from service.protocol.answers import IdMap
from service.protocol.queries import QUERIES

__all__ = ["write_answer", "write_query"]


def _same(object_id: int) -> int:
    return object_id


def write_answer(op: str, answer: Any, blocker_id: IdMap = _same) -> Any:
    """The wire form of an answer of `op` (the engine's result), object ids through `blocker_id`."""
    kind = QUERIES[op]
    if answer is None and kind.nullable:
        return None
    return {o.name: o.kind.write(getattr(answer, o.name), blocker_id) for o in kind.answer}


def write_query(op: str, **values: Any) -> dict[str, Any]:
    """One query of `op` as its wire map, from its fields' values by wire name (`from_` for `from`, a
    Python keyword); a value of None is left out, as the wire's optional fields may be."""
    kind = QUERIES[op]
    given = {name.rstrip("_"): value for name, value in values.items()}
    names = {f.name: f for f in kind.fields}
    unknown = sorted(set(given) - set(names))
    if unknown:
        raise TypeError(f"{op} has no field {', '.join(unknown)} (its fields: {', '.join(names)})")
    return {name: names[name].kind.write(value) for name, value in given.items() if value is not None}
