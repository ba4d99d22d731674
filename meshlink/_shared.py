"""Shared subscriptions: many short-lived subscriptions to keys under one wildcard, through
one Zenoh subscriber (:class:`SharedSubscribers`, used by ``Mesh.subscribe(key, via=...)``).

Why: a Zenoh router keeps state for every key expression a subscriber was ever declared on
(about 1.9 KB each, measured, never freed), so a subscription per run, per task or per motion
command (``agents/r1/runs/<run>/progress``: a fresh key each time) grows a long-running
router without bound. Subscribing once to ``agents/r1/runs/*/progress`` and sorting the
samples by key in the process costs the router nothing per run: publications on fresh keys
leave no state behind.

The first subscription through a wildcard declares the Zenoh subscriber (and waits one round
trip, so the router knows it); later ones join it at once; the last one to leave undeclares
it. Zenoh's callback thread hands each sample to the inboxes of the subscriptions whose key
expression matches its key (exact keys by a dict lookup).
"""

from __future__ import annotations

import threading
from collections.abc import AsyncIterator, Awaitable, Callable, Iterator
from contextlib import asynccontextmanager, contextmanager
from dataclasses import dataclass, field

import anyio
import zenoh

from . import _bridge as bridge

__all__ = ["SharedSubscribers"]

Declare = Callable[[str, "zenoh.handlers.Callback[zenoh.Sample]"], bridge.Undeclarable]


@dataclass(eq=False)
class _Shared:
    """One Zenoh subscriber on a wildcard and the subscriptions that share it."""

    exact: dict[str, list[bridge.Inbox[zenoh.Sample]]] = field(default_factory=dict)
    patterns: list[tuple[zenoh.KeyExpr, bridge.Inbox[zenoh.Sample]]] = field(default_factory=list)
    users: int = 0
    subscriber: bridge.Undeclarable | None = None
    ready: anyio.Event = field(default_factory=anyio.Event)
    failed: BaseException | None = None


class SharedSubscribers:
    """The shared subscribers of one session (see the module doc); no global state."""

    def __init__(
        self, declare: Declare, sync: Callable[[], Awaitable[None]], port: bridge.LoopPort
    ):
        self._declare, self._sync, self._port = declare, sync, port
        self._lock = threading.Lock()  # guards the listeners read by Zenoh's thread
        self._by_wildcard: dict[str, _Shared] = {}

    @asynccontextmanager
    async def subscribe(self, key_expr: str, via: str) -> AsyncIterator[bridge.Inbox[zenoh.Sample]]:
        """An inbox of the samples on ``key_expr`` (under ``via``) while the block runs.

        Raises:
            ValueError: ``via`` does not include ``key_expr``.
        """
        if not zenoh.KeyExpr(via).includes(zenoh.KeyExpr(key_expr)):
            raise ValueError(
                f"{key_expr!r} is not under {via!r}: subscribe through a wildcard over it"
            )
        shared = self._by_wildcard.get(via)
        if shared is None:
            shared = self._by_wildcard[via] = _Shared()
            shared.users += 1
            try:
                shared.subscriber = self._declare(via, self._callback(shared))
                await self._sync()
            except BaseException as e:
                shared.failed = e
                self._leave(via, shared)
                shared.ready.set()
                raise
            shared.ready.set()
        else:
            shared.users += 1
            await shared.ready.wait()
            if shared.failed is not None:
                self._leave(via, shared)
                raise shared.failed
        inbox: bridge.Inbox[zenoh.Sample] = bridge.Inbox(self._port.call_soon)
        with self._listening(shared, key_expr, inbox):
            try:
                yield inbox
            finally:
                inbox.close()
                self._leave(via, shared)

    @staticmethod
    def _wild(key_expr: str) -> bool:
        return "*" in key_expr or "$" in key_expr

    @contextmanager
    def _listening(
        self, shared: _Shared, key_expr: str, inbox: bridge.Inbox[zenoh.Sample]
    ) -> Iterator[None]:
        wild = self._wild(key_expr)
        with self._lock:
            if wild:
                shared.patterns.append((zenoh.KeyExpr(key_expr), inbox))
            else:
                shared.exact.setdefault(key_expr, []).append(inbox)
        try:
            yield
        finally:
            with self._lock:
                if wild:
                    shared.patterns = [p for p in shared.patterns if p[1] is not inbox]
                else:
                    rest = [i for i in shared.exact.get(key_expr, []) if i is not inbox]
                    if rest:
                        shared.exact[key_expr] = rest
                    else:
                        shared.exact.pop(key_expr, None)

    def _leave(self, via: str, shared: _Shared) -> None:
        shared.users -= 1
        if shared.users == 0:
            if self._by_wildcard.get(via) is shared:
                del self._by_wildcard[via]
            if shared.subscriber is not None:
                bridge.undeclare(shared.subscriber)

    def _callback(self, shared: _Shared) -> zenoh.handlers.Callback[zenoh.Sample]:
        lock = self._lock

        def dispatch(sample: zenoh.Sample) -> None:  # Zenoh's thread
            key = str(sample.key_expr)
            with lock:
                targets = list(shared.exact.get(key, ()))
                targets += [
                    inbox for kexpr, inbox in shared.patterns if kexpr.intersects(sample.key_expr)
                ]
            for inbox in targets:
                inbox.push(sample)

        def dropped() -> None:  # the session closed
            with lock:
                inboxes = [i for lst in shared.exact.values() for i in lst]
                inboxes += [i for _, i in shared.patterns]
            for inbox in inboxes:
                inbox.end()

        return zenoh.handlers.Callback(dispatch, dropped, indirect=True)
