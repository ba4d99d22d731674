"""The client side: turning an error reply back into the service's exception, by code."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any, NoReturn, TypeVar

from .._errors import RemoteError
from ._wire import UNAVAILABLE, Decoder, ErrorReply, WireError

__all__ = [
    "ErrorFactory",
    "decode_error",
    "error_for",
    "errors_by_code",
    "from_message",
    "raise_for_error",
]

E = TypeVar("E", bound=ErrorReply)

ErrorFactory = Callable[[Any], Exception]
"""Builds a service's exception from an :class:`ErrorReply` (or the service's subclass)."""

_error_decoder: Decoder[ErrorReply] = Decoder(ErrorReply, what="error reply")


def from_message(cls: Callable[[str], Exception]) -> ErrorFactory:
    """The factory that builds ``cls(reply.message)``."""

    def factory(reply: Any) -> Exception:
        return cls(reply.message)

    return factory


def errors_by_code(*classes: type[Exception]) -> dict[str, ErrorFactory]:
    """``{cls.code: from_message(cls)}`` for exception classes carrying a ``code``: the client
    side of :func:`~meshlink.rpc.coded_errors`, so ``except NotFound`` works across the wire."""
    return {getattr(cls, "code"): from_message(cls) for cls in classes}  # noqa: B009


def decode_error(payload: bytes, decoder: Decoder[E] | None = None) -> E | ErrorReply:
    """The :class:`ErrorReply` in an error reply's ``payload``; a payload that is none (plain
    text from a server that stopped before answering, or no RPC server) becomes
    ``ErrorReply(code=UNAVAILABLE, message=<the text>)``. ``decoder``: a service's subclass."""
    try:
        return (decoder or _error_decoder).decode(payload)
    except WireError:
        text = payload.decode("utf-8", errors="replace")
        return ErrorReply(code=UNAVAILABLE, message=text)


def error_for(
    error: ErrorReply | bytes,
    codes: Mapping[str, ErrorFactory],
    *,
    fallback: ErrorFactory | None = None,
    key_expr: str = "",
) -> Exception:
    """The exception for ``error`` (an :class:`ErrorReply`, or an error reply's payload).

    ``codes`` maps a code to a factory taking the reply (e.g. the exception class itself when
    it takes the message: ``lambda r: NotFound(r.message)``); an unmapped code uses
    ``fallback``, or gives a :class:`meshlink.RemoteError` that keeps ``code`` and ``message``.
    """
    reply = decode_error(error) if isinstance(error, bytes) else error
    factory = codes.get(reply.code, fallback)
    if factory is not None:
        return factory(reply)
    return RemoteError(
        error if isinstance(error, bytes) else reply.message.encode(),
        key_expr,
        code=reply.code,
        message=reply.message,
    )


def raise_for_error(
    reply: object,
    codes: Mapping[str, ErrorFactory],
    *,
    fallback: ErrorFactory | None = None,
    key_expr: str = "",
) -> None:
    """Raise :func:`error_for` if ``reply`` is an :class:`ErrorReply`; return otherwise."""
    if isinstance(reply, ErrorReply):
        _raise(error_for(reply, codes, fallback=fallback, key_expr=key_expr))


def _raise(exc: Exception) -> NoReturn:
    raise exc
