"""How a :class:`~mujoco_sim.SimWorld` in real time keeps the wall clock in its own thread.

While something moves, a real-time world runs a tick every 10 ms. Handed through the event
loop, each tick waits for the loop (it sleeps until the tick is due, hands it to a worker
thread and takes the result back), so a loop busy for longer than a tick holds the physics
back. A *paced run* (``WorldOptions.handover`` > 0) is one thread call that runs batches on
the wall clock by itself:

- between batches the simulation thread waits (``time.sleep``) until the next tick is due, or
  runs the ticks already due at once (up to ``max_ticks`` per batch), the same catch-up and
  slip rules as :class:`~mujoco_sim._pacing.RealTimePacing` (it shares that clock);
- each batch starts the commands queued meanwhile (the ``inbox`` deque), so a command starts at
  the next tick boundary;
- finished jobs and due alarms are posted to the loop as they happen, with a snapshot of that
  tick (:meth:`~mujoco_sim._fast_run.FastRun.report`); unlike a fast run, the simulation does
  not wait for the loop to take them: real time does not wait for anyone. Other batch ends are
  only published by reference (:attr:`SimWorld.snapshot` reads the newest);
- a snapshot of the world is published every ``publish`` simulated seconds (40 ms, the rate
  at which the device server publishes states), not every tick: the device states of a
  fleet cost about a millisecond a snapshot. A finished job or a due alarm always comes with
  a snapshot of its own tick, and the run ends with a fresh one;
- progress of running commands is posted at most every ``publish`` s while some command
  reports it, and never twice before the loop has taken the last one (a slow loop gets the
  newest values, not a backlog).

The run returns to the loop when the world turns quiet (nothing moves by command, nothing
queued, no alarm near: the loop's pacing then sleeps until a whole batch is due or news comes),
when a :meth:`SimWorld.call` waits for the model, when the world is being stopped, and after
``budget`` wall seconds at most. Backend: asyncio only, as the fast run.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import anyio.from_thread

from mujoco_sim._fast_run import FastRun
from mujoco_sim._pacing import RealTimePacing
from mujoco_sim._plant import Batch, Plant
from mujoco_sim._runner_state import LoopState, ThreadState
from mujoco_sim.control._job import Job

__all__ = ["PacedRun"]


class PacedRun:
    """One real-time thread call of batches on the wall clock (see module doc). ``progress``
    (loop) reports the running commands' progress; ``hand`` posts finished jobs and alarms."""

    def __init__(
        self,
        plant: Plant,
        on_loop: LoopState,
        in_thread: ThreadState,
        *,
        hand: FastRun,
        pacing: RealTimePacing,
        budget: float,
        publish: float,
        progress: Callable[[], None],
    ) -> None:
        self._plant = plant
        self._on_loop = on_loop
        self._in_thread = in_thread
        self._hand = hand
        self._pacing = pacing
        self._budget = budget
        self._publish = publish
        self._published = -math.inf  # simulated time of the last snapshot or progress post
        self._progress = progress
        self._progress_posted = False  # a progress post the loop has not taken yet

    def __call__(self, ticks: int, jobs: list[Job]) -> Batch:
        """Simulation thread: batches from ``ticks`` with ``jobs``, then as the clock says."""
        plant, inbox, hand = self._plant, self._on_loop.inbox, self._hand
        deadline = time.perf_counter() + self._budget
        total = 0
        while True:
            end = plant.time + ticks * plant.tick_time
            publish = end - self._published >= self._publish - 1e-9
            # unpublished batch ends leave the alarms to wake(), on every tick
            self._in_thread.batch_ticks = ticks
            self._in_thread.ticks_left = ticks + (0 if publish else 1)
            plant.run_batch(ticks, jobs, report=hand.report, wake=hand.wake, publish=publish)
            total += ticks
            self._in_thread.acks.clear()  # nothing waits for the loop in real time
            if publish:
                self._published = plant.time
                if self._on_loop.reporting > 0 and not self._progress_posted:
                    self._progress_posted = True
                    hand.post(self._report_progress)
            if time.perf_counter() >= deadline or self._must_return():
                break
            ticks = self._pacing.wait_in_thread(plant.time)
            if ticks < 1:
                break
            jobs = [inbox.popleft() for _ in range(len(inbox))]
        snapshot = plant.snapshot
        if snapshot.time < plant.time:  # the loop's pacing goes on from the present tick
            snapshot = self._in_thread.latest = plant.take_snapshot()
        return Batch([], snapshot, total, plant.time)

    def _must_return(self) -> bool:
        """Between batches: whether the world is being stopped or a call waits for the model
        (a quiet world is told by :meth:`RealTimePacing.wait_in_thread`)."""
        try:
            anyio.from_thread.check_cancelled()
        except BaseException as exc:  # the backend's cancellation exception
            if isinstance(exc, Exception):
                raise
            return True
        return self._on_loop.calls > 0

    def _report_progress(self) -> None:
        """Loop: the running commands' progress, as each batch end reports it."""
        self._progress_posted = False
        self._progress()
