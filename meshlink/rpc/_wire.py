"""The RPC wire: the generic :class:`ErrorReply`, the standard error codes, the shared encoder
and :class:`Decoder`, which turns every way bytes can fail to decode into one
:class:`WireError`.

Tag convention: the services tag their reply unions with ``tag_field="reply"`` and the class
name as tag (``tag=True``), so ``{"reply": "ErrorReply", "code": ..., "message": ...}`` is an
error in every service's reply union. A service that needs more fields on its errors subclasses
:class:`ErrorReply` with ``tag="ErrorReply"`` (the same tag) and adds fields with defaults.
"""

from __future__ import annotations

from typing import Any, Final, Generic, TypeVar

import msgspec

from .._errors import MeshlinkError

__all__ = [
    "BAD_REQUEST",
    "DEFAULT_MAX_REQUEST_BYTES",
    "INTERNAL",
    "TOO_LARGE",
    "UNAVAILABLE",
    "Decoder",
    "ErrorReply",
    "WireError",
    "encode",
]

BAD_REQUEST: Final = "bad_request"
"""The request bytes do not decode to a request of the service's schema (undecodable
MessagePack, invalid UTF-8, nesting too deep, unknown tag, wrong field type, empty payload)."""
TOO_LARGE: Final = "too_large"
"""The request is longer than the queryable's limit."""
INTERNAL: Final = "internal"
"""The handler raised an exception the service does not map to a code of its own."""
UNAVAILABLE: Final = "unavailable"
"""Client side only: the error reply is not an :class:`ErrorReply` (the server stopped before
answering, or it is no RPC server)."""

DEFAULT_MAX_REQUEST_BYTES: Final = 16 * 1024 * 1024
"""Size limit of a request when a queryable sets none (16 MiB)."""

SCHEMA_VERSION: Final = 1


class ErrorReply(msgspec.Struct, tag=True, tag_field="reply", frozen=True, kw_only=True):
    """The request was refused; nothing changed. ``code`` is a standard code
    (:data:`BAD_REQUEST`, :data:`TOO_LARGE`, :data:`INTERNAL`) or one of the service's own."""

    code: str
    message: str
    schema_version: int = SCHEMA_VERSION


class WireError(MeshlinkError):
    """Bytes that are no message of the expected schema (``code`` :data:`BAD_REQUEST`), or
    more bytes than allowed (``code`` :data:`TOO_LARGE`). Raised by :meth:`Decoder.decode`."""

    def __init__(self, code: str, message: str) -> None:
        super().__init__(message)
        self.code = code


_encoder = msgspec.msgpack.Encoder()

T = TypeVar("T")


def encode(message: object) -> bytes:
    """Encode a wire Struct (or any msgspec-encodable value) to MessagePack."""
    return _encoder.encode(message)


class Decoder(Generic[T]):
    """A MessagePack decoder for ``type_`` (a Struct or a tagged union), built once.

    ``max_bytes`` (optional) refuses longer payloads before decoding. ``what`` names the
    message in error texts ("request", "reply", ...). Thread-safe, like msgspec's decoders.
    """

    __slots__ = ("_decoder", "max_bytes", "what")

    def __init__(self, type_: Any, *, max_bytes: int | None = None, what: str = "message") -> None:
        self._decoder: msgspec.msgpack.Decoder[Any] = msgspec.msgpack.Decoder(type_)
        self.max_bytes = max_bytes
        self.what = what

    def decode(self, data: bytes) -> T:
        """The message in ``data``.

        Raises:
            WireError: ``code`` :data:`TOO_LARGE` if ``data`` exceeds ``max_bytes``, else
                :data:`BAD_REQUEST` for anything that is not a valid message (msgspec's
                DecodeError and ValidationError, UnicodeDecodeError from invalid UTF-8 in a
                string, RecursionError from nesting too deep).
        """
        if self.max_bytes is not None and len(data) > self.max_bytes:
            raise WireError(
                TOO_LARGE,
                f"{self.what} of {len(data)} bytes exceeds the limit of {self.max_bytes} bytes",
            )
        try:
            value: T = self._decoder.decode(data)
        except msgspec.MsgspecError as exc:  # DecodeError, ValidationError
            raise WireError(BAD_REQUEST, f"malformed {self.what}: {exc}") from None
        except UnicodeDecodeError as exc:
            raise WireError(BAD_REQUEST, f"malformed {self.what}: invalid UTF-8: {exc}") from None
        except RecursionError:
            raise WireError(BAD_REQUEST, f"malformed {self.what}: nested too deeply") from None
        return value
