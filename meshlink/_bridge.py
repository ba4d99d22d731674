"""The anyio <-> Zenoh bridge: every crossing between Zenoh's threads and the event loop.

asyncio is the supported backend (anyio on asyncio): the loop hand-off below uses the asyncio
loop's ``call_soon_threadsafe``; there is no trio path.

Zenoh-python has no async API. Its calls are short synchronous Rust calls that release the GIL
and are made directly on the loop, except those that may wait for the network: opening and
closing a session go through ``anyio.to_thread``; publications and queries go through the
mesh's sender thread (``meshlink._sender``, :attr:`LoopPort.send_off`), since both wait while
the session's send queue is full (a congested link, a stalled subscriber).
What Zenoh *delivers* (replies, queries, samples, drop notifications) arrives on other threads
through ``zenoh.handlers.Callback``; each callback here only appends to a list or deque and, at
most, schedules one wake-up of the loop:

* replies of a ``get``: ``indirect=False``, on Zenoh's thread with the GIL held (the default
  ``indirect=True`` would start a Python thread per call);
* queries and samples: ``indirect=True``, one Python thread per declaration that Zenoh feeds
  through a Rust channel, so Zenoh's network thread does not take the GIL for every sample
  (see docs/benchmarks.md, section Transport (meshlink)).

Loop hand-off (:class:`LoopPort`): ``anyio.lowlevel.current_token()`` is taken when the mesh
opens and work is handed over with the asyncio loop's non-blocking
``loop.call_soon_threadsafe``. ``anyio.from_thread.run_sync`` would block Zenoh's thread until
the loop ran the call, so it is not used. A hand-off after the loop finished is ignored, never
raised into Zenoh's thread. Coalescing (:class:`Inbox`): at most one wake-up is scheduled until
the consumer drains the deque, instead of one ``call_soon_threadsafe`` per sample.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import threading
from collections import deque
from collections.abc import Awaitable, Callable, Iterator
from contextlib import contextmanager
from typing import Any, Generic, Protocol, TypeVar, cast

import anyio
import anyio.abc
import anyio.lowlevel
import zenoh

from ._config import zenoh_message
from ._errors import SessionError
from ._messages import SubscriptionStatistics

__all__ = [
    "Counter",
    "Inbox",
    "LoopPort",
    "Undeclarable",
    "call0",
    "close_session",
    "drop_query",
    "open_session",
    "run_query",
    "sample_inbox",
    "serve",
    "sync_with_router",
    "undeclare",
]

T = TypeVar("T")


class Undeclarable(Protocol):
    """A declared Zenoh entity (subscriber, queryable, ...)."""

    def undeclare(self) -> Any: ...


_YIELD_EVERY = 64  # a consumer that never waits still yields to the loop this often
_TIMEOUT_GRACE = 1.0  # seconds past Zenoh's own query timeout before we cancel the query


def call0(method: object) -> None:
    """Call a no-argument Zenoh method whose stub has no annotations (``close``, ``drop``,
    ``undeclare``, ``cancel``): mypy --strict rejects calling it directly (no-untyped-call)."""
    cast("Callable[[], object]", method)()


class LoopPort:
    """Non-blocking hand-off from any thread into the asyncio event loop that built this object.

    Build it inside the loop (needs a running anyio loop on asyncio); call :meth:`call_soon`
    anywhere. anyio's own ``AsyncBackend.run_sync_soon`` is newer than the anyio 4.11 this
    project supports, and copies a context per call.

    Raises:
        RuntimeError: the running loop is not asyncio (the only supported backend).
    """

    __slots__ = ("_call", "send_off")

    def __init__(self, send_off: Callable[[Callable[[], object]], None] | None = None) -> None:
        native = anyio.lowlevel.current_token().native_token
        if not isinstance(native, asyncio.AbstractEventLoop):
            raise RuntimeError("meshlink runs on anyio's asyncio backend only")
        self._call: Callable[[Callable[[], object]], object] = native.call_soon_threadsafe
        self.send_off: Callable[[Callable[[], object]], None] = send_off or _call_here
        """How a Zenoh call that may wait for the network leaves the loop: the mesh's sender
        (:meth:`meshlink._sender.Sender.submit`), which makes it in order with the
        publications; without one, the call is made at once."""

    def call_soon(self, fn: Callable[[], object]) -> bool:
        """Schedule ``fn()`` in the loop; never blocks. False if the loop has finished."""
        try:
            self._call(fn)
        except RuntimeError:  # the loop is closed
            return False
        return True


def _call_here(op: Callable[[], object]) -> None:
    op()


class Counter:
    """A counter changed from Zenoh threads and the loop."""

    __slots__ = ("_lock", "value")

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.value = 0

    def add(self, n: int) -> None:
        with self._lock:
            self.value += n


class Inbox(Generic[T]):
    """A coalescing queue from producer threads into one consumer task of the loop.

    :meth:`push` and :meth:`end` may be called from any thread and never block; everything else
    runs in the loop. ``schedule`` hands a callable to the loop (:meth:`LoopPort.call_soon`)
    and returns False when the loop is gone. Unbounded: :meth:`statistics` shows the backlog.
    """

    def __init__(self, schedule: Callable[[Callable[[], object]], bool]) -> None:
        self._schedule = schedule
        self._items: deque[T] = deque()
        self._lock = threading.Lock()
        self._armed = False  # a wake-up is scheduled and the consumer has not drained since
        self._closed = False  # no more pushes accepted
        self._waiter: anyio.Event | None = None
        self._received = 0
        self._max_backlog = 0
        self._since_yield = 0

    def push(self, item: T) -> bool:
        """Append ``item`` (any thread). False, with ``item`` not kept, if the inbox is closed
        or the loop has finished: the caller then disposes of it."""
        with self._lock:
            if self._closed:
                return False
            items = self._items
            items.append(item)
            self._received += 1
            self._max_backlog = max(self._max_backlog, len(items))
            if not self._armed:
                self._armed = True
                if not self._schedule(self._wake):
                    items.pop()
                    self._closed = True
                    return False
        return True

    def end(self) -> None:
        """No more items will come (any thread, e.g. Zenoh's drop callback): the consumer
        gets the remaining items, then ``anyio.EndOfStream``."""
        with self._lock:
            self._closed = True
            if not self._armed:
                self._armed = True
                self._schedule(self._wake)

    def close(self) -> list[T]:
        """Stop accepting items and return those not received yet (loop only)."""
        with self._lock:
            self._closed = True
            rest = list(self._items)
            self._items.clear()
        self._wake()
        return rest

    def _wake(self) -> None:
        waiter, self._waiter = self._waiter, None
        if waiter is not None:
            waiter.set()

    def receive_nowait(self) -> T:
        """The next item (loop only). Raises ``anyio.WouldBlock`` if there is none yet,
        ``anyio.EndOfStream`` once the inbox is closed and drained."""
        try:
            return self._items.popleft()
        except IndexError:
            pass
        with self._lock:
            if self._items:
                return self._items.popleft()
            self._armed = False  # drained: the next push schedules a wake-up
            if self._closed:
                raise anyio.EndOfStream from None
        raise anyio.WouldBlock

    async def receive(self) -> T:
        """Wait for the next item (loop only); ``anyio.EndOfStream`` once closed and drained.

        Not a checkpoint on every call: while items are waiting it yields to the loop (and
        notices cancellation) once per 64 items, which keeps most of the throughput a
        checkpoint per item would cost (see docs/benchmarks.md, section Transport
        (meshlink)); it always checkpoints before it waits.
        """
        if self._items and self._since_yield < _YIELD_EVERY:
            self._since_yield += 1
            return self._items.popleft()  # only this task pops: non-empty stays non-empty
        self._since_yield = 0
        await anyio.lowlevel.checkpoint()
        while True:
            try:
                return self.receive_nowait()
            except anyio.WouldBlock:
                waiter = self._waiter = anyio.Event()
                await waiter.wait()

    def statistics(self) -> SubscriptionStatistics:
        """A snapshot: items received, largest backlog, items pending."""
        with self._lock:
            return SubscriptionStatistics(self._received, self._max_backlog, len(self._items))


def _endpoints(zconf: zenoh.Config, key: str, mode: str) -> list[str]:
    value: Any = json.loads(zconf.get_json(key))
    if isinstance(value, dict):
        value = value.get(mode, [])
    return [str(v) for v in value] if isinstance(value, list) else []


async def open_session(zconf: zenoh.Config) -> zenoh.Session:
    """Open a session in a worker thread (a router binds its listeners first).

    Shielded: a cancellation waits for the open to finish, so the caller can always close
    what was opened; deliver it afterwards with a checkpoint inside its ``try``.

    Raises:
        SessionError: Zenoh refused (no router reachable in client mode, port in use, ...).
    """
    mode = str(json.loads(zconf.get_json("mode")) or "peer")
    connect = _endpoints(zconf, "connect/endpoints", mode)
    listen = _endpoints(zconf, "listen/endpoints", mode)
    try:
        with anyio.CancelScope(shield=True):
            session = await anyio.to_thread.run_sync(zenoh.open, zconf)
    except zenoh.ZError as e:
        raise SessionError.cannot_open(mode, connect, listen, zenoh_message(e)) from None
    return session


async def close_session(session: zenoh.Session) -> None:
    """Close ``session`` in a worker thread, shielded from cancellation (never from a Zenoh
    callback: that deadlocks). Undeclares everything the session declared."""
    with anyio.CancelScope(shield=True):
        await anyio.to_thread.run_sync(call0, session.close)


async def run_query(
    session: zenoh.Session,
    selector: str,
    payload: bytes | None,
    *,
    timeout: float,
    target: zenoh.QueryTarget,
    port: LoopPort,
    in_flight: Counter,
    first_only: bool = False,
) -> list[zenoh.Reply]:
    """Send a query and wait, without blocking the loop, until Zenoh finalizes it (its drop
    callback runs: all replies in, or ``timeout``) or, with ``first_only``, the first reply.

    Cancelling the caller cancels the query through a ``zenoh.CancellationToken`` before the
    cancellation propagates; so does returning early. ``token.cancel()`` returns once the
    drop callback has run, so no callback touches the reply list after this returns.

    Raises:
        zenoh.ZError: Zenoh refused the query (the caller translates it).
    """
    replies: list[zenoh.Reply] = []
    finished = anyio.Event()
    done_lock = threading.Lock()
    done = False

    def on_reply(reply: zenoh.Reply) -> None:  # Zenoh thread, GIL held: keep it tiny
        replies.append(reply)
        if first_only and len(replies) == 1:
            port.call_soon(finished.set)

    def on_drop() -> None:  # Zenoh thread, or the loop inside token.cancel()
        nonlocal done
        with done_lock:
            if done:
                return
            done = True
        in_flight.add(-1)
        port.call_soon(finished.set)

    refused: list[zenoh.ZError] = []

    def send() -> None:  # the mesh's sender thread: with the send queue full, get() waits
        try:
            session.get(
                selector,
                zenoh.handlers.Callback(on_reply, on_drop, indirect=False),
                payload=payload,
                timeout=timeout,
                target=target,
                consolidation=zenoh.ConsolidationMode.NONE,  # stream replies, keep duplicates
                cancellation_token=token,
            )
        except zenoh.ZError as e:
            refused.append(e)
            on_drop()

    token = zenoh.CancellationToken()
    in_flight.add(1)
    try:
        port.send_off(send)
        with anyio.move_on_after(timeout + _TIMEOUT_GRACE):
            await finished.wait()
        if refused:
            raise refused[0]
    finally:
        if not done:
            call0(token.cancel)  # blocks only while a reply callback is running
        on_drop()  # no-op if Zenoh called it; balances the counter if it never will
    return list(replies)


async def sync_with_router(session: zenoh.Session, port: LoopPort) -> None:
    """Wait for one query round trip through the router (see docs/benchmarks.md, section
    Transport (meshlink)). The link to the router is ordered, so the router has then processed
    every declaration this session made before: a query or publication sent by any other client
    afterwards reaches a queryable or subscriber just declared. Without it, a request sent
    right after ``serve`` reported started can miss the server.
    The probe key's ``@`` chunk is matched by no wildcard, so no queryable sees it.
    Best effort: gives up silently after 1 s (e.g. an ACL that drops the probe)."""
    await run_query(
        session,
        "@meshlink/sync",
        None,
        timeout=1.0,
        target=zenoh.QueryTarget.ALL,
        port=port,
        in_flight=Counter(),
    )


async def alive_tokens(session: zenoh.Session, key_expr: str, port: LoopPort) -> list[str]:
    """Keys of the liveliness tokens matching ``key_expr`` alive now, sorted.

    A liveliness *get* from a client sometimes answers nothing although the tokens are alive
    (with callback handlers). A liveliness *subscriber with history* always
    receives them: the router sends the current tokens when it processes the declaration, on
    the same ordered link as the later probe reply. The subscriber's callback runs on Zenoh's
    receive thread (``indirect=False``, a set insertion), like the probe's reply, so when the
    probe round trip is over every history sample has been recorded. That order held in all
    but one of thousands of runs (a machine under a load of 8 on 2 cores answered a token's
    own key with nothing): an empty answer is confirmed by a second round trip.
    """
    keys: set[str] = set()

    def on_sample(sample: zenoh.Sample) -> None:  # Zenoh thread, GIL held: keep it tiny
        if sample.kind == zenoh.SampleKind.PUT:
            keys.add(str(sample.key_expr))
        else:
            keys.discard(str(sample.key_expr))

    subscriber = session.liveliness().declare_subscriber(
        key_expr, zenoh.handlers.Callback(on_sample, _nothing, indirect=False), history=True
    )
    try:
        await sync_with_router(session, port)
        if not keys:  # on a loaded host the history has come after the first probe's reply
            await sync_with_router(session, port)
    finally:
        undeclare(subscriber)
    return sorted(keys)


def _nothing() -> None:
    pass


def undeclare(entity: Undeclarable) -> None:
    """Undeclare ``entity``; a no-op once the session is closed."""
    with contextlib.suppress(zenoh.ZError):
        call0(entity.undeclare)


def drop_query(query: zenoh.Query) -> None:
    """Drop ``query``: finalizes it for the querier (ignores an already dropped query)."""
    with contextlib.suppress(zenoh.ZError):
        call0(query.drop)


async def serve(
    session: zenoh.Session,
    key_expr: str,
    answer: Callable[[zenoh.Query], Awaitable[None]],
    *,
    complete: bool,
    max_concurrency: int,
    port: LoopPort,
    task_status: anyio.abc.TaskStatus[None],
) -> None:
    """Declare a queryable and run ``answer(query)`` for each query in its own task (at most
    ``max_concurrency`` at once) until cancelled or the session closes; then undeclare it.
    Every query is dropped when its task ends, and queued ones when serving stops."""
    inbox: Inbox[zenoh.Query] = Inbox(port.call_soon)

    def on_query(query: zenoh.Query) -> None:  # the queryable's own Python thread
        if not inbox.push(query):
            drop_query(query)

    queryable = session.declare_queryable(
        key_expr, zenoh.handlers.Callback(on_query, inbox.end, indirect=True), complete=complete
    )
    limiter = anyio.CapacityLimiter(max_concurrency)

    async def run_one(query: zenoh.Query, borrower: object) -> None:
        try:
            await answer(query)
        finally:
            drop_query(query)  # a query kept alive makes the querier wait for its full timeout
            limiter.release_on_behalf_of(borrower)

    try:
        await sync_with_router(session, port)
        async with anyio.create_task_group() as tg:
            task_status.started()
            while True:
                try:
                    query = await inbox.receive()
                except anyio.EndOfStream:
                    break
                borrower = object()
                try:
                    await limiter.acquire_on_behalf_of(borrower)
                except BaseException:
                    drop_query(query)
                    raise
                tg.start_soon(run_one, query, borrower)
    finally:
        undeclare(queryable)
        for query in inbox.close():
            drop_query(query)


@contextmanager
def sample_inbox(
    declare: Callable[[zenoh.handlers.Callback[zenoh.Sample]], Undeclarable], port: LoopPort
) -> Iterator[Inbox[zenoh.Sample]]:
    """Declare a subscriber (``declare(callback)`` returns it) feeding an :class:`Inbox`;
    undeclare it on exit. The inbox ends when Zenoh drops the subscriber (session closed)."""
    inbox: Inbox[zenoh.Sample] = Inbox(port.call_soon)
    subscriber = declare(zenoh.handlers.Callback(inbox.push, inbox.end, indirect=True))
    try:
        yield inbox
    finally:
        undeclare(subscriber)
        inbox.close()
