"""How a :class:`~mujoco_sim.SimWorld` in fast mode hands the simulation over to the event loop.

``fast`` runs batches back to back in one thread call (a *run*) that returns only when a job
that reports progress advanced, when :meth:`SimWorld.call` waits, when the world is stopped,
and after ``fast_handover`` wall seconds at most. Meanwhile the simulation thread hands the
loop two kinds of news:

- **events**: a job finished, or a :meth:`SimWorld.wait_time` alarm came due. Each is posted
  to the loop at once (through :class:`~mujoco_sim.LoopPost`, with a snapshot of that tick), and
  before the next batch starts the simulation waits until the loop has taken them and let the
  tasks they woke take a step. So whatever the loop does *in reaction to the simulation* starts
  at the next batch boundary, exactly as if the run had returned there: the same ticks,
  however busy the loop (a test checks it bit for bit against one thread call per batch).
- **batch ends** at which nothing happened: the new snapshot is published by reference (one
  attribute store, atomic under the GIL; :attr:`SimWorld.snapshot` reads the newer of it and
  the last one delivered with an event), and the next batch starts at once: no post, no
  wake-up of the loop, no waiting. Readers on the loop see the newest snapshot there is.

What this saves is the loop's wake-up per batch and the simulation's wait for it (the figures
are in docs/benchmarks.md, section Simulation), while the loop still reacts to the simulation
in lock-step. The loop does not step with the simulation between events: a task that polls
the snapshot (rather than awaiting an event or an alarm) sees the simulation go on in steps of
whatever it ran meanwhile, as it would in real time.

Backend: asyncio only (anyio's asyncio backend, as meshlink), since a fast run posts to the
running asyncio loop from the simulation thread.

:class:`FastRun` holds this hand-over; the :class:`~mujoco_sim.SimWorld` owns one and keeps
the device API, the runner's loop and the lifecycle.
"""

from __future__ import annotations

import asyncio
import logging
import threading
from collections.abc import Callable
from functools import partial

import anyio.from_thread

from mujoco_sim._loop_post import LoopPost, loop_post
from mujoco_sim._plant import Batch, Plant
from mujoco_sim._runner_state import LoopState, ThreadState
from mujoco_sim._snapshot import Snapshot
from mujoco_sim.control._job import Job

__all__ = ["FastRun"]

_log = logging.getLogger(__name__)
_ACK_WAIT = 5.0  # wall seconds the simulation thread waits for the loop to take finished jobs


