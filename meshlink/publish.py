"""Declared entities held by the caller: :class:`MeshPublisher` and :class:`MeshToken`.

Both are synchronous context managers; every call is a short Zenoh call that releases the GIL.
``put`` uses BLOCK congestion control, so it can wait while the session's send queue is full
(that is the back-pressure which keeps a fast burst from being dropped silently; on loopback
the wait is sub-millisecond).
"""

from __future__ import annotations

from collections.abc import Callable
from types import TracebackType
from typing import Self

import zenoh

from .bridge import undeclare
from .errors import SessionError

__all__ = ["MeshPublisher", "MeshToken"]


class MeshPublisher:
    """A reliable publisher on one key.

    By default congestion control is BLOCK: nothing is dropped (changes, commands, events).
    With ``latest_only`` it is DROP: for periodic state where the newest sample supersedes
    the others, a full send queue drops a sample instead of holding the publisher.

    :meth:`put` / :meth:`delete` raise :class:`~meshlink.errors.SessionError` once undeclared
    and ``zenoh.ZError`` after the session closed.
    """

    def __init__(self, session: zenoh.Session, key_expr: str, *, latest_only: bool = False) -> None:
        congestion = zenoh.CongestionControl.DROP if latest_only else zenoh.CongestionControl.BLOCK
        self._publisher: zenoh.Publisher | None = session.declare_publisher(
            key_expr, congestion_control=congestion, reliability=zenoh.Reliability.RELIABLE
        )
        self.key_expr = key_expr
        self.latest_only = latest_only

    def put(self, payload: bytes, *, encoding: str = "") -> None:
        """Publish ``payload``; with BLOCK, may wait while the send queue is full."""
        self._declared().put(payload, encoding=encoding or None)

    def delete(self) -> None:
        """Publish a delete sample for this key."""
        self._declared().delete()

    def undeclare(self) -> None:
        """Undeclare the publisher (idempotent)."""
        publisher, self._publisher = self._publisher, None
        if publisher is not None:
            undeclare(publisher)

    def _declared(self) -> zenoh.Publisher:
        if self._publisher is None:
            raise SessionError(f"the publisher on {self.key_expr!r} was undeclared")
        return self._publisher

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.undeclare()


class MeshToken:
    """A liveliness token: watchers of a matching key see it alive until :meth:`undeclare`
    (or the context exits, or the session closes). Holds the ``zenoh.LivelinessToken``,
    which Zenoh would undeclare as soon as it is garbage-collected."""

    def __init__(
        self, session: zenoh.Session, key_expr: str, forget: Callable[[MeshToken], None]
    ) -> None:
        self._token: zenoh.LivelinessToken | None = session.liveliness().declare_token(key_expr)
        self._forget = forget
        self.key_expr = key_expr

    @property
    def declared(self) -> bool:
        """True until :meth:`undeclare` is called."""
        return self._token is not None

    def undeclare(self) -> None:
        """Undeclare the token (idempotent); watchers see ``alive=False``."""
        token, self._token = self._token, None
        if token is not None:
            self._forget(self)
            undeclare(token)

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.undeclare()
