"""Declared entities held by the caller: :class:`MeshPublisher` and :class:`MeshToken`.

Both are synchronous context managers. A publisher's ``put``, ``delete`` and ``undeclare`` never
block: they are queued on the mesh's sender (``meshlink._sender``), whose thread makes the Zenoh
calls in order, so a full send queue (BLOCK congestion control) holds that thread, not the
event loop.
"""

from __future__ import annotations

from collections.abc import Callable
from types import TracebackType
from typing import Self

import zenoh

from ._bridge import undeclare
from ._errors import SessionError
from ._sender import Latest, Sender

__all__ = ["MeshPublisher", "MeshToken"]


class MeshPublisher:
    """A reliable publisher on one key.

    By default congestion control is BLOCK: nothing is dropped (changes, commands, events);
    samples wait in the mesh's sender queue while the link is congested. With ``latest_only``
    it is DROP: for periodic state where the newest sample supersedes the others, at most one
    sample waits in the queue (a newer one replaces it) and a full send queue drops a sample.

    :meth:`put` / :meth:`delete` raise :class:`~meshlink.SessionError` once undeclared or once
    the mesh closed.
    """

    def __init__(
        self,
        session: zenoh.Session,
        key_expr: str,
        *,
        latest_only: bool = False,
        sender: Sender | None = None,
    ) -> None:
        congestion = zenoh.CongestionControl.DROP if latest_only else zenoh.CongestionControl.BLOCK
        self._publisher: zenoh.Publisher | None = session.declare_publisher(
            key_expr, congestion_control=congestion, reliability=zenoh.Reliability.RELIABLE
        )
        self._session = session
        self._sender = sender or Sender()
        self.key_expr = key_expr
        self.latest_only = latest_only
        self._latest: Latest | None = (
            Latest(self._send_to(self._publisher)) if latest_only else None
        )

    def put(self, payload: bytes, *, encoding: str = "") -> None:
        """Queue ``payload`` for publication; returns at once (see the class docstring)."""
        publisher = self._declared()
        if self._latest is not None:
            self._sender.submit_latest(self._latest, payload, encoding)
        else:
            self._sender.submit(lambda: publisher.put(payload, encoding=encoding or None))

    @staticmethod
    def _send_to(publisher: zenoh.Publisher) -> Callable[[bytes, str], object]:
        def send(payload: bytes, encoding: str) -> None:
            publisher.put(payload, encoding=encoding or None)

        return send

    def delete(self) -> None:
        """Queue a delete sample for this key."""
        publisher = self._declared()
        if self._latest is not None:
            self._latest = Latest(self._send_to(publisher))  # later samples queue after it
        self._sender.submit(publisher.delete)

    def undeclare(self) -> None:
        """Undeclare the publisher (idempotent), once its queued samples are sent."""
        publisher, self._publisher = self._publisher, None
        if publisher is None:
            return
        try:
            self._sender.submit(lambda: undeclare(publisher))
        except SessionError:  # the mesh closed: the session undeclares everything
            undeclare(publisher)

    def _declared(self) -> zenoh.Publisher:
        if self._publisher is None:
            raise SessionError(f"the publisher on {self.key_expr!r} was undeclared")
        if self._session.is_closed():
            raise SessionError(f"the mesh session is closed (publishing on {self.key_expr!r})")
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