class FastRun:
    """The hand-over of a world's thread calls to the loop (see module doc). ``release``
    (loop) forgets a finished job as waiting; ``ring`` (loop) wakes the alarms due at a
    simulated time."""

    def __init__(
        self,
        plant: Plant,
        on_loop: LoopState,
        in_thread: ThreadState,
        *,
        release: Callable[[Job], None],
        ring: Callable[[float], None],
    ) -> None:
        self._plant = plant
        self._on_loop = on_loop
        self._in_thread = in_thread
        self._release = release
        self._ring = ring
        self._loop: asyncio.AbstractEventLoop | None = None  # the running loop, in a fast run
        self._post: LoopPost | None = None  # how report hands over (see loop_post)

    def batch_runner(
        self, *, fast: bool, fast_handover: float
    ) -> Callable[[int, list[Job]], Batch]:
        """Loop: what one thread call runs: one batch, or in fast mode with a ``fast_handover``
        a fast run of batches back to back, which posts finished jobs and due alarms to the
        loop as they happen (see module doc)."""
        plant = self._plant
        if not (fast and fast_handover > 0):
            return plant.run_batch
        self.attach()
        return partial(
            plant.run_batch,
            inbox=self._on_loop.inbox,
            until=self._between_batches,
            budget=fast_handover,
            report=self.report,
            wake=self.wake,
        )

    def attach(self) -> None:
        """Loop: post to the running loop from now on (a fast run, or a paced run in real
        time: :mod:`mujoco_sim._paced_run`)."""
        self._loop = asyncio.get_running_loop()
        self._post = loop_post(self._loop)

    def post(self, fn: Callable[[], object]) -> None:
        """Simulation thread: run ``fn()`` on the loop soon, in order with the reports."""
        assert self._loop is not None
        if self._post is not None:
            self._post.post(fn)
        else:
            self._loop.call_soon_threadsafe(fn)

    def begin(self, ticks: int) -> None:
        """Loop, before each thread call, of batches of ``ticks``: forget the last call's
        posts and reported alarms."""
        self._in_thread.acks.clear()  # the reactions to those came in at the checkpoint
        self._in_thread.woken.clear()  # the world's completion of the batch rang them
        self._in_thread.batch_ticks = self._in_thread.ticks_left = ticks

    def _between_batches(self, sim_time: float) -> bool:
        """Simulation thread, between the batches of a fast run: wait until the loop has
        dealt with what was reported during the last batch, then say whether the run must
        return: a job reports progress, a :meth:`SimWorld.call` waits, or the world is being
        stopped (a due alarm does not end it: it is reported, see :meth:`wake`)."""
        for ack in self._in_thread.acks:
            if not ack.wait(_ACK_WAIT):
                _log.warning("the event loop took over %g s to take a batch", _ACK_WAIT)
        self._in_thread.acks.clear()
        try:
            anyio.from_thread.check_cancelled()  # the world is being stopped: return now
        except BaseException as exc:  # the backend's cancellation exception
            if isinstance(exc, Exception):
                raise
            return True
        if self._on_loop.reporting > 0 or self._on_loop.calls > 0:
            return True
        # another batch of as many ticks follows
        self._in_thread.ticks_left = self._in_thread.batch_ticks
        return False

    def wake(self, sim_time: float) -> bool:
        """Simulation thread, after each tick of a fast run: whether an alarm not yet reported
        is due (then the plant reports, and :meth:`deliver` rings it). Not after the last
        tick of a batch: the batch's own report, with its snapshot of that very tick, comes
        next and rings it (a second state check, snapshot and post for the same tick would be
        wasted; sleeps that start at a batch boundary end at one)."""
        self._in_thread.ticks_left -= 1
        if sim_time < self._on_loop.next_alarm or self._in_thread.ticks_left <= 0:
            return False
        due = [
            a[1]
            for a in list(self._on_loop.alarms)
            if a[0] <= sim_time and a[1] not in self._in_thread.woken
        ]
        self._in_thread.woken.update(due)
        return bool(due)

    def report(self, finished: list[Job], snapshot: Snapshot) -> None:
        """Simulation thread: hand ``finished`` jobs or a due alarm to the loop now, with
        ``snapshot``; the next batch starts once the loop has taken it and let the tasks it woke
        take a step. The end of a batch at which neither happened is only published (see
        module doc)."""
        if not finished and snapshot.time < self._on_loop.next_alarm:
            self._in_thread.latest = snapshot
            return
        assert self._loop is not None
        ack = threading.Event()
        self._in_thread.acks.append(ack)
        if self._post is not None:
            self._post.post(self.deliver, finished, snapshot, ack)
        else:
            self._loop.call_soon_threadsafe(self.deliver, finished, snapshot, ack)

    def take_posts(self) -> None:
        """Loop, once a thread call has returned: deliver what it posted and the loop has not
        taken yet, before what follows (as ``call_soon_threadsafe`` posts would be)."""
        if self._post is not None:
            self._post.run_pending()

    def deliver(self, finished: list[Job], snapshot: Snapshot, ack: threading.Event) -> None:
        """Loop: wake the waiters of ``finished``; ``ack`` once they have taken a step (the
        callbacks ``call_soon`` queued before it have run, as after a checkpoint)."""
        if snapshot.time >= self._on_loop.snapshot.time:  # (posts are taken in order: always)
            self._on_loop.snapshot = snapshot
        for job in finished:
            self._release(job)
            job.done.set()
        self._ring(snapshot.time)
        assert self._loop is not None
        self._loop.call_soon(ack.set)

    def close(self) -> None:
        """Loop, when the runner ends: deliver what is still posted, then close the post."""
        self.take_posts()
        if self._post is not None:
            self._post.close()
            self._post = None
