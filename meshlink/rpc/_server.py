"""The server side of an RPC queryable: :class:`RequestHandler` decodes a request, runs the
service's dispatch, and encodes the reply or an :class:`~meshlink.rpc.ErrorReply`. It never
raises an ``Exception`` and never answers plain text.
"""

from __future__ import annotations

import logging
from collections.abc import Awaitable, Callable, Sequence
from typing import Any, Generic, TypeVar

from .._messages import Answer, IncomingQuery
from .._serving import Handler
from ._wire import (
    BAD_REQUEST,
    DEFAULT_MAX_REQUEST_BYTES,
    INTERNAL,
    Decoder,
    ErrorReply,
    WireError,
    encode,
)

__all__ = ["ErrorMapper", "RequestHandler", "coded_errors"]

_log = logging.getLogger(__name__)

Req = TypeVar("Req")
Rep = TypeVar("Rep")

ErrorMapper = Callable[[Exception], ErrorReply | None]
"""A service's mapping of its own exceptions to error replies; ``None``: not one of them (the
handler then answers :data:`~meshlink.rpc.INTERNAL` and logs the exception)."""

MSGPACK = "application/msgpack"


def coded_errors(
    *roots: type[Exception], bad_request: tuple[type[Exception], ...] = ()
) -> ErrorMapper:
    """The usual :data:`ErrorMapper`: an exception derived from one of ``roots`` answers with
    its ``code`` attribute and ``str(exc)``; one of ``bad_request`` (e.g. ``ValueError`` from a
    name that is no key segment) answers :data:`~meshlink.rpc.BAD_REQUEST`."""

    def to_reply(exc: Exception) -> ErrorReply | None:
        if isinstance(exc, roots):
            return ErrorReply(code=str(getattr(exc, "code", INTERNAL)), message=str(exc))
        if isinstance(exc, bad_request):
            return ErrorReply(code=BAD_REQUEST, message=f"{type(exc).__name__}: {exc}")
        return None

    return to_reply


def _no_known_errors(exc: Exception) -> ErrorReply | None:
    return None


class RequestHandler(Generic[Req, Rep]):
    """One RPC queryable: ``bytes -> request -> dispatch(request) -> reply -> bytes``.

    Args:
        request_type: the request Struct or tagged union the queryable accepts.
        dispatch: the service's answer to a decoded request. It may return an
            :class:`ErrorReply` (sent as an error reply) or raise.
        errors: the service's exceptions -> error replies (:func:`coded_errors`); an exception
            it does not map answers :data:`~meshlink.rpc.INTERNAL`, logged with its traceback.
        max_request_bytes: longer requests answer :data:`~meshlink.rpc.TOO_LARGE` undecoded.
        empty: the request an empty payload stands for (e.g. ``ListSkills()``); ``None``: an
            empty payload is malformed like any other.
        error_type: the ErrorReply class to build standard errors with (a service subclass).
        name: what the log calls this queryable.

    Malformed bytes of any kind (see :meth:`~meshlink.rpc.Decoder.decode`) answer
    :data:`~meshlink.rpc.BAD_REQUEST`. Cancellation is never caught.
    """

    def __init__(
        self,
        request_type: Any,
        dispatch: Callable[[Req], Awaitable[Rep | ErrorReply]],
        *,
        errors: ErrorMapper = _no_known_errors,
        max_request_bytes: int = DEFAULT_MAX_REQUEST_BYTES,
        empty: Req | None = None,
        error_type: type[ErrorReply] = ErrorReply,
        name: str = "rpc",
    ) -> None:
        self.decoder: Decoder[Req] = Decoder(
            request_type, max_bytes=max_request_bytes, what="request"
        )
        self.dispatch = dispatch
        self.errors = errors
        self.empty = empty
        self.error_type = error_type
        self.name = name

    async def handle_bytes(self, data: bytes) -> tuple[bytes, bool]:
        """Answer one request payload: ``(reply bytes, ok)``; ``ok`` is False for an
        :class:`ErrorReply`. Never raises an ``Exception``."""
        reply = await self.handle_payload(data)
        try:
            return encode(reply), not isinstance(reply, ErrorReply)
        except Exception as exc:  # a reply the service built wrongly (unencodable value)
            _log.exception("%s: cannot encode the reply %s", self.name, type(reply).__name__)
            return encode(self._error(INTERNAL, f"unencodable reply: {exc}")), False

    async def handle_payload(self, data: bytes) -> Rep | ErrorReply:
        """Like :meth:`handle_bytes`, before encoding (for in-process transports)."""
        request: Req
        if not data and self.empty is not None:
            request = self.empty
        else:
            try:
                request = self.decoder.decode(data)
            except WireError as exc:
                return self._error(exc.code, str(exc))
        try:
            return await self.dispatch(request)
        except Exception as exc:
            try:
                known = self.errors(exc)
            except Exception:  # a broken mapper must not break the reply
                _log.exception("%s: the error mapper failed", self.name)
                known = None
            if known is not None:
                return known
            _log.exception("%s: request %s failed", self.name, type(request).__name__)
            return self._error(INTERNAL, f"{type(exc).__name__}: {exc}")

    def _error(self, code: str, message: str) -> ErrorReply:
        return self.error_type(code=code, message=message)

    def serve_on(self, key: str, *, encoding: str = MSGPACK) -> Handler:
        """A :meth:`Mesh.serve <meshlink.Mesh.serve>` handler answering on ``key`` (an error
        as a Zenoh error reply)."""

        async def handler(query: IncomingQuery) -> Sequence[Answer]:
            data, ok = await self.handle_bytes(query.payload or b"")
            return [Answer(key=key, payload=data, ok=ok, encoding=encoding)]

        return handler
