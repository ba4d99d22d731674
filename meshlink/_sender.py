"""The mesh's sender: publications and queries leave the event loop and go out, in order, from
one worker thread per mesh.

A Zenoh ``put`` with BLOCK congestion control, and a ``get``, wait while the session's send
queue is full (a slow or stalled subscriber, a congested link), up to Zenoh's own block
timeout. Made on the loop, that wait would stop every task of the process. So
:class:`MeshPublisher <meshlink.MeshPublisher>`, :meth:`Mesh.put <meshlink.Mesh.put>` and every
query (:attr:`meshlink._bridge.LoopPort.send_off`) only append to this sender's queue, which
never blocks, and the sender's thread makes the Zenoh calls; a query's replies come back
through its callbacks as before.

Policy:

* order: one FIFO queue per mesh, so publications (puts, deletes, undeclarations) go out in
  the order they were made, per key and across keys;
* reliable publishers (BLOCK) never drop: the backlog is unbounded; it is counted
  (``Mesh.statistics().publications_pending``) and a warning is logged each time it passes
  :data:`WARN_BACKLOG` entries;
* ``latest_only`` publishers (DROP) keep at most one queued sample each: a newer sample
  replaces the queued one (the superseded sample is dropped), in the older one's place;
* close: the queue is drained before the session closes, for at most ``timeout`` seconds.
"""

from __future__ import annotations

import logging
import threading
from collections import deque
from collections.abc import Callable

import anyio
import zenoh

from ._errors import SessionError

__all__ = ["WARN_BACKLOG", "Latest", "Sender"]

_log = logging.getLogger(__name__)

WARN_BACKLOG = 10_000
"""Queued publications above which a warning is logged (once per crossing)."""

Op = Callable[[], object]


class Latest:
    """The queued sample of one ``latest_only`` publisher (at most one at a time)."""

    __slots__ = ("encoding", "payload", "queued", "send")

    def __init__(self, send: Callable[[bytes, str], object]) -> None:
        self.send = send
        self.payload = b""
        self.encoding = ""
        self.queued = False


class Sender:
    """A FIFO of publications sent by one daemon thread, started on first use.

    :meth:`submit` and :meth:`submit_latest` run on the loop and never block; :meth:`aclose`
    drains the queue and stops the thread.
    """

    def __init__(self, name: str = "meshlink-sender") -> None:
        self._name = name
        self._items: deque[Op | Latest] = deque()
        self._lock = threading.Lock()
        self._ready = threading.Condition(self._lock)
        self._thread: threading.Thread | None = None
        self._closed = False
        self._warned = False

    @property
    def pending(self) -> int:
        """Publications and queries queued and not sent yet (the one being sent included)."""
        return len(self._items)

    def submit(self, op: Op) -> None:
        """Queue ``op`` (a Zenoh call) behind every publication queued before.

        Raises:
            SessionError: the mesh is closing or closed.
        """
        with self._lock:
            self._append(op)

    def submit_latest(self, slot: Latest, payload: bytes, encoding: str = "") -> None:
        """Queue ``payload`` for a ``latest_only`` publisher: replaces its queued sample if it
        has one, else queues a new one.

        Raises:
            SessionError: the mesh is closing or closed.
        """
        with self._lock:
            if self._closed:
                raise SessionError("the mesh session is closed")
            slot.payload, slot.encoding = payload, encoding
            if not slot.queued:
                slot.queued = True
                self._append(slot)

    def _append(self, item: Op | Latest) -> None:  # lock held
        if self._closed:
            raise SessionError("the mesh session is closed")
        self._items.append(item)
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name=self._name, daemon=True)
            self._thread.start()
        size = len(self._items)
        if size == 1:
            self._ready.notify()
        elif size > WARN_BACKLOG and not self._warned:
            self._warned = True
            _log.warning(
                "%d publications wait to be sent: the link or a subscriber is congested",
                size,
            )
        elif size < WARN_BACKLOG // 2:
            self._warned = False

    def _run(self) -> None:
        while True:
            with self._lock:
                while not self._items and not self._closed:
                    self._ready.wait()
                if not self._items:
                    return  # closed and drained
                item = self._items[0]
                if isinstance(item, Latest):
                    op: Op = _bind(item.send, item.payload, item.encoding)
                    item.queued = False
                else:
                    op = item
            try:
                op()
            except zenoh.ZError as e:  # the session closed meanwhile: nobody to send to
                _log.debug("publication not sent: %s", e)
            except Exception:
                _log.exception("publication failed")
            with self._lock:
                self._items.popleft()

    def _close(self, timeout: float) -> bool:
        with self._lock:
            self._closed = True
            self._ready.notify()
            thread = self._thread
        if thread is None:
            return True
        thread.join(timeout)
        return not thread.is_alive()

    async def aclose(self, timeout: float = 10.0) -> None:
        """Refuse new publications, wait (in a worker thread, shielded) until the queued ones
        are sent or ``timeout`` seconds passed; then the session may close (which ends any
        send still blocked)."""
        with anyio.CancelScope(shield=True):
            drained = await anyio.to_thread.run_sync(self._close, timeout)
        if not drained:
            _log.warning("%d publications not sent within %g s of closing", self.pending, timeout)


def _bind(send: Callable[[bytes, str], object], payload: bytes, encoding: str) -> Op:
    return lambda: send(payload, encoding)
