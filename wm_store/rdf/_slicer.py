"""Time-slicing of the SPARQL child, owned by the store: :class:`Slicer`.

While the store serves requests (:meth:`Slicer.serving`, around each request other than
SPARQL), the child running a query is stopped (``SIGSTOP``), and it is continued
(``SIGCONT``) once the store has had none for ``linger`` seconds (a client's next request
usually comes sooner: the child waits through the gaps of a stream of requests, not only
through the requests). The processor's priorities (``nice``, idle scheduling, one core for
the child) leave the store waiting for the child's time slice now and then on a host with few
cores; a stopped child takes none.

The bound: a child stopped for ``max_pause`` seconds in a row is continued for ``min_run``
seconds even while requests keep coming (under a steady stream of requests it runs at least
``min_run / (max_pause + min_run)`` of the time), so a query always progresses. The time a
query was stopped is added to its time limit (:meth:`Slicer.attach` takes the query's cancel
scope): the limit counts the time the child could run.

A child is never left stopped: it is continued when its query ends in any way
(:meth:`Slicer.detach`, called before the child is killed or reused), and the kernel kills it
(``SIGKILL`` ends a stopped process too) when the store's process dies: the child asks for
that at its start (``PR_SET_PDEATHSIG``, see ``_worker.py``).
"""

from __future__ import annotations

import contextlib
import os
import signal
from collections.abc import Callable, Iterator

import anyio

__all__ = ["Slicer"]


class Slicer:
    """Stops the child that runs a query while the store serves requests (see the module
    doc). ``clock`` reads seconds (the event loop's time); ``send`` delivers a signal."""

    def __init__(
        self,
        *,
        max_pause: float = 0.5,
        min_run: float = 0.005,
        linger: float = 0.005,
        clock: Callable[[], float] = anyio.current_time,
        send: Callable[[int, int], None] = os.kill,
    ) -> None:
        self.max_pause, self.min_run, self.linger = max_pause, min_run, linger
        self.clock, self.send = clock, send
        self.serving_now = 0
        """Requests the store is serving now (other than SPARQL)."""
        self.pid: int | None = None
        """The child running a query (None: none to stop)."""
        self.scope: anyio.CancelScope | None = None
        self.stopped_at: float | None = None
        """When the child was stopped (None: it runs)."""
        self.run_until = -float("inf")
        """Till then the child runs whatever comes (its ``min_run`` after a long pause)."""
        self.idle_since = -float("inf")
        """When the store's last request ended."""
        self._changed: anyio.Event | None = None  # wakes pace() (made in the loop)
        self.stopped_total = 0.0
        """Seconds the current query's child was stopped (statistics, tests)."""
        self.pauses = 0
        """How many times a child was stopped (statistics, tests)."""

    # ------------------------------------------------------------------ the query
    def attach(self, pid: int, scope: anyio.CancelScope) -> None:
        """``pid`` runs a query whose time limit is ``scope``'s deadline."""
        self.pid, self.scope, self.stopped_total = pid, scope, 0.0
        self.run_until = -float("inf")
        if self.serving_now:
            self._stop()

    def detach(self) -> None:
        """The query ended (answered, refused, timed out, cancelled): the child runs."""
        self._continue()
        self.pid = self.scope = None

    # ------------------------------------------------------------------ the store's requests
    @contextlib.contextmanager
    def serving(self) -> Iterator[None]:
        """Around one request the store serves: the child is stopped meanwhile (within the
        bound) and continued once no request came for ``linger`` seconds."""
        self.serving_now += 1
        try:
            self._stop()
            yield
        finally:
            self.serving_now -= 1
            if self.serving_now == 0:
                self.idle_since = self.clock()
                if self.linger <= 0:
                    self._continue()
                else:
                    self._wake()

    def tick(self) -> float:
        """Continue a stopped child that is due (the store idle for ``linger``, or the child
        stopped for ``max_pause``: then it runs ``min_run`` whatever comes); returns the
        seconds until the next call is due (:meth:`pace` calls it; inf: none)."""
        if self.stopped_at is None:
            return float("inf")
        now = self.clock()
        if self.serving_now == 0 and now >= self.idle_since + self.linger:
            self._continue()
            return float("inf")
        if now >= self.stopped_at + self.max_pause:
            self._continue()
            self.run_until = now + self.min_run
            return float("inf")
        due = self.stopped_at + self.max_pause
        if self.serving_now == 0:
            due = min(due, self.idle_since + self.linger)
        return due - now

    async def pace(self) -> None:
        """Keep :meth:`tick`'s times while a query runs (run it beside the query; cancel it
        after)."""
        while True:
            self._changed = anyio.Event()
            with anyio.move_on_after(self.tick()):
                await self._changed.wait()

    def _wake(self) -> None:
        if self._changed is not None:
            self._changed.set()

    # ------------------------------------------------------------------ signals
    def _stop(self) -> None:
        if self.pid is None or self.stopped_at is not None or self.clock() < self.run_until:
            return
        try:
            self.send(self.pid, signal.SIGSTOP)
        except OSError:  # already ended: nothing to stop
            return
        self.stopped_at = self.clock()
        self.pauses += 1
        self._wake()

    def _continue(self) -> None:
        if self.stopped_at is None:
            return
        paused = self.clock() - self.stopped_at
        self.stopped_at = None
        self.stopped_total += paused
        if self.scope is not None:
            self.scope.deadline += paused  # the limit counts the time the child could run
        if self.pid is not None:
            with contextlib.suppress(OSError):  # ended meanwhile (killed): nothing to continue
                self.send(self.pid, signal.SIGCONT)
