"""Errors of the transport layer. Everything ``meshlink`` raises on purpose derives from
:class:`MeshlinkError`, so callers can catch the package as a whole.

Hierarchy::

    MeshlinkError
    ├── ConfigError        a MeshConfig, an endpoint or a Zenoh config file is invalid (ValueError)
    ├── SessionError       a session cannot be opened (no router reachable, port taken) or is closed
    ├── InvalidKeyError    a name segment or key expression is not allowed (ValueError)
    ├── NoReplyError       a request got no reply in time (server down, or denied by an ACL)
    └── RemoteError        the server answered with an error reply (carries its payload)

Messages say what to do where that is known.
"""

from __future__ import annotations

from collections.abc import Sequence

__all__ = [
    "ConfigError",
    "InvalidKeyError",
    "MeshlinkError",
    "NoReplyError",
    "RemoteError",
    "SessionError",
]


class MeshlinkError(Exception):
    """Root of every error raised on purpose by :mod:`meshlink`."""


class ConfigError(MeshlinkError, ValueError):
    """A :class:`~meshlink.MeshConfig`, an endpoint string or a Zenoh config file is
    invalid. Raised before any network activity."""


class SessionError(MeshlinkError):
    """A Zenoh session cannot be opened, or was used after it closed.

    ``endpoints`` lists the endpoints that were tried (connect endpoints for clients and peers,
    listen endpoints for routers).
    """

    def __init__(self, message: str, *, endpoints: Sequence[str] = ()) -> None:
        super().__init__(message)
        self.endpoints: tuple[str, ...] = tuple(endpoints)

    @classmethod
    def cannot_open(
        cls, mode: str, connect: Sequence[str], listen: Sequence[str], cause: str
    ) -> SessionError:
        """The error for a failed ``zenoh.open``: names the endpoints and the way out."""
        if mode == "router":
            return cls(
                f"cannot start a Zenoh router listening on {', '.join(listen) or '(nothing)'}: "
                f"{cause}. Is another router (or another program) using that port? "
                "Pick a free one with --listen ENDPOINT.",
                endpoints=listen,
            )
        tried = ", ".join(connect) or "(no connect endpoints)"
        return cls(
            f"cannot open a Zenoh session in {mode} mode; tried {tried}: {cause}. "
            "Start a router with `skimesh router` (or point --connect ENDPOINT at the "
            "router you use); if it runs, it may have refused this client's user/password "
            "or certificate.",
            endpoints=connect,
        )


class InvalidKeyError(MeshlinkError, ValueError):
    """A name segment (mesh, agent, run, robot, device, element or task id) or a key
    expression contains a character that is not allowed, or is empty."""


class NoReplyError(MeshlinkError):
    """A request that needs a reply got none within ``timeout`` seconds.

    Zenoh gives no error in two common cases, so this error names both: nobody serves the key
    (the server is not running or uses another mesh name), or a router ACL denied the query
    (denied queries are dropped silently).
    """

    def __init__(self, key_expr: str, timeout: float, *, waited: float | None = None) -> None:
        if waited is None or waited >= timeout * 0.9:
            when = f"within {timeout:g} s"
        else:  # Zenoh ends a query at once when no server is routed for it
            when = f"(the query ended after {waited:.1f} s: no server answers this key)"
        super().__init__(
            f"no reply from {key_expr!r} {when}: is the server for this key running and on "
            "the same mesh? A router ACL that denies the query also looks like this (Zenoh "
            "drops denied queries silently)."
        )
        self.key_expr = key_expr
        self.timeout = timeout
        self.waited = timeout if waited is None else waited
        self.when = when
        """The time really waited, for messages: ``within 5 s``, or ``(the query ended after
        0.3 s: ...)`` when Zenoh gave up before the limit."""


class RemoteError(MeshlinkError):
    """The server answered with an error reply. ``payload`` holds its bytes unchanged (a
    meshlink server sends ``"<ExceptionType>: <message>"`` in UTF-8 when its handler raised);
    ``key_expr`` is the key that was queried. Built by :func:`meshlink.rpc.error_for` for a
    code the service does not map: ``code`` and ``message`` are then the
    :class:`~meshlink.rpc.ErrorReply`'s (else ``""`` and the payload as text)."""

    def __init__(
        self, payload: bytes, key_expr: str = "", *, code: str = "", message: str | None = None
    ) -> None:
        text = payload.decode("utf-8", errors="replace") if message is None else message
        where = f" from {key_expr!r}" if key_expr else ""
        shown = f"[{code}] {text}" if code else text
        super().__init__(f"error reply{where}: {shown}")
        self.payload = payload
        self.key_expr = key_expr
        self.code = code
        self.message = text
