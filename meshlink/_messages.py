"""Plain values that cross the meshlink API: replies, samples, queries, answers, liveliness
events and statistics snapshots. Frozen msgspec Structs with no Zenoh objects inside, so they
can be kept, compared and sent across threads freely.
"""

from __future__ import annotations

from typing import Literal

import msgspec

__all__ = [
    "Answer",
    "IncomingQuery",
    "Liveness",
    "MeshStatistics",
    "Reply",
    "Sample",
    "SubscriptionStatistics",
]


class Reply(msgspec.Struct, frozen=True):
    """One reply to :meth:`Mesh.get <meshlink.Mesh.get>`.

    ``ok=False`` is an error reply; its ``key`` is then the queried key expression (Zenoh error
    replies carry no key) and ``payload`` the error bytes.
    """

    key: str
    payload: bytes
    ok: bool


class Sample(msgspec.Struct, frozen=True):
    """One publication received by a subscription. ``timestamp`` is Zenoh's
    ``<ntp64>/<id>`` text when the publisher's router or session timestamps samples."""

    key: str
    payload: bytes
    kind: Literal["put", "delete"]
    timestamp: str | None = None


class IncomingQuery(msgspec.Struct, frozen=True):
    """A query as a handler of :meth:`Mesh.serve <meshlink.Mesh.serve>` sees it.

    ``key_expr`` is the key expression the querier asked for (it may hold wildcards when the
    served key does); ``parameters`` the selector parameters after ``?`` (``"a=1;b=2"``).
    """

    key_expr: str
    parameters: str
    payload: bytes | None


class Answer(msgspec.Struct, frozen=True):
    """One answer of a handler. ``ok=False`` sends an error reply (``key`` is then unused);
    ``key`` must intersect the query's key expression. ``encoding`` is a Zenoh encoding string
    such as ``"application/msgpack"``; empty means none. The error payload ``b"Timeout"`` is
    reserved: it is what Zenoh itself sends when a query times out, and clients drop it."""

    key: str
    payload: bytes
    ok: bool = True
    encoding: str = ""


class Liveness(msgspec.Struct, frozen=True):
    """A liveliness token appeared (``alive=True``) or disappeared (``alive=False``).

    Tokens also disappear all at once when the router is lost: treat that as "state unknown",
    not "all dead"."""

    key: str
    alive: bool


class SubscriptionStatistics(msgspec.Struct, frozen=True):
    """Snapshot of a subscription inbox: items ``received`` from Zenoh so far, the largest
    backlog seen (``max_backlog``) and the items waiting now (``pending``)."""

    received: int
    max_backlog: int
    pending: int


class MeshStatistics(msgspec.Struct, frozen=True):
    """Snapshot of one :class:`~meshlink.Mesh`: ``gets_in_flight`` counts Zenoh queries this
    session issued that Zenoh has not finalized yet (their drop callback has not run);
    ``queries_being_served`` the incoming queries held by ``serve`` handlers right now;
    ``publications_pending`` the publications queued on the mesh's sender, not sent yet."""

    gets_in_flight: int
    queries_being_served: int
    publications_pending: int = 0
