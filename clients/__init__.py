"""acphys clients: the Python client library and the `acphys` command line.

    from clients import Client, Move
"""

from clients.aio import AsyncClient
from clients.batch import BatchResults
from clients.client import Client
from clients.errors import AcphysError, BusyError, NoServiceError, RequestTimeout, ServiceError
from clients.query_columns import QueryColumnResults
from clients.spatial import SightQuery
from clients.subscriptions import Subscription
from clients.types import InstanceInfo, Move, MoverState

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
