"""acphys clients: the Python client library and the `acphys` command line.

    from clients import Client, Move
"""

from .aio import AsyncClient
from .batch import BatchResults
from .client import Client, Subscription
from .errors import AcphysError, BusyError, NoServiceError, RequestTimeout, ServiceError
from .query_columns import QueryColumnResults
from .spatial import SightQuery
from .types import InstanceInfo, Move, MoverState

__all__ = [
    "AcphysError",
    "AsyncClient",
    "BatchResults",
    "BusyError",
    "Client",
    "InstanceInfo",
    "Move",
    "MoverState",
    "NoServiceError",
    "QueryColumnResults",
    "RequestTimeout",
    "ServiceError",
    "SightQuery",
    "Subscription",
]
