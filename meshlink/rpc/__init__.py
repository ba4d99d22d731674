"""One RPC layer for every skimesh service: a request/reply queryable speaking MessagePack.

- Wire: :class:`ErrorReply` (tag ``"ErrorReply"`` on ``tag_field="reply"``, the services'
  convention, so it belongs in any service's reply union), the standard codes
  :data:`BAD_REQUEST`, :data:`TOO_LARGE`, :data:`INTERNAL` (and :data:`UNAVAILABLE` on the
  client side), :func:`encode` and :class:`Decoder`, whose every failure is one
  :class:`WireError`.
- Server: :class:`RequestHandler` decodes (with a size limit, default
  :data:`DEFAULT_MAX_REQUEST_BYTES`), dispatches, and answers an :class:`ErrorReply` for
  anything that goes wrong, logging unexpected exceptions; services give their own exceptions'
  codes as data (:func:`coded_errors`).
- Client: :func:`error_for` / :func:`raise_for_error` rebuild the service's exception from a
  code -> factory mapping (:func:`errors_by_code`, :func:`from_message`), falling back to
  :class:`meshlink.RemoteError` (which keeps the code).
"""

from ._client import (
    ErrorFactory,
    decode_error,
    error_for,
    errors_by_code,
    from_message,
    raise_for_error,
)
from ._server import MSGPACK, ErrorMapper, RequestHandler, coded_errors
from ._wire import (
    BAD_REQUEST,
    DEFAULT_MAX_REQUEST_BYTES,
    INTERNAL,
    TOO_LARGE,
    UNAVAILABLE,
    Decoder,
    ErrorReply,
    WireError,
    encode,
)

__all__ = [
    "BAD_REQUEST",
    "DEFAULT_MAX_REQUEST_BYTES",
    "INTERNAL",
    "MSGPACK",
    "TOO_LARGE",
    "UNAVAILABLE",
    "Decoder",
    "ErrorFactory",
    "ErrorMapper",
    "ErrorReply",
    "RequestHandler",
    "WireError",
    "coded_errors",
    "decode_error",
    "encode",
    "error_for",
    "errors_by_code",
    "from_message",
    "raise_for_error",
]
