"""Answering one Zenoh query with a meshlink handler (loop side of :meth:`Mesh.serve
<meshlink.Mesh.serve>`; the queryable, the task per query and the final drop of the query are
in :func:`meshlink._bridge.serve`).

A handler never crashes the server: an exception becomes the error reply
``"<ExceptionType>: <message>"`` (and is logged), and a handler cancelled because the server
stops sends ``"Cancelled: ..."``, so the querier learns at once instead of after its timeout.
"""

from __future__ import annotations

import logging
from collections.abc import Awaitable, Callable, Sequence

import anyio
import zenoh

from ._bridge import Counter
from ._messages import Answer, IncomingQuery

__all__ = ["Handler", "answer_query"]

Handler = Callable[[IncomingQuery], Awaitable[Sequence[Answer]]]
"""A ``serve`` handler: one incoming query in, the answers to send out."""

logger = logging.getLogger(__name__)


def incoming(query: zenoh.Query) -> IncomingQuery:
    """The plain-value view of a Zenoh query."""
    payload = query.payload
    return IncomingQuery(
        key_expr=str(query.key_expr),
        parameters=str(query.parameters),
        payload=None if payload is None else payload.to_bytes(),
    )


def _reply_err(query: zenoh.Query, text: str) -> None:
    try:
        query.reply_err(text.encode("utf-8"))
    except zenoh.ZError:  # the session closed meanwhile: nobody to tell
        logger.debug("could not send an error reply to %s", query.key_expr, exc_info=True)


async def answer_query(query: zenoh.Query, handler: Handler, serving: Counter) -> None:
    """Run ``handler`` for ``query`` and send its answers (``ok=False`` -> error reply).

    Never raises on a handler error (it becomes an error reply); re-raises cancellation after
    telling the querier. Does not drop the query: the caller does, always.
    """
    serving.add(1)
    try:
        try:
            request = incoming(query)
            for answer in await handler(request):
                encoding = answer.encoding or None
                if answer.ok:
                    query.reply(answer.key, answer.payload, encoding=encoding)
                else:
                    query.reply_err(answer.payload, encoding=encoding)
        except anyio.get_cancelled_exc_class():
            _reply_err(query, "Cancelled: the server stopped before answering")
            raise
        except Exception as e:
            logger.exception("serving %s failed", query.key_expr)
            _reply_err(query, f"{type(e).__name__}: {e}")
    finally:
        serving.add(-1)
